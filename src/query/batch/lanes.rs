//! The batch's active rays in structure-of-arrays form.
//!
//! Each ray keeps only what the box test reads: origin, inverse direction, current range end
//! and its index in the batch, as eight 32-bit columns. The move-to-front partition
//! ([`super::partition`]) moves the ray data itself rather than indices into it, so each box
//! test streams through contiguous columns, 8 or 16 rays per instruction. The triangle
//! kernels, which run far less often, read the full per-ray constants (`PreparedRay`) by index,
//! which keeps them the very functions the single-ray path runs.

use crate::geom::PreparedRay;

/// Column indices.
pub(crate) const OX: usize = 0;
pub(crate) const OY: usize = 1;
pub(crate) const OZ: usize = 2;
pub(crate) const IX: usize = 3;
pub(crate) const IY: usize = 4;
pub(crate) const IZ: usize = 5;
/// Current upper end of the range: the best hit so far for closest-hit queries, `-inf` once an
/// any-hit ray is answered (so every later box test drops it).
pub(crate) const TMAX: usize = 6;
/// Index of the ray in the batch (the only integer column).
pub(crate) const ID: usize = 7;
pub(crate) const COLUMNS: usize = 8;

/// Extra spare slots: vector stores may write a full vector past the last miss.
pub(crate) const SPARE_PADDING: usize = 16;

/// The active rays of one batch chunk, as bit patterns (floats are stored with `to_bits`).
#[derive(Clone, Debug, Default)]
pub(crate) struct Lanes {
    pub cols: [Vec<u32>; COLUMNS],
    /// Where a partition parks the rays that miss before copying them back behind the hits.
    pub spare: [Vec<u32>; COLUMNS],
}

impl Lanes {
    /// Makes room for `n` lanes (contents unspecified until [`Lanes::set`]) and sizes the spare
    /// columns.
    pub fn reset(&mut self, n: usize) {
        for col in &mut self.cols {
            col.resize(n, 0);
        }
        for s in &mut self.spare {
            s.resize(n + SPARE_PADDING, 0);
        }
    }

    pub fn len(&self) -> usize {
        self.cols[ID].len()
    }

    /// Writes ray `id` into lane `lane`.
    #[inline(always)]
    pub fn set(&mut self, lane: usize, ray: &PreparedRay, id: u32) {
        let values = [
            ray.origin.x.to_bits(),
            ray.origin.y.to_bits(),
            ray.origin.z.to_bits(),
            ray.inv_dir.x.to_bits(),
            ray.inv_dir.y.to_bits(),
            ray.inv_dir.z.to_bits(),
            ray.tmax.to_bits(),
            id,
        ];
        for (col, v) in self.cols.iter_mut().zip(values) {
            col[lane] = v;
        }
    }

    #[inline(always)]
    pub fn id(&self, lane: usize) -> u32 {
        self.cols[ID][lane]
    }

    #[inline(always)]
    pub fn tmax(&self, lane: usize) -> f32 {
        f32::from_bits(self.cols[TMAX][lane])
    }

    #[inline(always)]
    pub fn set_tmax(&mut self, lane: usize, tmax: f32) {
        self.cols[TMAX][lane] = tmax.to_bits();
    }
}
