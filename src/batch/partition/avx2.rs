//! AVX2 partition: 8 rays per step. AVX2 has no compress-store, so the touching lanes are
//! gathered to the bottom of the vector by a permute whose indices come from a 256-entry table
//! (one entry per 8-bit hit mask), and the whole vector is stored: the slots past the touching
//! lanes receive junk that later writes overwrite. The last partial step runs the portable
//! code, so nothing is written past `end`.

use std::arch::x86_64::*;

use super::EXIT_SCALE;
use super::portable::{Cursors, partition_lanes};
use crate::batch::lanes::{COLUMNS, IX, Lanes, OX, SPARE_PADDING, TMAX};
use crate::geom::Aabb;

/// For each 8-bit mask, the indices of its set bits in increasing order (then zeros).
static COMPRESS: [[u32; 8]; 256] = compress_table();

const fn compress_table() -> [[u32; 8]; 256] {
    let mut table = [[0u32; 8]; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut bit, mut k) = (0, 0);
        while bit < 8 {
            if mask & (1 << bit) != 0 {
                table[mask][k] = bit as u32;
                k += 1;
            }
            bit += 1;
        }
        mask += 1;
    }
    table
}

/// Entry point: checks the range and spare sizes the vector code relies on.
///
/// # Safety
/// The CPU must support AVX2 (checked once per batched call, see [`super::Partitioner`]).
pub(crate) unsafe fn partition(
    lanes: &mut Lanes,
    bounds: &Aabb,
    start: usize,
    end: usize,
) -> usize {
    assert!(start <= end && end <= lanes.len());
    assert!(
        lanes
            .spare
            .iter()
            .all(|s| s.len() >= end - start + SPARE_PADDING)
    );
    // SAFETY: AVX2 is available (the caller's contract), and the range and spare sizes the function
    // relies on were asserted above.
    let (cursors, done) = unsafe { partition_avx2(lanes, bounds, start, end) };
    let cursors = partition_lanes(lanes, bounds, done, end, cursors);
    // SAFETY: AVX2 is available; spare entries 0..missed hold the parked rays.
    unsafe { copy_back(lanes, cursors) };
    cursors.front - start
}

/// Copies the parked rays back behind the touching ones: 8 at a time, then one by one (a full
/// vector store past `end` would overwrite rays outside the range).
///
/// # Safety
/// Requires AVX2, and `front + missed <= lanes.len()`.
#[target_feature(enable = "avx2")]
unsafe fn copy_back(lanes: &mut Lanes, cursors: Cursors) {
    for k in 0..COLUMNS {
        let (src, dst) = (lanes.spare[k].as_ptr(), lanes.cols[k].as_mut_ptr());
        let mut j = 0;
        while j + 8 <= cursors.missed {
            // SAFETY: j + 8 <= missed entries of the spare, and front + missed <= len.
            unsafe {
                let v = _mm256_loadu_si256(src.add(j) as *const __m256i);
                _mm256_storeu_si256(dst.add(cursors.front + j) as *mut __m256i, v);
            }
            j += 8;
        }
        for j in j..cursors.missed {
            lanes.cols[k][cursors.front + j] = lanes.spare[k][j];
        }
    }
}

/// Partitions whole steps of 8 lanes; returns the cursors and the first lane not processed.
///
/// # Safety
/// Requires AVX2, `start <= end <= lanes.len()` and spare columns of at least
/// `end - start + 8` entries.
#[target_feature(enable = "avx2")]
unsafe fn partition_avx2(
    lanes: &mut Lanes,
    bounds: &Aabb,
    start: usize,
    end: usize,
) -> (Cursors, usize) {
    let cols: [*mut u32; COLUMNS] = std::array::from_fn(|k| lanes.cols[k].as_mut_ptr());
    let spare: [*mut u32; COLUMNS] = std::array::from_fn(|k| lanes.spare[k].as_mut_ptr());
    let zero = _mm256_setzero_ps();
    let scale = _mm256_set1_ps(EXIT_SCALE);
    let largest = _mm256_set1_ps(f32::MAX);
    let mins = [0, 1, 2].map(|a| _mm256_set1_ps(bounds.min[a]));
    let maxs = [0, 1, 2].map(|a| _mm256_set1_ps(bounds.max[a]));
    let mut cursors = Cursors {
        front: start,
        missed: 0,
    };
    let mut i = start;
    while i + 8 <= end {
        // SAFETY: lanes i..i + 8 are within 0..end <= len.
        let v: [__m256; COLUMNS] =
            std::array::from_fn(|k| unsafe { _mm256_loadu_ps(cols[k].add(i) as *const f32) });
        let mut near = zero;
        let mut far = _mm256_min_ps(v[TMAX], largest);
        for axis in 0..3 {
            let (o, inv) = (v[OX + axis], v[IX + axis]);
            let t0 = _mm256_mul_ps(_mm256_sub_ps(mins[axis], o), inv);
            let t1 = _mm256_mul_ps(_mm256_sub_ps(maxs[axis], o), inv);
            let negative = _mm256_cmp_ps::<_CMP_LT_OQ>(inv, zero);
            let enter = _mm256_blendv_ps(t0, t1, negative);
            let exit = _mm256_mul_ps(_mm256_blendv_ps(t1, t0, negative), scale);
            near = _mm256_blendv_ps(near, enter, _mm256_cmp_ps::<_CMP_GT_OQ>(enter, near));
            far = _mm256_blendv_ps(far, exit, _mm256_cmp_ps::<_CMP_LT_OQ>(exit, far));
        }
        let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as usize;
        let miss = !hit & 0xFF;
        // SAFETY: table entries are 8 u32 = 32 bytes.
        let (to_front, to_spare) = unsafe {
            (
                _mm256_loadu_si256(COMPRESS[hit].as_ptr() as *const __m256i),
                _mm256_loadu_si256(COMPRESS[miss].as_ptr() as *const __m256i),
            )
        };
        for k in 0..COLUMNS {
            // SAFETY: `front <= i`, so the 8 slots from `front` end at or before `i + 8`: lanes
            // already loaded. The spare holds `end - start + 8` entries and `missed <= i - start`.
            unsafe {
                _mm256_storeu_ps(
                    cols[k].add(cursors.front) as *mut f32,
                    _mm256_permutevar8x32_ps(v[k], to_front),
                );
                _mm256_storeu_ps(
                    spare[k].add(cursors.missed) as *mut f32,
                    _mm256_permutevar8x32_ps(v[k], to_spare),
                );
            }
        }
        cursors.front += hit.count_ones() as usize;
        cursors.missed += miss.count_ones() as usize;
        i += 8;
    }
    (cursors, i)
}
