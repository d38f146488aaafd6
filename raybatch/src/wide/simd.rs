//! The 4-wide tree's hand-written SIMD (x86-64), each with a portable twin its module's tests
//! compare it with:
//!
//! - [`slabs`]: one ray against a node's four boxes with SSE, twin of
//!   [`super::node::WideRay::slabs_portable`] (compared by `node::tests`);
//! - [`stream_masks`]: eight rays at a time against each box with AVX2, for the stream split,
//!   twin of its one-ray loop (compared by `stream::tests`);
//! - [`RayOctet`]: the watertight sign filter for eight rays at once with AVX2, for the stream's
//!   leaves, twin of [`RayQuad::may_hit`] (compared by `simd::tests`).
//!
//! The one-ray box test:
//!
//! `maxps(a, b)` is `a > b ? a : b` and `minps(a, b)` is `a < b ? a : b`, so with the new
//! value first they are exactly the scalar test's NaN-safe compare-and-select (a NaN lane keeps
//! the running value) in one instruction; portable code needs a compare and a three-instruction
//! select on SSE2 for each. The arithmetic is the same: `(plane - origin) * inv_dir`, times
//! the exit scale for the far plane, no FMA.

use std::arch::x86_64::{
    __m128, __m128i, __m256, __m256i, _CMP_EQ_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm_cmple_ps,
    _mm_loadl_epi64, _mm_max_ps, _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_set1_ps, _mm_sub_ps,
    _mm256_and_ps, _mm256_and_si256, _mm256_andnot_ps, _mm256_blendv_ps, _mm256_castps_si256,
    _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_cvtepu8_epi32, _mm256_load_ps,
    _mm256_loadu_si256, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps,
    _mm256_or_ps, _mm256_permute2f128_ps, _mm256_permutevar8x32_epi32, _mm256_set1_epi32,
    _mm256_set1_ps, _mm256_setzero_ps, _mm256_shuffle_ps, _mm256_srli_epi32, _mm256_storeu_si256,
    _mm256_sub_ps, _mm256_unpackhi_ps, _mm256_unpacklo_ps,
};

use glam::{Vec3, Vec4};

use super::node::{Planes, WideRay};
use crate::batch::lanes::{self, Lanes};
use crate::geom::PreparedRay;
use crate::geom::aabb::EXIT_SCALE;
#[cfg(doc)]
use crate::geom::sign_filter::RayQuad;
pub(crate) use crate::traverse::avx2::Avx2;

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

/// The stream split's box tests eight rays at a time, twin of the one-ray-at-a-time loop
/// (`stream::masks_one_by_one`, compared by `stream::tests`): for the first `8 * (ids.len() / 8)`
/// rays of `ids` (indices into `rays`, all of the octant `planes` were picked for), writes one
/// `u32` per eight rays to `group_bits` (byte `k`: which of the eight enter child `k`) and
/// returns how many rays that was and the number entering each child in 32-bit fields.
///
/// Lane `j` computes exactly what [`WideRay::hits_planes`] computes for ray `j`, one child at a
/// time: the same subtractions and products in the same order, the same NaN-keeping `max`/`min`
/// fold and the same final compare. Panics if an index is out of range.
#[inline(always)]
pub(crate) fn stream_masks(
    _: Avx2,
    planes: &Planes,
    rays: &[PreparedRay],
    ids: &[u32],
    group_bits: &mut [u32],
) -> (usize, u128) {
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe { stream_masks_avx2(planes, rays, ids, group_bits) }
}

