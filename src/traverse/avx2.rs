//! Running a loop in a copy compiled with AVX2, picked at run time: the one place where a
//! traversal crosses into code built for a CPU feature the baseline lacks.
//!
//! A [`Loop`] is a task whose `run` is inlined into [`Loop::run_avx2`], compiled with AVX2
//! enabled, so the whole loop gets wider blends and three-operand instructions; [`Loop::run_portable`]
//! is the same task compiled for the baseline. Both perform the same IEEE operations in the same
//! order (Rust never fuses a multiply and an add on its own), so they return identical bits; each
//! structure's tests compare the two.
//!
//! Hand-written AVX2 elsewhere (`wide::simd`, `batch::prepare_avx2`, the eight-ray sign filter)
//! takes an [`Avx2`] token (`crate::x86`), which only exists where the CPU has AVX2.

/// Work to run in either copy. `run` must be `#[inline(always)]`, so that it is compiled into
/// the copy that calls it. Each copy is a provided method, so its instances are compiled with
/// the loop type's module (a codegen unit per kind of loop, which keeps the crate's build
/// parallel) and stay out of line: one function per copy, one call per ray or stream.
pub(crate) trait Loop: Sized {
    /// What the loop returns.
    type Output;
    /// Whether the loop has an AVX2 copy at all: false for loops measured no faster that way
    /// and for diagnostic walks (node counting), which are then compiled once, not twice.
    const AVX2: bool;

    /// Runs the loop.
    fn run(self) -> Self::Output;

    /// The loop compiled for the baseline.
    #[inline(never)]
    fn run_portable(self) -> Self::Output {
        self.run()
    }

    /// The loop compiled with AVX2 enabled.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    unsafe fn run_avx2(self) -> Self::Output {
        self.run()
    }
}

/// `task` in the AVX2 copy if it has one ([`Loop::AVX2`]), `wanted` and the CPU has AVX2, else
/// in the baseline copy.
#[inline]
pub(crate) fn run<L: Loop>(task: L, wanted: bool) -> L::Output {
    #[cfg(target_arch = "x86_64")]
    if L::AVX2 && wanted && std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, the only requirement of `run_avx2`.
        return unsafe { task.run_avx2() };
    }
    let _ = wanted;
    task.run_portable()
}
