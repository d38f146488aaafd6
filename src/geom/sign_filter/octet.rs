//! The watertight sign filter for eight rays at once with AVX2: [`RayOctet`], the twin of
//! [`super::RayQuad`] (compared by `tests`), for the stream engines' leaves on x86-64 CPUs
//! with AVX2. Lane by lane it computes what `RayQuad` and the scalar kernel compute (see
//! [`super`] for why a cleared lane is a certain miss), eight rays per instruction instead of
//! four.

use std::arch::x86_64::{
    __m256, _CMP_GT_OQ, _CMP_LT_OQ, _mm256_and_ps, _mm256_and_si256, _mm256_blendv_ps,
    _mm256_castps_si256, _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_load_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_or_ps, _mm256_set1_epi32, _mm256_set1_ps,
    _mm256_srli_epi32, _mm256_sub_ps,
};

use glam::Vec3;

use crate::geom::PreparedRay;
use crate::x86::{Avx2, load_bits, transpose};

/// Eight rays' constants for the watertight kernel's sign test, lane `j` for ray `j`: the
/// stream's leaves prove most ray/triangle misses eight rays at a time with it (see
/// [`crate::geom::sign_filter`] for why the filter never drops a hit). Lane by lane, the same
/// `f32` operations as [`RayQuad::may_hit`](super::RayQuad::may_hit) and the scalar kernel, in the same order, no FMA.
#[derive(Clone, Copy)]
pub(crate) struct RayOctet {
    origin: [__m256; 3],
    shear_x: __m256,
    shear_y: __m256,
    /// All ones in the lanes whose dominant axis is x, and y (the rest: z).
    kz_is_x: __m256,
    kz_is_y: __m256,
}

impl RayOctet {
    /// The constants of eight rays stored as columns (the binary trees' stream layout, one
    /// 32-byte load per column): their origins, shear constants `x` and `y`, and the axes
    /// column, whose low byte is the dominant axis `kz` (`batch::lanes`).
    #[inline(always)]
    pub(crate) fn from_columns(
        _: Avx2,
        origin: [&[u32; 8]; 3],
        shear: [&[u32; 8]; 2],
        axes: &[u32; 8],
    ) -> Self {
        // SAFETY: an `Avx2` exists only if the CPU has AVX2.
        unsafe { Self::from_columns_avx2(origin, shear, axes) }
    }

    /// See [`RayOctet::from_columns`].
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn from_columns_avx2(
        origin: [&[u32; 8]; 3],
        shear: [&[u32; 8]; 2],
        axes: &[u32; 8],
    ) -> Self {
        // SAFETY (each load): the CPU has AVX2, so AVX; a column is 32 readable bytes.
        let float = |eight: &[u32; 8]| unsafe { load_bits(eight) };
        let kz = _mm256_and_si256(_mm256_castps_si256(float(axes)), _mm256_set1_epi32(0xFF));
        let is = |axis: i32| _mm256_castsi256_ps(_mm256_cmpeq_epi32(kz, _mm256_set1_epi32(axis)));
        Self {
            origin: origin.map(float),
            shear_x: float(shear[0]),
            shear_y: float(shear[1]),
            kz_is_x: is(0),
            kz_is_y: is(1),
        }
    }

    /// The constants of rays `ids` (indices into `rays`). Panics if an index is out of range.
    #[inline(always)]
    pub(crate) fn gather(_: Avx2, rays: &[PreparedRay], ids: &[u32; 8]) -> Self {
        // SAFETY: an `Avx2` exists only if the CPU has AVX2.
        unsafe { Self::gather_avx2(rays, ids) }
    }

    /// See [`RayOctet::gather`].
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn gather_avx2(rays: &[PreparedRay], ids: &[u32; 8]) -> Self {
        // A ray's first 32 bytes hold its origin, its second 32 the direction, the shear and
        // the octant and axis bytes (see `PreparedRay`'s layout).
        let rays: [&PreparedRay; 8] = ids.map(|i| &rays[i as usize]);
        let half = |offset: usize| {
            transpose(rays.map(|ray| {
                let ray: *const PreparedRay = ray;
                // SAFETY: a `PreparedRay` is 64 bytes aligned to 64, all initialised (its last
                // six are the `pad` field), so both 32-byte halves are aligned and readable.
                unsafe { _mm256_load_ps(ray.cast::<f32>().add(offset)) }
            }))
        };
        let [ox, oy, oz, ..] = half(0);
        let [_, _, _, shear_x, shear_y, _, bytes, _] = half(8);
        // Byte 1 of the eighth 32-bit value is `kz`.
        let kz = _mm256_and_si256(
            _mm256_srli_epi32::<8>(_mm256_castps_si256(bytes)),
            _mm256_set1_epi32(0xFF),
        );
        let is = |axis: i32| _mm256_castsi256_ps(_mm256_cmpeq_epi32(kz, _mm256_set1_epi32(axis)));
        Self {
            origin: [ox, oy, oz],
            shear_x,
            shear_y,
            kz_is_x: is(0),
            kz_is_y: is(1),
        }
    }

    /// Bit `j` is set unless ray `j` certainly misses `tri`.
    #[inline(always)]
    pub(crate) fn may_hit(&self, avx2: Avx2, tri: &[Vec3; 3]) -> u32 {
        let _ = avx2;
        // SAFETY: an `Avx2` exists only if the CPU has AVX2.
        unsafe { self.may_hit_avx2(tri) }
    }