/// See [`stream_masks`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn stream_masks_avx2(
    planes: &Planes,
    rays: &[PreparedRay],
    ids: &[u32],
    group_bits: &mut [u32],
) -> (usize, u128) {
    let groups = (ids.len() / 8).min(group_bits.len());
    let scale = _mm256_set1_ps(EXIT_SCALE);
    let mut counts = 0u128;
    for g in 0..groups {
        let group = &ids[8 * g..8 * g + 8];
        // Each ray's first 32 bytes are its box-test row (see `PreparedRay`'s layout).
        let rows = std::array::from_fn(|j| {
            let ray: *const PreparedRay = &rays[group[j] as usize];
            // SAFETY: a `PreparedRay` is 64 bytes aligned to 64, its first 32 initialised `f32`s.
            unsafe { _mm256_load_ps(ray.cast::<f32>()) }
        });
        let [ox, oy, oz, ix, iy, iz, tmin, tmax] = transpose(rows);
        let (o, inv) = ([ox, oy, oz], [ix, iy, iz]);
        let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(f32::MAX));
        let mut bits = 0;
        for child in 0..4 {
            let (mut near, mut far) = (tmin, tmax);
            for a in 0..3 {
                let near_plane = _mm256_set1_ps(planes.near[a][child]);
                let far_plane = _mm256_set1_ps(planes.far[a][child]);
                let enter = _mm256_mul_ps(_mm256_sub_ps(near_plane, o[a]), inv[a]);
                let exit =
                    _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far_plane, o[a]), inv[a]), scale);
                near = _mm256_max_ps(enter, near);
                far = _mm256_min_ps(exit, far);
            }
            let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
            counts += u128::from(hit.count_ones()) << (32 * child);
            bits |= hit << (8 * child);
        }
        group_bits[g] = bits;
    }
    (8 * groups, counts)
}

/// The stream split's list writes eight rays at a time, twin of the one-ray-at-a-time loop in
/// `stream::Walk::split` (compared by `stream::tests`): appends the rays of `ids` (a multiple of
/// eight) to the list of each child they enter (`group_bits` from [`stream_masks`]), list `k`
/// growing at `lists[cursor[k]..]`, in their order. Writes up to seven slots past each list's
/// end (a list needs `stream::SPARE` slots after it); panics rather than write outside `lists`.
#[inline(always)]
pub(crate) fn write_lists(
    _: Avx2,
    ids: &[u32],
    group_bits: &[u32],
    cursor: &mut [usize; 4],
    lists: &mut [u32],
) {
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe { write_lists_avx2(ids, group_bits, cursor, lists) }
}

/// See [`write_lists`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn write_lists_avx2(
    ids: &[u32],
    group_bits: &[u32],
    cursor: &mut [usize; 4],
    lists: &mut [u32],
) {
    for (group, &bits) in ids.chunks_exact(8).zip(group_bits) {
        // SAFETY: `group` is 32 readable bytes; an unaligned load is allowed.
        let rays = unsafe { _mm256_loadu_si256(group.as_ptr().cast::<__m256i>()) };
        for (child, at) in cursor.iter_mut().enumerate() {
            let hits = (bits >> (8 * child)) & 0xFF;
            // SAFETY: a table row is 8 readable bytes; an unaligned load is allowed.
            let row =
                unsafe { _mm_loadl_epi64(COMPRESS[hits as usize].as_ptr().cast::<__m128i>()) };
            let kept = _mm256_permutevar8x32_epi32(rays, _mm256_cvtepu8_epi32(row));
            let out: &mut [u32; 8] = (&mut lists[*at..*at + 8]).try_into().unwrap();
            // SAFETY: `out` is 32 writable bytes of `u32`s; an unaligned store is allowed.
            unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast::<__m256i>(), kept) };
            *at += hits.count_ones() as usize;
        }
    }
}

