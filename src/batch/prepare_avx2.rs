//! Preparing a batch's rays eight at a time with AVX2 (x86-64, detected at run time): the
//! validity checks, group keys and [`PreparedRay`] constants of eight rays in eight lanes.
//!
//! Grouping a batch prepares every ray once, and done one ray at a time that costs about a
//! fifth of a batched query's instructions (the checks, the dominant axis, two divisions, the
//! record's stores). Here eight [`Ray`]s are loaded as eight 32-byte rows and transposed into
//! columns, every lane runs the scalar code's IEEE operations in the same order (the same
//! comparisons, the same selects, the same divisions; `vdivps` rounds as `divss` does), and the
//! records are transposed back into rows. Twin: [`PreparedRay::new`] and the scalar group key;
//! `tests` compares them bit for bit on rays full of special values.

use std::arch::x86_64::{
    __m256, __m256i, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm256_and_ps,
    _mm256_andnot_ps, _mm256_blendv_ps, _mm256_castps_si256, _mm256_castsi256_ps, _mm256_cmp_ps,
    _mm256_div_ps, _mm256_loadu_ps, _mm256_movemask_ps, _mm256_or_si256, _mm256_set1_epi32,
    _mm256_set1_ps, _mm256_setzero_ps, _mm256_slli_epi32, _mm256_sllv_epi32, _mm256_srli_epi32,
    _mm256_store_ps, _mm256_storeu_si256,
};

use super::rays::PreparedRays;
use super::slots::Placer;
use crate::geom::box_octet::slab_range;
use crate::geom::{Aabb, PreparedRay, Ray};
use crate::x86::Avx2;
use crate::x86::transpose;

/// Eight rays in columns, their directions flushed, and which of them are valid.
struct Columns {
    origin: [__m256; 3],
    /// Directions with subnormal components flushed to signed zero.
    dir: [__m256; 3],
    tmin: __m256,
    tmax: __m256,
    /// All ones in the lanes of valid rays ([`Ray::validate`]).
    valid: __m256,
    /// Each lane's direction octant ([`crate::geom::octant`]), as a 32-bit integer.
    octant: __m256i,
}

/// The group key of each of the eight rays: `invalid` for an invalid ray, else its octant, or 0
/// when `by_octant` is false (see `group::group_starts`).
#[inline(always)]
pub(crate) fn keys(_: Avx2, rays: &[Ray; 8], by_octant: bool, invalid: u8) -> [u8; 8] {
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe { keys_avx2(rays, by_octant, invalid) }
}

/// See [`keys`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn keys_avx2(rays: &[Ray; 8], by_octant: bool, invalid: u8) -> [u8; 8] {
    let columns = columns(rays);
    let group = if by_octant {
        columns.octant
    } else {
        _mm256_set1_epi32(0)
    };
    let keys = _mm256_blendv_ps(
        _mm256_castsi256_ps(_mm256_set1_epi32(i32::from(invalid))),
        _mm256_castsi256_ps(group),
        columns.valid,
    );
    let mut out = [0u32; 8];
    // SAFETY: `out` is 32 writable bytes; an unaligned store is allowed.
    unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), _mm256_castps_si256(keys)) };
    out.map(|key| key as u8)
}

/// The prepared records of the eight rays into `out`, those of invalid rays meaningless; returns
/// which of them touch `cull` (bit `j` for ray `j`; all eight without a box), by
/// [`Aabb::hit_by`] on the record with its own `tmax`.
#[inline(always)]
pub(crate) fn prepare(
    _: Avx2,
    rays: &[Ray; 8],
    cull: Option<&Aabb>,
    out: &mut [PreparedRay; 8],
) -> u32 {
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe { prepare_avx2(rays, cull, out) }
}

/// See [`prepare`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn prepare_avx2(rays: &[Ray; 8], cull: Option<&Aabb>, out: &mut [PreparedRay; 8]) -> u32 {
    let rows = rows(rays, cull);
    for (j, record) in out.iter_mut().enumerate() {
        rows.store(j, record);
    }
    rows.touching
}

