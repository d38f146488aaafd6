//! The conservative slab test of one box against eight rays at once with AVX2: [`BoxOctet`],
//! whose twin is [`super::aabb::box_entry`] (compared lane by lane by `tests`). The batched
//! engine's packet walk (`traverse::packet`) tests each node's children against the few rays
//! that reach it with one call instead of one per ray.
//!
//! Lane by lane it performs `box_entry`'s `f32` operations: the near and far planes picked by
//! the sign of `inv_dir`, `(plane - origin) * inv_dir` (the exit scaled by `EXIT_SCALE`), each
//! axis folded into the range `[tmin, min(tmax, f32::MAX)]` with a compare-and-select (a NaN
//! axis leaves it alone). `box_entry` takes the largest entry and smallest exit of the three
//! selected values at the end instead of folding them in turn; both give the largest (smallest)
//! non-NaN value, so the lanes' answers (`entry < inf`, `entry <= t`) are `box_entry`'s.

use std::arch::x86_64::{
    __m256, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm256_blendv_ps, _mm256_cmp_ps, _mm256_loadu_ps,
    _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_ps, _mm256_setzero_ps,
    _mm256_sub_ps,
};

use glam::Vec3;

use super::aabb::EXIT_SCALE;
use crate::x86::{Avx2, load, load_bits, store};

/// Eight rays' constants for the slab test, lane `j` for ray `j`.
#[derive(Clone, Copy)]
pub(crate) struct BoxOctet {
    origin: [__m256; 3],
    inv_dir: [__m256; 3],
    tmin: __m256,
}

impl BoxOctet {
    /// The constants of eight rays stored as columns (one 32-byte load each): their
    /// origins, inverse directions and `tmin`.
    #[inline(always)]
    pub(crate) fn from_columns(
        _: Avx2,
        origin: [&[u32; 8]; 3],
        inv_dir: [&[u32; 8]; 3],
        tmin: &[u32; 8],
    ) -> Self {
        let column = |eight: &[u32; 8]| -> __m256 {
            // SAFETY: an `Avx2` exists only if the CPU has AVX2 (loading needs AVX), and
            // `eight` is 32 readable bytes.
            unsafe { load_bits(eight) }
        };
        Self {
            origin: origin.map(column),
            inv_dir: inv_dir.map(column),
            tmin: column(tmin),
        }
    }

    /// Each lane's entry distance into the box `min..max` within `[tmin, tmax[j]]`, or `+inf`
    /// where the ray misses it: lane `j` is `box_entry(min, max, ray j, tmax[j])` (up to the
    /// sign of a zero, which no comparison sees).
    #[inline(always)]
    pub(crate) fn entries(&self, _: Avx2, min: Vec3, max: Vec3, tmax: &[f32; 8]) -> Entries {
        // SAFETY: an `Avx2` exists only if the CPU has AVX2.
        unsafe { self.entries_avx2(min, max, tmax) }
    }

    /// See [`BoxOctet::entries`].
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn entries_avx2(&self, min: Vec3, max: Vec3, tmax: &[f32; 8]) -> Entries {
        // SAFETY: `tmax` is 32 readable bytes; an unaligned load is allowed.
        let tmax = unsafe { _mm256_loadu_ps(tmax.as_ptr()) };
        let (near, far) = slab_range(min, max, self.origin, self.inv_dir, (self.tmin, tmax));
        let touched = _mm256_cmp_ps::<_CMP_LE_OQ>(near, far);
        Entries(_mm256_blendv_ps(
            _mm256_set1_ps(f32::INFINITY),
            near,
            touched,
        ))
    }
}

/// The slab test's range `(near, far)` of eight rays (columns: origins, inverse directions,
/// `tmin` and `tmax`) through the box `min..max`, lane by lane `box_entry`'s `f32` operations
/// (see the module docs): the ray touches the box where `near <= far`, and then enters it at
/// `near`. The one copy of the eight-ray slab test, also used where a batch is prepared
/// (`batch::prepare_avx2`, rays outside the structure's box).
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn slab_range(
    min: Vec3,
    max: Vec3,
    origin: [__m256; 3],
    inv_dir: [__m256; 3],
    (tmin, tmax): (__m256, __m256),
) -> (__m256, __m256) {
    let zero = _mm256_setzero_ps();
    let scale = _mm256_set1_ps(EXIT_SCALE);
    let mut near = tmin;
    let mut far = _mm256_min_ps(tmax, _mm256_set1_ps(f32::MAX));
    for axis in 0..3 {
        let (o, inv) = (origin[axis], inv_dir[axis]);
        let t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(min[axis]), o), inv);
        let t1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(max[axis]), o), inv);
        let negative = _mm256_cmp_ps::<_CMP_LT_OQ>(inv, zero);
        let enter = _mm256_blendv_ps(t0, t1, negative);
        let exit = _mm256_mul_ps(_mm256_blendv_ps(t1, t0, negative), scale);
        near = _mm256_blendv_ps(near, enter, _mm256_cmp_ps::<_CMP_GT_OQ>(enter, near));
        far = _mm256_blendv_ps(far, exit, _mm256_cmp_ps::<_CMP_LT_OQ>(exit, far));
    }
    (near, far)
}

/// Eight entry distances ([`BoxOctet::entries`]).
#[derive(Clone, Copy)]
pub(crate) struct Entries(__m256);

