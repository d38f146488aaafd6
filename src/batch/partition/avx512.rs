//! AVX-512 partition: 16 rays per step. The slab test runs on 16 lanes with mask registers;
//! the touching rays are compressed (in registers) and stored forward in place, the others
//! compressed into the spare columns. The last partial step uses masked loads, so nothing is read or written past
//! `end`.

use std::arch::x86_64::*;

use super::EXIT_SCALE;
use super::portable::Cursors;
use crate::batch::lanes::{COLUMNS, IX, Lanes, OX, TMAX};
use crate::geom::Aabb;

/// Entry point: checks the range and spare sizes the vector code relies on.
///
/// # Safety
/// The CPU must support AVX-512F (checked once per batched call, see [`super::Partitioner`]).
pub(crate) unsafe fn partition(
    lanes: &mut Lanes,
    bounds: &Aabb,
    start: usize,
    end: usize,
) -> usize {
    assert!(start <= end && end <= lanes.len());
    assert!(lanes.spare.iter().all(|s| s.len() >= end - start));
    // SAFETY: AVX-512F is available (the caller's contract), and the range and spare sizes the
    // function relies on were asserted above.
    unsafe { partition_avx512(lanes, bounds, start, end) }
}

/// The mask of the lowest `n` of 16 lanes.
fn low_bits(n: u32) -> __mmask16 {
    ((1u32 << n) - 1) as __mmask16
}

/// # Safety
/// Requires AVX-512F, `start <= end <= lanes.len()` and spare columns of at least
/// `end - start` entries.
#[target_feature(enable = "avx512f")]
unsafe fn partition_avx512(lanes: &mut Lanes, bounds: &Aabb, start: usize, end: usize) -> usize {
    let cols: [*mut u32; COLUMNS] = std::array::from_fn(|k| lanes.cols[k].as_mut_ptr());
    let spare: [*mut u32; COLUMNS] = std::array::from_fn(|k| lanes.spare[k].as_mut_ptr());
    let zero = _mm512_setzero_ps();
    let scale = _mm512_set1_ps(EXIT_SCALE);
    let largest = _mm512_set1_ps(f32::MAX);
    let mins = [0, 1, 2].map(|a| _mm512_set1_ps(bounds.min[a]));
    let maxs = [0, 1, 2].map(|a| _mm512_set1_ps(bounds.max[a]));
    let mut cursors = Cursors {
        front: start,
        missed: 0,
    };
    let mut i = start;
    while i < end {
        let remaining = end - i;
        let valid: __mmask16 = if remaining >= 16 {
            0xFFFF
        } else {
            (1u16 << remaining) - 1
        };
        // SAFETY: lanes i..i + 16 masked by `valid` are within 0..end <= len.
        let v: [__m512; COLUMNS] = std::array::from_fn(|k| unsafe {
            _mm512_maskz_loadu_ps(valid, cols[k].add(i) as *const f32)
        });
        let mut near = zero;
        let mut far = _mm512_min_ps(v[TMAX], largest);
        for axis in 0..3 {
            let (o, inv) = (v[OX + axis], v[IX + axis]);
            let t0 = _mm512_mul_ps(_mm512_sub_ps(mins[axis], o), inv);
            let t1 = _mm512_mul_ps(_mm512_sub_ps(maxs[axis], o), inv);
            let negative = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(inv, zero);
            let enter = _mm512_mask_blend_ps(negative, t0, t1);
            let exit = _mm512_mul_ps(_mm512_mask_blend_ps(negative, t1, t0), scale);
            near = _mm512_mask_mov_ps(near, _mm512_cmp_ps_mask::<_CMP_GT_OQ>(enter, near), enter);
            far = _mm512_mask_mov_ps(far, _mm512_cmp_ps_mask::<_CMP_LT_OQ>(exit, far), exit);
        }
        let hit = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(near, far) & valid;
        let miss = !hit & valid;
        let (hits, misses) = (hit.count_ones(), miss.count_ones());
        let (front_mask, spare_mask) = (low_bits(hits), low_bits(misses));
        for k in 0..COLUMNS {
            // Compress in registers, then a masked store: the memory form of vcompressps is
            // microcoded and several times slower on current cores.
            let to_front = _mm512_maskz_compress_ps(hit, v[k]);
            let to_spare = _mm512_maskz_compress_ps(miss, v[k]);
            // SAFETY: `front <= i` and the store covers `hits` lanes, so it stays within lanes
            // already loaded; the spare holds `end - start` entries and `missed + misses` of
            // them are consumed lanes.
            unsafe {
                _mm512_mask_storeu_ps(cols[k].add(cursors.front) as *mut f32, front_mask, to_front);
                _mm512_mask_storeu_ps(
                    spare[k].add(cursors.missed) as *mut f32,
                    spare_mask,
                    to_spare,
                );
            }
        }
        cursors.front += hits as usize;
        cursors.missed += misses as usize;
        i += 16;
    }
    // Copy the parked rays back behind the touching ones, 16 at a time.
    let mut j = 0;
    while j < cursors.missed {
        let left = cursors.missed - j;
        let valid: __mmask16 = if left >= 16 {
            0xFFFF
        } else {
            (1u16 << left) - 1
        };
        for k in 0..COLUMNS {
            // SAFETY: spare entries 0..missed were written above; `front + missed == end`.
            unsafe {
                let v = _mm512_maskz_loadu_ps(valid, spare[k].add(j) as *const f32);
                _mm512_mask_storeu_ps(cols[k].add(cursors.front + j) as *mut f32, valid, v);
            }
        }
        j += 16;
    }
    cursors.front - start
}
