//! The 4-wide one-ray loop compiled twice: for the baseline instruction set and with AVX2,
//! picked at run time (as [`crate::traverse::dispatch`] does for the binary trees).
//!
//! With AVX2 (and the VEX encoding it brings) the box test and the triangle kernels need fewer
//! register copies. Both copies perform the same IEEE operations in the same order (Rust never
//! fuses a multiply and an add on its own), so they return identical bits; `wide::tests`
//! compares them.

use super::WideTree;
use super::single;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;

/// [`single::trace`], in the AVX2 copy where the CPU has AVX2.
#[inline]
pub(crate) fn trace<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    ray: &PreparedRay,
    id: u32,
    stack: &mut Vec<(u32, f32)>,
    visitor: &mut V,
) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, the only requirement of `trace_avx2`.
        return unsafe { trace_avx2::<K, V>(tree, ray, id, stack, visitor) };
    }
    trace_portable::<K, V>(tree, ray, id, stack, visitor)
}

/// [`single::trace`] compiled for the baseline instruction set.
pub(crate) fn trace_portable<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    ray: &PreparedRay,
    id: u32,
    stack: &mut Vec<(u32, f32)>,
    visitor: &mut V,
) -> f32 {
    single::trace::<K, V>(tree, ray, id, stack, visitor)
}

/// [`single::trace`] compiled with AVX2 enabled.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn trace_avx2<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    ray: &PreparedRay,
    id: u32,
    stack: &mut Vec<(u32, f32)>,
    visitor: &mut V,
) -> f32 {
    single::trace::<K, V>(tree, ray, id, stack, visitor)
}