impl Entries {
    /// Bit `j` is set if ray `j` touches the box.
    #[inline(always)]
    pub(crate) fn touched(&self, avx2: Avx2) -> u32 {
        self.within(avx2, &[f32::MAX; 8])
    }

    /// Bit `j` is set if ray `j` enters the box at or before `t[j]`: for `t[j]` at most the
    /// range end the entries were computed with, what testing the box again would say.
    #[inline(always)]
    pub(crate) fn within(&self, _: Avx2, t: &[f32; 8]) -> u32 {
        // SAFETY: an `Avx2` exists only if the CPU has AVX2.
        unsafe { self.within_avx2(t) }
    }

    /// See [`Entries::within`].
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn within_avx2(&self, t: &[f32; 8]) -> u32 {
        // SAFETY: `t` is 32 readable bytes; an unaligned load is allowed.
        let t = unsafe { _mm256_loadu_ps(t.as_ptr()) };
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, t)) as u32
    }

    /// The eight distances as an array.
    #[inline(always)]
    pub(crate) fn to_array(self, _: Avx2) -> [f32; 8] {
        let mut out = [0.0; 8];
        // SAFETY: `out` is 32 writable bytes; an unaligned store is allowed. Storing needs
        // only AVX, which an `Avx2` proves.
        unsafe { store(&mut out, self.0) };
        out
    }

    /// Entries stored by [`Entries::to_array`].
    #[inline(always)]
    pub(crate) fn from_array(_: Avx2, entries: &[f32; 8]) -> Self {
        // SAFETY: `entries` is 32 readable bytes; loading needs only AVX, which an `Avx2`
        // proves.
        Self(unsafe { load(entries) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::aabb::box_entry;
    use crate::geom::{PreparedRay, Ray};
    use crate::test_support::TestRng;

    /// Lane by lane, the eight-ray test gives `box_entry`'s answers: which rays touch the box,
    /// and which enter it at or before a later, smaller range end; over rays with zero
    /// direction components of both signs, origins on the box's planes, range ends of every
    /// kind (finite, `+inf`, `-inf` for finished rays) and flat boxes.
    #[test]
    fn eight_ray_box_test_equals_the_scalar_one() {
        let Some(avx2) = Avx2::detect() else {
            return;
        };
        let mut rng = TestRng::new(21);
        let (mut touched, mut missed) = (0, 0);
        for round in 0..20_000 {
            let lo = rng.vec3(2.0);
            let mut hi = lo
                + Vec3::new(
                    rng.range(0.0, 2.0),
                    rng.range(0.0, 2.0),
                    rng.range(0.0, 2.0),
                );
            if round % 7 == 0 {
                hi.y = lo.y;
            }
            let rays: [PreparedRay; 8] = std::array::from_fn(|j| {
                let mut origin = rng.vec3(3.0);
                // Aimed near the box, so that about half of the rays touch it.
                let aim = lo
                    + (hi - lo)
                        * Vec3::new(
                            rng.range(-0.5, 1.5),
                            rng.range(-0.5, 1.5),
                            rng.range(-0.5, 1.5),
                        );
                let mut dir = aim - origin;
                match (round + j) % 6 {
                    1 => dir.x = 0.0,
                    2 => dir.z = -0.0,
                    3 => origin.x = lo.x,
                    4 => origin.y = hi.y,
                    _ => {}
                }
                let mut ray = Ray::new(origin, dir);
                ray.tmax = match (round + j) % 5 {
                    0 => f32::INFINITY,
                    1 => f32::NEG_INFINITY,
                    _ => rng.range(0.0, 4.0),
                };
                PreparedRay::new(&ray)
                    .unwrap_or_else(|| PreparedRay::new(&Ray::new(origin, Vec3::X)).unwrap())
            });
            let tmax: [f32; 8] = std::array::from_fn(|j| rays[j].tmax);
            let later: [f32; 8] = std::array::from_fn(|j| tmax[j].min(rng.range(0.0, 4.0)));
            let column = |f: &dyn Fn(&PreparedRay) -> f32| rays.each_ref().map(|r| f(r).to_bits());
            let origin = [0, 1, 2].map(|a| column(&|r| r.origin[a]));
            let inv_dir = [0, 1, 2].map(|a| column(&|r| r.inv_dir[a]));
            let tmin = column(&|r| r.tmin);
            let boxes = BoxOctet::from_columns(
                avx2,
                [&origin[0], &origin[1], &origin[2]],
                [&inv_dir[0], &inv_dir[1], &inv_dir[2]],
                &tmin,
            );
            let entries = boxes.entries(avx2, lo, hi, &tmax);
            let (mut expected_touched, mut expected_within) = (0, 0);
            for (j, ray) in rays.iter().enumerate() {
                let entry = box_entry(lo, hi, ray, tmax[j]);
                expected_touched |= ((entry < f32::INFINITY) as u32) << j;
                expected_within |= ((entry <= later[j]) as u32) << j;
            }
            assert_eq!(entries.touched(avx2), expected_touched, "round {round}");
            assert_eq!(
                entries.within(avx2, &later),
                expected_within,
                "round {round}"
            );
            let stored = Entries::from_array(avx2, &entries.to_array(avx2));
            assert_eq!(
                stored.within(avx2, &later),
                expected_within,
                "round {round}"
            );
            touched += expected_touched.count_ones();
            missed += 8 - expected_touched.count_ones();
        }
        assert!(touched > 10_000 && missed > 10_000, "{touched} / {missed}");
    }
}