/// Eight rays' constants for the watertight kernel's sign test, lane `j` for ray `j`: the
/// stream's leaves prove most ray/triangle misses eight rays at a time with it (see
/// [`crate::geom::sign_filter`] for why the filter never drops a hit). Lane by lane, the same
/// `f32` operations as [`RayQuad::may_hit`] and the scalar kernel, in the same order, no FMA.
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
    /// The constants of the eight rays in lanes `lane..lane + 8` of `lanes` (the binary
    /// trees' stream layout: one load per column). Panics if a lane is out of range.
    #[inline(always)]
    pub(crate) fn from_lanes(_: Avx2, lanes: &Lanes, lane: usize) -> Self {
        // SAFETY: an `Avx2` exists only if the CPU has AVX2.
        unsafe { Self::from_lanes_avx2(lanes, lane) }
    }

    /// See [`RayOctet::from_lanes`].
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn from_lanes_avx2(lanes: &Lanes, lane: usize) -> Self {
        let column = |c: usize| {
            let eight: &[u32; 8] = lanes.cols[c][lane..lane + 8].try_into().unwrap();
            // SAFETY: `eight` is 32 readable bytes; an unaligned load is allowed.
            unsafe { _mm256_loadu_si256(eight.as_ptr().cast::<__m256i>()) }
        };
        let float = |c: usize| _mm256_castsi256_ps(column(c));
        // The low byte of the axes column is `kz`.
        let kz = _mm256_and_si256(column(lanes::AXES), _mm256_set1_epi32(0xFF));
        let is = |axis: i32| _mm256_castsi256_ps(_mm256_cmpeq_epi32(kz, _mm256_set1_epi32(axis)));
        Self {
            origin: [float(lanes::OX), float(lanes::OY), float(lanes::OZ)],
            shear_x: float(lanes::SX),
            shear_y: float(lanes::SY),
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
        let any = |f: fn(__m256, __m256) -> __m256| {
            let zero = _mm256_setzero_ps();
            _mm256_or_ps(_mm256_or_ps(f(u, zero), f(v, zero)), f(w, zero))
        };
        let any_zero = any(|a, b| _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b));
        let any_negative = any(|a, b| _mm256_cmp_ps::<_CMP_LT_OQ>(a, b));
        let any_positive = any(|a, b| _mm256_cmp_ps::<_CMP_GT_OQ>(a, b));
        let certain_miss = _mm256_andnot_ps(any_zero, _mm256_and_ps(any_negative, any_positive));
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

/// Eight rows of eight values to eight columns: `out[c]` lane `r` is `rows[r]` lane `c`.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn transpose(rows: [__m256; 8]) -> [__m256; 8] {
    let [r0, r1, r2, r3, r4, r5, r6, r7] = rows;
    // Pairs of rows interleaved, then quads, within each 128-bit half...
    let pairs = |a, b| (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
    let quads = |a, b| {
        (
            _mm256_shuffle_ps::<0x44>(a, b),
            _mm256_shuffle_ps::<0xEE>(a, b),
        )
    };
    let ((t0, t1), (t2, t3)) = (pairs(r0, r1), pairs(r2, r3));
    let ((t4, t5), (t6, t7)) = (pairs(r4, r5), pairs(r6, r7));
    let ((u0, u1), (u2, u3)) = (quads(t0, t2), quads(t1, t3));
    let ((u4, u5), (u6, u7)) = (quads(t4, t6), quads(t5, t7));
    // ...then the halves: rows 0-3 low, rows 4-7 high.
    let low = |a, b| _mm256_permute2f128_ps::<0x20>(a, b);
    let high = |a, b| _mm256_permute2f128_ps::<0x31>(a, b);
    [
        low(u0, u4),
        low(u1, u5),
        low(u2, u6),
        low(u3, u7),
        high(u0, u4),
        high(u1, u5),
        high(u2, u6),
        high(u3, u7),
    ]
}

/// For each 8-bit mask, the positions of its set bits, lowest first, then zeros: the lanes a
/// compress keeps, in order.
static COMPRESS: [[u8; 8]; 256] = {
    let mut table = [[0u8; 8]; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut bit, mut out) = (0, 0);
        while bit < 8 {
            if mask & (1 << bit) != 0 {
                table[mask][out] = bit as u8;
                out += 1;
            }
            bit += 1;
        }
        mask += 1;
    }
    table
};
