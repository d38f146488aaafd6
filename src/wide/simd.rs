//! The wide trees' hand-written SIMD (x86-64), each with a portable twin its module's tests
//! compare it with:
//!
//! - [`slabs`]: one ray against a node's four boxes with SSE, twin of
//!   [`super::slabs::slabs_portable`] (compared by `node4::tests`);
//! - [`slabs8`]: one ray against an 8-wide node's eight boxes with AVX2, twin of
//!   [`super::slabs::slabs_by_halves`] (compared by `node8::tests`);
//! - [`slabs8q`]: the same against a quantized 8-wide node, decoding its planes first, twin of
//!   [`QuantizedWideNode8::hits_portable`](super::node8q::QuantizedWideNode8::hits_portable)
//!   (compared by `quantize::tests`);
//! - [`stream_masks`]: eight rays at a time (of one octant, or of mixed octants) against each
//!   box with AVX2, for the stream split, twin of its one-ray loop (compared by
//!   `stream::tests`).
//!
//! The leaves' eight-ray sign filter is `geom::sign_filter::RayOctet`, shared with the binary
//! trees' stream engine.
//!
//! The one-ray box test:
//!
//! `maxps(a, b)` is `a > b ? a : b` and `minps(a, b)` is `a < b ? a : b`, so with the new
//! value first they are exactly the scalar test's NaN-safe compare-and-select (a NaN lane keeps
//! the running value) in one instruction; portable code needs a compare and a three-instruction
//! select on SSE2 for each. The arithmetic is the same: `(plane - origin) * inv_dir`, times
//! the exit scale for the far plane, no FMA.

use std::arch::x86_64::{
    __m128, __m128i, __m256, __m256i, _CMP_LE_OQ, _mm_cmple_ps, _mm_loadl_epi64, _mm_max_ps,
    _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_set1_ps, _mm_sub_ps, _mm256_add_ps,
    _mm256_blendv_ps, _mm256_cmp_ps, _mm256_cvtepi32_ps, _mm256_cvtepu8_epi32, _mm256_load_ps,
    _mm256_loadu_si256, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps,
    _mm256_permutevar8x32_epi32, _mm256_set1_ps, _mm256_storeu_ps, _mm256_storeu_si256,
    _mm256_sub_ps,
};

use glam::Vec4;

use super::quantize::Grid;
use super::ray::{Planes, StreamPlanes, WideRay};
use super::rows::PlaneRows8;
use crate::geom::PreparedRay;
use crate::geom::aabb::EXIT_SCALE;
pub(crate) use crate::x86::Avx2;
use crate::x86::transpose;

/// See [`super::slabs::hits_planes`].
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

/// One ray against an 8-wide node's eight boxes (`rows`) with AVX2, twin of
/// [`super::slabs::slabs_by_halves`] (compared by `node8::tests`): lane by lane the arithmetic
/// of [`slabs`], with 8 lanes.
#[inline(always)]
pub(crate) fn slabs8(_: Avx2, ray: &WideRay, rows: &PlaneRows8, tmax: f32) -> (u32, [f32; 8]) {
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe { slabs8_avx2(ray, rows, tmax) }
}

/// See [`slabs8`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn slabs8_avx2(ray: &WideRay, rows: &PlaneRows8, tmax: f32) -> (u32, [f32; 8]) {
    // Each row is 32 bytes at a multiple of 32 from the rows' 32-byte alignment.
    // SAFETY: the row is eight initialised `f32`s, aligned to 32 bytes.
    let row = |row: usize| unsafe { _mm256_load_ps(rows[row].as_ptr()) };
    slab_rows8(ray, row, tmax)
}

/// One ray against a quantized 8-wide node's eight boxes (its grid and the steps of its boxes'
/// minima and maxima, per axis and slot) with AVX2, twin of
/// [`QuantizedWideNode8::hits_portable`](super::node8q::QuantizedWideNode8::hits_portable)
/// (compared by `quantize::tests`): each row's eight steps widened to `f32`, times the axis
/// step (exact: fewer than 256 steps of a power of two), plus the origin, the decode's own
/// arithmetic (`quantize::plane`); then [`slabs8`]'s test on them. All eight lanes, used or not
/// (the caller masks).
#[inline(always)]
pub(crate) fn slabs8q(
    _: Avx2,
    ray: &WideRay,
    node: (Grid, &[[u8; 8]; 3], &[[u8; 8]; 3]),
    tmax: f32,
) -> (u32, [f32; 8]) {
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe { slabs8q_avx2(ray, node, tmax) }
}

/// See [`slabs8q`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn slabs8q_avx2(
    ray: &WideRay,
    (grid, low, high): (Grid, &[[u8; 8]; 3], &[[u8; 8]; 3]),
    tmax: f32,
) -> (u32, [f32; 8]) {
    let (origin, steps) = (grid.origin, grid.steps());
    // Row `row` of the decoded planes (min x, y, z, max x, y, z), decoded where it is asked for.
    let row = |row: usize| {
        let (bytes, axis) = if row < 3 {
            (&low[row], row)
        } else {
            (&high[row - 3], row - 3)
        };
        // SAFETY: `bytes` is eight readable bytes; the load has no alignment requirement.
        let packed = unsafe { _mm_loadl_epi64(bytes.as_ptr().cast::<__m128i>()) };
        let lanes = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(packed));
        let offsets = _mm256_mul_ps(lanes, _mm256_set1_ps(steps[axis]));
        _mm256_add_ps(_mm256_set1_ps(origin[axis]), offsets)
    };
    slab_rows8(ray, row, tmax)
}

