//! The wide box tests' portable side, which every node layout runs: one ray against four
//! boxes' planes ([`hits_planes`]: SSE on x86-64, `simd::slabs`; glam's `Vec4` elsewhere,
//! [`slabs_portable`]), and against eight boxes' rows as two such tests ([`slabs_by_halves`],
//! the twin of the AVX2 tests `simd::slabs8` and `simd::slabs8q`).
//!
//! The portable lanes use glam's `Vec4` (SSE2 on x86-64, NEON on aarch64, scalar elsewhere)
//! and do the scalar slab test's arithmetic lane by lane ([`crate::geom::aabb::box_entry`]):
//! the same near/far plane choice by the direction's sign, the same products in the same order
//! without FMA, the same exit scaling, and the same NaN-safe compare-and-select fold. A lane
//! misses exactly when the scalar test misses and enters at the same distance (`node4::tests`
//! and `node8::tests` check it).

use glam::Vec4;

use super::ray::{Planes, WideRay};
use crate::geom::aabb::EXIT_SCALE;

/// Which of four boxes `ray` enters within `[tmin, tmax]` (bit `k` for lane `k`) and the entry
/// distances (meaningful for those lanes only), given their planes for the ray's octant.
#[inline(always)]
pub(crate) fn hits_planes(ray: &WideRay, planes: &Planes, tmax: f32) -> (u32, Vec4) {
    #[cfg(target_arch = "x86_64")]
    {
        super::simd::slabs(ray, planes, tmax)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        slabs_portable(ray, planes, tmax)
    }
}

/// [`hits_planes`] with glam's `Vec4` only: the portable twin of the SSE version (used where
/// SSE is not the baseline, and by the tests everywhere).
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
#[inline(always)]
pub(crate) fn slabs_portable(ray: &WideRay, planes: &Planes, tmax: f32) -> (u32, Vec4) {
    // Hits have finite `t`, so an infinite entry (a parallel ray below a slab) is a miss.
    let mut near = ray.tmin;
    let mut far = Vec4::splat(tmax.min(f32::MAX));
    for axis in 0..3 {
        let (o, inv) = (ray.origin[axis], ray.inv_dir[axis]);
        let enter = (planes.near[axis] - o) * inv;
        let exit = (planes.far[axis] - o) * inv * EXIT_SCALE;
        // Compare-and-select, so a NaN lane (the ray grazes this slab) leaves the range
        // alone. Folding the axes one by one gives the scalar test's max (min) of the
        // selected values, which never depends on the order.
        near = Vec4::select(enter.cmpgt(near), enter, near);
        far = Vec4::select(exit.cmplt(far), exit, far);
    }
    (near.cmple(far).bitmask(), near)
}

/// The 8-wide box test on `bounds` (rows as [`super::node8::WideNode8`] holds them) as two
/// 4-wide box tests: the portable twin of the AVX2 tests (`simd::slabs8`, `simd::slabs8q`).
#[inline(always)]
pub(crate) fn slabs_by_halves(bounds: &[[f32; 8]; 6], ray: &WideRay, tmax: f32) -> (u32, [f32; 8]) {
    let mut mask = 0;
    let mut entries = [0.0; 8];
    for half in 0..2 {
        let (mut near, mut far) = ([Vec4::ZERO; 3], [Vec4::ZERO; 3]);
        for axis in 0..3 {
            let negative = (ray.octant >> axis) & 1 != 0;
            let (near_row, far_row) = if negative {
                (axis + 3, axis)
            } else {
                (axis, axis + 3)
            };
            near[axis] = Vec4::from_slice(&bounds[near_row][4 * half..]);
            far[axis] = Vec4::from_slice(&bounds[far_row][4 * half..]);
        }
        let (m, e) = hits_planes(ray, &Planes { near, far }, tmax);
        mask |= m << (4 * half);
        e.write_to_slice(&mut entries[4 * half..]);
    }
    (mask, entries)
}