/// Prepares `rays` into `out`'s records at the slots `placer` gives them (group keys `keys`,
/// the cull box `cull`), eight at a time, each record stored from registers into its slot;
/// returns how many rays that was (a multiple of eight: the caller does the rest).
#[inline(always)]
pub(crate) fn scatter_records(
    _: Avx2,
    (rays, keys): (&[Ray], &[u8]),
    cull: Option<&Aabb>,
    placer: &mut Placer,
    out: &mut PreparedRays,
) -> usize {
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe { scatter_records_avx2((rays, keys), cull, placer, out) }
}

/// See [`scatter_records`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn scatter_records_avx2(
    (rays, keys): (&[Ray], &[u8]),
    cull: Option<&Aabb>,
    placer: &mut Placer,
    out: &mut PreparedRays,
) -> usize {
    for (k, (eight, keys)) in rays.chunks_exact(8).zip(keys.chunks_exact(8)).enumerate() {
        let rows = rows(eight.try_into().unwrap(), cull);
        for (j, &key) in keys.iter().enumerate() {
            if let Some(slot) = placer.place(8 * k + j, key, rows.touching >> j & 1 == 1) {
                rows.store(j, &mut out.rays[slot]);
                out.ids[slot] = slot as u32;
            }
        }
    }
    rays.len() / 8 * 8
}

/// Eight prepared records as rows (ray `j`'s first and second 32 bytes), and which of the rays
/// touch the cull box.
struct Rows {
    first: [__m256; 8],
    second: [__m256; 8],
    touching: u32,
}

impl Rows {
    /// Writes ray `j`'s record to `record`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn store(&self, j: usize, record: &mut PreparedRay) {
        let record: *mut PreparedRay = record;
        // SAFETY: a `PreparedRay` is 64 bytes aligned to 64 of plain `f32`s and bytes (its
        // layout is asserted next to it), so both halves are aligned, writable, and any bits
        // are a valid value; the second half's last lane is the `pad` field, written zero.
        unsafe {
            _mm256_store_ps(record.cast::<f32>(), self.first[j]);
            _mm256_store_ps(record.cast::<f32>().add(8), self.second[j]);
        }
    }
}

/// The records of the eight rays as rows, those of invalid rays meaningless, and which of
/// them touch `cull`. Lane by lane the arithmetic of `PreparedRay::from_flushed` and of
/// `geom::aabb::box_entry`.
#[inline]
#[target_feature(enable = "avx2")]
fn rows(rays: &[Ray; 8], cull: Option<&Aabb>) -> Rows {
    let Columns {
        origin,
        dir: d,
        tmin,
        tmax,
        octant,
        ..
    } = columns(rays);
    let abs = d.map(|c| abs(c));
    // The dominant axis: x if it is at least both others, else y if at least z, else z.
    let x_wins = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GE_OQ>(abs[0], abs[1]),
        _mm256_cmp_ps::<_CMP_GE_OQ>(abs[0], abs[2]),
    );
    let y_wins = _mm256_cmp_ps::<_CMP_GE_OQ>(abs[1], abs[2]);
    let pick = |if_x: __m256, if_y: __m256, if_z: __m256| {
        _mm256_blendv_ps(_mm256_blendv_ps(if_z, if_y, y_wins), if_x, x_wins)
    };
    // (kx, ky, kz) = (kz + 1, kz + 2, kz) mod 3.
    let z = pick(d[0], d[1], d[2]);
    let x = pick(d[1], d[2], d[0]);
    let y = pick(d[2], d[0], d[1]);
    let one = _mm256_set1_ps(1.0);
    let shear = [
        _mm256_div_ps(x, z),
        _mm256_div_ps(y, z),
        _mm256_div_ps(one, z),
    ];
    let inv = d.map(|c| _mm256_div_ps(one, c));
    let touching = cull.map_or(0xFF, |bounds| touches(bounds, origin, inv, (tmin, tmax)));
    let int = |v: i32| _mm256_castsi256_ps(_mm256_set1_epi32(v));
    let kz = _mm256_castps_si256(pick(int(0), int(1), int(2)));
    // Byte 0: `1 << octant`, byte 1: `kz`, bytes 2 and 3 (the first of `pad`): zero.
    let bytes = _mm256_or_si256(
        _mm256_sllv_epi32(_mm256_set1_epi32(1), octant),
        _mm256_slli_epi32::<8>(kz),
    );
    let first = transpose([
        origin[0], origin[1], origin[2], inv[0], inv[1], inv[2], tmin, tmax,
    ]);
    let second = transpose([
        d[0],
        d[1],
        d[2],
        shear[0],
        shear[1],
        shear[2],
        _mm256_castsi256_ps(bytes),
        _mm256_setzero_ps(),
    ]);
    Rows {
        first,
        second,
        touching,
    }
}