/// The 8-lane slab test on the six rows of planes `row` gives (0 to 5: min x, y, z, max x, y,
/// z), for [`slabs8`] (rows loaded straight from the node) and [`slabs8q`] (rows decoded).
#[inline]
#[target_feature(enable = "avx2")]
fn slab_rows8(ray: &WideRay, row: impl Fn(usize) -> __m256, tmax: f32) -> (u32, [f32; 8]) {
    let mut near = _mm256_set1_ps(ray.tmin.x);
    let mut far = _mm256_set1_ps(tmax.min(f32::MAX));
    let scale = _mm256_set1_ps(EXIT_SCALE);
    for axis in 0..3 {
        let o = _mm256_set1_ps(ray.origin[axis].x);
        let inv = _mm256_set1_ps(ray.inv_dir[axis].x);
        let negative = ((ray.octant >> axis) & 1) as usize;
        let near_plane = row(axis + 3 * negative);
        let far_plane = row(axis + 3 * (1 - negative));
        let enter = _mm256_mul_ps(_mm256_sub_ps(near_plane, o), inv);
        let exit = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far_plane, o), inv), scale);
        near = _mm256_max_ps(enter, near);
        far = _mm256_min_ps(exit, far);
    }
    let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
    let mut entries = [0.0; 8];
    // SAFETY: `entries` is 32 writable bytes of `f32`s; an unaligned store is allowed.
    unsafe { _mm256_storeu_ps(entries.as_mut_ptr(), near) };
    (mask, entries)
}

/// The stream split's box tests eight rays at a time, twin of its one-ray-at-a-time loop
/// (`stream::masks_one_by_one`, compared by `stream::tests`): for the first `8 * (ids.len() / 8)`
/// rays of `ids` (indices into `rays`), against the node's first `width` children, writes one
/// `u64` per eight rays to `group_bits` (byte `k`: which of the eight enter child `k`) and
/// returns how many rays that was and the number entering each child.
///
/// `octant_mask` is the stream's: one bit if all its rays share that octant, whose `planes`
/// the caller picked; 0 for rays of mixed octants, with the node's octant-0 planes (near the
/// box's minimum, far its maximum), which each lane swaps where its inverse direction is
/// negative (its sign bit: the ray's octant bit, `-0.0` included), picking exactly the planes
/// the ray's own octant would.
///
/// Lane `j` computes exactly what the one-ray box test ([`super::slabs::hits_planes`], or the
/// 8-wide node's) computes for ray `j`, one child at a time: the same subtractions and products
/// in the same order, the same NaN-keeping `max`/`min` fold and the same final compare. Panics
/// if an index is out of range.
#[inline(always)]
pub(crate) fn stream_masks(
    _: Avx2,
    (planes, width, octant_mask): (&StreamPlanes, usize, u8),
    rays: &[PreparedRay],
    ids: &[u32],
    group_bits: &mut [u64],
) -> (usize, [u32; 8]) {
    let node = (planes, width.min(8));
    // SAFETY: an `Avx2` exists only if the CPU has AVX2.
    unsafe {
        if octant_mask == 0 {
            stream_masks_avx2::<true>(node, rays, ids, group_bits)
        } else {
            stream_masks_avx2::<false>(node, rays, ids, group_bits)
        }
    }
}

/// See [`stream_masks`].
///
/// # Safety
/// The CPU must support AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn stream_masks_avx2<const MIXED: bool>(
    (planes, width): (&StreamPlanes, usize),
    rays: &[PreparedRay],
    ids: &[u32],
    group_bits: &mut [u64],
) -> (usize, [u32; 8]) {
    let groups = (ids.len() / 8).min(group_bits.len());
    let scale = _mm256_set1_ps(EXIT_SCALE);
    let mut counts = [0u32; 8];
    for g in 0..groups {
        let group = &ids[8 * g..8 * g + 8];
        prefetch_group(rays, ids, g + PREFETCH_GROUPS);
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
        for (child, count) in counts.iter_mut().enumerate().take(width) {
            let (mut near, mut far) = (tmin, tmax);
            for a in 0..3 {
                let mut near_plane = _mm256_set1_ps(planes.near[a][child]);
                let mut far_plane = _mm256_set1_ps(planes.far[a][child]);
                if MIXED {
                    (near_plane, far_plane) = (
                        _mm256_blendv_ps(near_plane, far_plane, inv[a]),
                        _mm256_blendv_ps(far_plane, near_plane, inv[a]),
                    );
                }
                let enter = _mm256_mul_ps(_mm256_sub_ps(near_plane, o[a]), inv[a]);
                let exit =
                    _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far_plane, o[a]), inv[a]), scale);
                near = _mm256_max_ps(enter, near);
                far = _mm256_min_ps(exit, far);
            }
            let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
            *count += hit.count_ones();
            bits |= u64::from(hit) << (8 * child);
        }
        group_bits[g] = bits;
    }
    (8 * groups, counts)
}

/// How many groups of eight ahead the split prefetches its rays. The rays of a list are
/// scattered over the walk's records (64 MiB for a walk of 1M rays), so each group's loads
/// would miss the caches one after another; prefetched 64 rays ahead they overlap (about 11%
/// faster on the bunny's incoherent rays, batched; 4 or 16 groups ahead do a little worse).
const PREFETCH_GROUPS: usize = 8;

/// Prefetches the rays of group `g` of `ids`, if there is such a group.
#[inline(always)]
fn prefetch_group(rays: &[PreparedRay], ids: &[u32], g: usize) {
    if let Some(group) = ids.get(8 * g..8 * g + 8) {
        for ray in group.iter().filter_map(|&i| rays.get(i as usize)) {
            crate::prefetch::prefetch(ray);
        }
    }
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
    group_bits: &[u64],
    cursor: &mut [usize],
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
    group_bits: &[u64],
    cursor: &mut [usize],
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