    /// See [`RayOctet::may_hit`].
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn may_hit_avx2(&self, tri: &[Vec3; 3]) -> u32 {
        let (ax, ay) = self.project(tri[0]);
        let (bx, by) = self.project(tri[1]);
        let (cx, cy) = self.project(tri[2]);
        let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        // The kernel's compares: signs beyond the subnormal range.
        let m = _mm256_set1_ps(f32::MIN_POSITIVE);
        let minus_m = _mm256_set1_ps(-f32::MIN_POSITIVE);
        let negative = |x: __m256| _mm256_cmp_ps::<_CMP_LT_OQ>(x, minus_m);
        let positive = |x: __m256| _mm256_cmp_ps::<_CMP_GT_OQ>(x, m);
        let (un, vn, wn) = (negative(u), negative(v), negative(w));
        let (up, vp, wp) = (positive(u), positive(v), positive(w));
        let or = |a, b| _mm256_or_ps(a, b);
        let and = |a, b| _mm256_and_ps(a, b);
        let all_normal = and(and(or(un, up), or(vn, vp)), or(wn, wp));
        let certain_miss = and(all_normal, and(or(or(un, vn), wn), or(or(up, vp), wp)));
        !(_mm256_movemask_ps(certain_miss) as u32) & 0xFF
    }

    /// Corner `p` relative to each origin, permuted to `(kx, ky, kz)` and sheared, as
    /// [`RayQuad`] computes it.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn project(&self, p: Vec3) -> (__m256, __m256) {
        let rel = [
            _mm256_sub_ps(_mm256_set1_ps(p.x), self.origin[0]),
            _mm256_sub_ps(_mm256_set1_ps(p.y), self.origin[1]),
            _mm256_sub_ps(_mm256_set1_ps(p.z), self.origin[2]),
        ];
        // kz = x: (kx, ky) = (y, z); kz = y: (z, x); kz = z: (x, y).
        let pick = |if_x: usize, if_y: usize, if_z: usize| {
            let y_or_z = _mm256_blendv_ps(rel[if_z], rel[if_y], self.kz_is_y);
            _mm256_blendv_ps(y_or_z, rel[if_x], self.kz_is_x)
        };
        let (x, y, z) = (pick(1, 2, 0), pick(2, 0, 1), pick(0, 1, 2));
        (
            _mm256_sub_ps(x, _mm256_mul_ps(self.shear_x, z)),
            _mm256_sub_ps(y, _mm256_mul_ps(self.shear_y, z)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::super::RayQuad;
    use super::*;
    use crate::geom::Ray;
    use crate::test_support::TestRng;

    /// The eight-ray sign filter (AVX2) gives, lane by lane, the four-ray filter's answer
    /// ([`RayQuad::may_hit`], which `sign_filter::tests` checks against the kernel), over rays
    /// of every dominant axis and triangles with corners and edges on a ray, with the eight
    /// rays' constants gathered from records and loaded from columns.
    #[test]
    fn eight_ray_sign_filter_equals_two_four_ray_ones() {
        let Some(avx2) = Avx2::detect() else {
            return;
        };
        let mut rng = TestRng::new(9);
        let mut axes = [0usize; 3];
        for round in 0..20_000 {
            let rays: Vec<PreparedRay> = (0..16)
                .map(|k| {
                    let mut dir = rng.vec3(1.0);
                    if k % 5 == 0 {
                        dir[k % 3] = 0.0;
                    }
                    let ray = Ray::new(rng.vec3(2.0), dir);
                    PreparedRay::new(&ray).unwrap_or_else(|| {
                        PreparedRay::new(&Ray::new(ray.origin, Vec3::Y)).unwrap()
                    })
                })
                .collect();
            let ids: [u32; 8] = std::array::from_fn(|_| rng.range(0.0, 15.99) as u32);
            let at = |j: usize| &rays[ids[j] as usize];
            let mut tri = [rng.vec3(3.0), rng.vec3(3.0), rng.vec3(3.0)];
            match round % 4 {
                // A corner on a ray, and a ray through the middle of an edge.
                1 => tri[0] = at(round % 8).origin + at(round % 8).dir * 1.5,
                2 => tri[1] = 2.0 * (at(round % 8).origin + at(round % 8).dir) - tri[0],
                _ => {}
            }
            let octet = RayOctet::gather(avx2, &rays, &ids);
            let quads = [0, 4].map(|j| RayQuad::from_rays(std::array::from_fn(|k| at(j + k))));
            let expected = quads[0].may_hit(&tri) | quads[1].may_hit(&tri) << 4;
            assert_eq!(octet.may_hit(avx2, &tri), expected, "round {round}");
            // The same rays as columns (the binary trees' lanes).
            let column = |f: &dyn Fn(&PreparedRay) -> u32| std::array::from_fn(|j| f(at(j)));
            let origin = [0, 1, 2].map(|a| column(&|r| r.origin[a].to_bits()));
            let shear = [0, 1].map(|a| column(&|r| r.shear[a].to_bits()));
            let axis_bytes = column(&|r| r.kz as u32 | (r.octant_mask as u32) << 8);
            let from_columns = RayOctet::from_columns(
                avx2,
                [&origin[0], &origin[1], &origin[2]],
                [&shear[0], &shear[1]],
                &axis_bytes,
            );
            assert_eq!(
                from_columns.may_hit(avx2, &tri),
                expected,
                "columns, round {round}"
            );
            (0..8).for_each(|j| axes[at(j).kz as usize] += 1);
        }
        assert!(
            axes.iter().all(|&n| n > 10_000),
            "every dominant axis: {axes:?}"
        );
    }
}
