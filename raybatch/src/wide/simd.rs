//! The 4-lane box test with SSE intrinsics (x86-64), twin of
//! [`super::node::WideRay::slabs_portable`] (compared by `node::tests`).
//!
//! `maxps(a, b)` is `a > b ? a : b` and `minps(a, b)` is `a < b ? a : b`, so with the new
//! value first they are exactly the scalar test's NaN-safe compare-and-select (a NaN lane keeps
//! the running value) in one instruction; portable code needs a compare and a three-instruction
//! select on SSE2 for each. The arithmetic is the same: `(plane - origin) * inv_dir`, times
//! the exit scale for the far plane, no FMA.

use std::arch::x86_64::{
    __m128, _mm_cmple_ps, _mm_max_ps, _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_set1_ps,
    _mm_sub_ps,
};

use glam::Vec4;

use super::node::{Planes, WideRay};
use crate::geom::aabb::EXIT_SCALE;

/// See [`WideRay::hits_planes`].
#[inline(always)]
pub(crate) fn slabs(ray: &WideRay, planes: &Planes, tmax: f32) -> (u32, Vec4) {
    // SAFETY: the intrinsics need SSE and SSE2, which every x86-64 CPU has (they are part of
    // the target's baseline); they only compute on values, no memory is touched.
    unsafe {
        let mut near: __m128 = ray.tmin.into();
        let mut far = _mm_set1_ps(tmax.min(f32::MAX));
        let scale = _mm_set1_ps(EXIT_SCALE);
        for axis in 0..3 {
            let o: __m128 = ray.origin[axis].into();
            let inv: __m128 = ray.inv_dir[axis].into();
            let near_plane: __m128 = planes.near[axis].into();
            let far_plane: __m128 = planes.far[axis].into();
            let enter = _mm_mul_ps(_mm_sub_ps(near_plane, o), inv);
            let exit = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(far_plane, o), inv), scale);
            near = _mm_max_ps(enter, near);
            far = _mm_min_ps(exit, far);
        }
        let mask = _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32;
        (mask, near.into())
    }
}