/// Which of eight rays (columns: origins, inverse directions, ranges) touch `bounds`: lane by
/// lane the slab test of `geom::aabb::box_entry` ([`slab_range`]).
#[inline]
#[target_feature(enable = "avx2")]
fn touches(bounds: &Aabb, origin: [__m256; 3], inv: [__m256; 3], range: (__m256, __m256)) -> u32 {
    let (near, far) = slab_range(bounds.min, bounds.max, origin, inv, range);
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
}

/// Loads eight rays as columns and runs the validity checks of `geom::ray::flushed_if_valid`.
#[inline]
#[target_feature(enable = "avx2")]
fn columns(rays: &[Ray; 8]) -> Columns {
    let rows = rays.each_ref().map(|ray| {
        let ray: *const Ray = ray;
        // SAFETY: a `Ray` is 32 bytes of eight `f32`s (`repr(C)`, asserted next to it); an
        // unaligned load is allowed.
        unsafe { _mm256_loadu_ps(ray.cast::<f32>()) }
    });
    let [ox, oy, oz, dx, dy, dz, tmin, tmax] = transpose(rows);
    let finite = |v: __m256| _mm256_cmp_ps::<_CMP_LT_OQ>(abs(v), _mm256_set1_ps(f32::INFINITY));
    let and = _mm256_and_ps;
    let all_finite = and(
        and(and(finite(ox), finite(oy)), finite(oz)),
        and(and(finite(dx), finite(dy)), finite(dz)),
    );
    let dir = [dx, dy, dz].map(|c| flush_subnormals(c));
    let is_zero = |v: __m256| _mm256_cmp_ps::<_CMP_EQ_OQ>(v, _mm256_setzero_ps());
    let dir_zero = and(and(is_zero(dir[0]), is_zero(dir[1])), is_zero(dir[2]));
    let range_ok = and(
        and(
            _mm256_cmp_ps::<_CMP_GE_OQ>(tmin, _mm256_setzero_ps()),
            _mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax),
        ),
        finite(tmin),
    );
    let valid = _mm256_andnot_ps(dir_zero, and(all_finite, range_ok));
    let sign = |v: __m256, bit: i32| {
        let bit = _mm256_set1_epi32(bit);
        _mm256_sllv_epi32(_mm256_srli_epi32::<31>(_mm256_castps_si256(v)), bit)
    };
    let octant = _mm256_or_si256(
        _mm256_or_si256(sign(dir[0], 0), sign(dir[1], 1)),
        sign(dir[2], 2),
    );
    Columns {
        origin: [ox, oy, oz],
        dir,
        tmin,
        tmax,
        valid,
        octant,
    }
}

/// `|v|`, lane by lane (the sign bit cleared).
#[inline]
#[target_feature(enable = "avx2")]
fn abs(v: __m256) -> __m256 {
    _mm256_andnot_ps(_mm256_set1_ps(-0.0), v)
}

