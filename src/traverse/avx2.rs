//! Running a loop in a copy compiled with AVX2, picked at run time: the one place where a
//! traversal crosses into code built for a CPU feature the baseline lacks.
//!
//! A [`Loop`] is a task whose `run` is inlined into [`run_avx2`], a function compiled with AVX2
//! enabled, so the whole loop gets wider blends and three-operand instructions; [`run_portable`]
//! is the same task compiled for the baseline. Both perform the same IEEE operations in the same
//! order (Rust never fuses a multiply and an add on its own), so they return identical bits; each
//! structure's tests compare the two.
//!
//! Hand-written AVX2 elsewhere (`wide::simd`, `batch::prepare_avx2`, the eight-ray sign filter)
//! takes an [`Avx2`] token (`crate::x86`), which only exists where the CPU has AVX2.

/// Work to run in either copy. `run` must be `#[inline(always)]`, so that it is compiled into
/// the copy that calls it.
pub(crate) trait Loop {
    /// What the loop returns.
    type Output;
    /// Runs the loop.
    fn run(self) -> Self::Output;
}

/// `task` in the AVX2 copy if `wanted` and the CPU has AVX2, else in the baseline copy.
#[inline]
pub(crate) fn run<L: Loop>(task: L, wanted: bool) -> L::Output {
    #[cfg(target_arch = "x86_64")]
    if wanted && std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, the only requirement of `run_avx2`.
        return unsafe { run_avx2(task) };
    }
    let _ = wanted;
    task.run()
}

/// `task` compiled with AVX2 enabled.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_avx2<L: Loop>(task: L) -> L::Output {
    task.run()
}