/// `geom::ray::flush_subnormals` lane by lane: magnitudes below `f32::MIN_POSITIVE` become a
/// zero of the same sign; NaN compares false and is kept.
#[inline]
#[target_feature(enable = "avx2")]
fn flush_subnormals(v: __m256) -> __m256 {
    let tiny = _mm256_cmp_ps::<_CMP_LT_OQ>(abs(v), _mm256_set1_ps(f32::MIN_POSITIVE));
    let signed_zero = _mm256_and_ps(v, _mm256_set1_ps(-0.0));
    _mm256_blendv_ps(v, signed_zero, tiny)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::geom::octant;
    use crate::test_support::TestRng;

    /// A value that is often special: zeros of both signs, subnormals, infinities, NaN, or
    /// a plain random number.
    fn special(rng: &mut TestRng) -> f32 {
        const SPECIAL: [f32; 9] = [
            0.0,
            -0.0,
            1e-40,
            -1e-40,
            f32::MIN_POSITIVE,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
        ];
        let pick = rng.range(0.0, 30.0) as usize;
        SPECIAL
            .get(pick)
            .copied()
            .unwrap_or_else(|| rng.range(-3.0, 3.0))
    }

    fn random_ray(rng: &mut TestRng, round: usize) -> Ray {
        let mut ray = Ray::with_range(rng.vec3(5.0), rng.vec3(1.0), 0.0, f32::INFINITY);
        // Some rays with special values here and there, some with ties between axes.
        match round % 4 {
            0 => ray.dir[round % 3] = special(rng),
            1 => ray.origin[round % 3] = special(rng),
            2 => (ray.tmin, ray.tmax) = (special(rng).abs(), special(rng)),
            // Ties between the axes' magnitudes (the dominant axis's tie rule).
            _ => {
                let pick =
                    |rng: &mut TestRng| [-1.0, -0.5, 0.5, 1.0][rng.range(0.0, 3.99) as usize];
                ray.dir = Vec3::new(pick(rng), pick(rng), pick(rng));
            }
        }
        ray
    }

    fn bits(ray: &PreparedRay) -> Vec<u32> {
        let v = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut out = [v(ray.origin), v(ray.inv_dir), v(ray.dir), v(ray.shear)].concat();
        out.extend([ray.tmin.to_bits(), ray.tmax.to_bits()]);
        out.extend([u32::from(ray.octant_mask), u32::from(ray.kz)]);
        out.extend(ray.pad.map(u32::from));
        out
    }

    /// Eight lanes give the scalar keys and, for valid rays, the scalar records bit for bit and
    /// the scalar slab test's answer for a box.
    #[test]
    fn eight_at_a_time_equals_one_at_a_time() {
        let Some(avx2) = Avx2::detect() else {
            return;
        };
        let mut rng = TestRng::new(17);
        let (mut valid, mut invalid) = (0, 0);
        let (mut hit, mut missed) = (0, 0);
        for round in 0..20_000 {
            let rays: [Ray; 8] = std::array::from_fn(|j| random_ray(&mut rng, round + j));
            let by_octant = round % 2 == 0;
            let keys = keys(avx2, &rays, by_octant, 8);
            let mut records = [PreparedRay::new(&Ray::new(Vec3::ZERO, Vec3::X)).unwrap(); 8];
            // A box some rays touch and some miss, now and then flat or a point.
            let corner = rng.vec3(4.0);
            let mut size = rng.vec3(8.0).abs();
            if round % 5 == 0 {
                size[round % 3] = 0.0;
            }
            let bounds = Aabb::new(corner, corner + size);
            let touching = prepare(avx2, &rays, Some(&bounds), &mut records);
            assert_eq!(prepare(avx2, &rays, None, &mut records), 0xFF);
            for (j, ray) in rays.iter().enumerate() {
                match PreparedRay::new(ray) {
                    Some(expected) => {
                        valid += 1;
                        let key = if by_octant {
                            octant(expected.dir) as u8
                        } else {
                            0
                        };
                        assert_eq!(keys[j], key, "{ray:?}");
                        assert_eq!(bits(&records[j]), bits(&expected), "{ray:?}");
                        let touches = bounds.hit_by(&expected, expected.tmax);
                        assert_eq!(touching >> j & 1 == 1, touches, "{ray:?} {bounds:?}");
                        (hit, missed) = (hit + touches as usize, missed + !touches as usize);
                    }
                    None => {
                        invalid += 1;
                        assert_eq!(keys[j], 8, "{ray:?}");
                    }
                }
            }
        }
        assert!(
            valid > 50_000 && invalid > 10_000,
            "{valid} valid, {invalid} invalid"
        );
        assert!(
            hit > 5_000 && missed > 5_000,
            "{hit} touch the box, {missed} miss it"
        );
    }
}
