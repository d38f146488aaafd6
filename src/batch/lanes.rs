//! The batch's active rays in structure-of-arrays form.
//!
//! Each ray is sixteen 32-bit columns: first what the box test reads (origin, inverse
//! direction, current range end, index in the batch), then what the triangle kernels read
//! (shear constants, direction, `tmin`, dominant axis). The move-to-front partition
//! ([`super::partition`]) moves all of it rather than indices into it, so each box test streams
//! through contiguous columns, 8 or 16 rays per instruction, and a leaf's triangle tests find
//! their rays' constants right there instead of gathering them from a ray array scattered over
//! megabytes (which cost a cache miss per ray and leaf). The kernels get a `PreparedRay`
//! rebuilt from the same bits, so they stay the very functions the single-ray path runs.

use glam::{BVec4A, Vec3, Vec4};

use crate::geom::PreparedRay;
#[cfg(target_arch = "x86_64")]
use crate::geom::box_octet::BoxOctet;
#[cfg(target_arch = "x86_64")]
use crate::geom::sign_filter::RayOctet;
use crate::geom::sign_filter::RayQuad;
#[cfg(target_arch = "x86_64")]
use crate::x86::Avx2;

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
/// Index of the ray in the batch (an integer column).
pub(crate) const ID: usize = 7;
/// Triangle-kernel constants: shear, (subnormal-flushed) direction, `tmin`, and the dominant
/// axis `kz` with the octant mask (an integer column: `kz | mask << 8`).
pub(crate) const SX: usize = 8;
pub(crate) const SY: usize = 9;
pub(crate) const SZ: usize = 10;
pub(crate) const DX: usize = 11;
pub(crate) const DY: usize = 12;
pub(crate) const DZ: usize = 13;
pub(crate) const TMIN: usize = 14;
pub(crate) const AXES: usize = 15;
pub(crate) const COLUMNS: usize = 16;

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
            ray.shear.x.to_bits(),
            ray.shear.y.to_bits(),
            ray.shear.z.to_bits(),
            ray.dir.x.to_bits(),
            ray.dir.y.to_bits(),
            ray.dir.z.to_bits(),
            ray.tmin.to_bits(),
            ray.kz as u32 | (ray.octant_mask as u32) << 8,
        ];
        for (col, v) in self.cols.iter_mut().zip(values) {
            col[lane] = v;
        }
    }

    /// The sign-filter constants of lanes `lane..lane + 4` (all below [`Lanes::len`]).
    #[inline(always)]
    pub fn quad(&self, lane: usize) -> RayQuad {
        let f = |c: usize| {
            let bits: &[u32; 4] = self.cols[c][lane..lane + 4].try_into().unwrap();
            Vec4::from_array(bits.map(f32::from_bits))
        };
        let axes: &[u32; 4] = self.cols[AXES][lane..lane + 4].try_into().unwrap();
        RayQuad {
            origin: [f(OX), f(OY), f(OZ)],
            shear_x: f(SX),
            shear_y: f(SY),
            kz_is_x: BVec4A::from(axes.map(|a| a & 0xFF == 0)),
            kz_is_y: BVec4A::from(axes.map(|a| a & 0xFF == 1)),
        }
    }

    /// The sign-filter constants of lanes `lane..lane + 8` (all below [`Lanes::len`]), eight
    /// at a time with AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn octet(&self, avx2: Avx2, lane: usize) -> RayOctet {
        let eight = |c: usize| -> &[u32; 8] { self.cols[c][lane..lane + 8].try_into().unwrap() };
        RayOctet::from_columns(
            avx2,
            [eight(OX), eight(OY), eight(OZ)],
            [eight(SX), eight(SY)],
            eight(AXES),
        )
    }

    /// Lanes `lane..lane + count` (`1 <= count <= 8`, all below [`Lanes::len`]) copied out as
    /// a [`Block`], for the packet walk; the block's lanes past `count` hold other rays (the
    /// next lanes, or copies of lane `lane` at the end of the columns), which the walk leaves
    /// out of every mask.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn block(&self, lane: usize, count: usize) -> Block {
        debug_assert!((1..=8).contains(&count) && lane + count <= self.len());
        let mut block = Block {
            cols: [[0; 8]; COLUMNS],
        };
        if lane + 8 <= self.len() {
            for (out, col) in block.cols.iter_mut().zip(&self.cols) {
                *out = col[lane..lane + 8].try_into().unwrap();
            }
        } else {
            for (out, col) in block.cols.iter_mut().zip(&self.cols) {
                for (j, value) in out.iter_mut().enumerate() {
                    *value = col[lane + if j < count { j } else { 0 }];
                }
            }
        }
        block
    }

    /// The prepared ray in lane `lane`, bit for bit as it was written (with the current
    /// range end).
    #[inline(always)]
    pub fn ray(&self, lane: usize) -> PreparedRay {
        ray_from_columns(|c| self.cols[c][lane])
    }

    /// The origin of the ray in `lane`.
    #[inline(always)]
    pub fn origin(&self, lane: usize) -> Vec3 {
        let f = |c: usize| f32::from_bits(self.cols[c][lane]);
        Vec3::new(f(OX), f(OY), f(OZ))
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

    #[inline(always)]
    pub fn set_tmin(&mut self, lane: usize, tmin: f32) {
        self.cols[TMIN][lane] = tmin.to_bits();
    }
}

/// Eight lanes of the columns, copied next to each other ([`Lanes::block`]): the rays of a
/// packet walk (`traverse::packet`, x86-64 only).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(align(32))]
pub(crate) struct Block {
    pub cols: [[u32; 8]; COLUMNS],
}

#[cfg(target_arch = "x86_64")]
impl Block {
    /// The prepared ray in lane `j`, bit for bit as it was written (with the range end it had
    /// when the block was copied).
    #[inline(always)]
    pub fn ray(&self, j: usize) -> PreparedRay {
        ray_from_columns(|c| self.cols[c][j])
    }

    /// The range ends of the eight lanes.
    #[inline(always)]
    pub fn tmax(&self) -> [f32; 8] {
        self.cols[TMAX].map(f32::from_bits)
    }

    /// The batch positions of the eight lanes.
    #[inline(always)]
    pub fn ids(&self) -> [u32; 8] {
        self.cols[ID]
    }

    /// The sign-filter constants of the eight lanes.
    #[inline(always)]
    pub(crate) fn octet(&self, avx2: Avx2) -> RayOctet {
        let c = &self.cols;
        RayOctet::from_columns(avx2, [&c[OX], &c[OY], &c[OZ]], [&c[SX], &c[SY]], &c[AXES])
    }

    /// The slab-test constants of the eight lanes.
    #[inline(always)]
    pub(crate) fn boxes(&self, avx2: Avx2) -> BoxOctet {
        let c = &self.cols;
        BoxOctet::from_columns(
            avx2,
            [&c[OX], &c[OY], &c[OZ]],
            [&c[IX], &c[IY], &c[IZ]],
            &c[TMIN],
        )
    }
}

/// The prepared ray whose column `c` holds `word(c)`, bit for bit as it was written: the one
/// decoding of a lane, for [`Lanes`] and the packet walk's copies.
#[inline(always)]
fn ray_from_columns(word: impl Fn(usize) -> u32) -> PreparedRay {
    let f = |c: usize| f32::from_bits(word(c));
    let axes = word(AXES);
    PreparedRay {
        origin: Vec3::new(f(OX), f(OY), f(OZ)),
        dir: Vec3::new(f(DX), f(DY), f(DZ)),
        inv_dir: Vec3::new(f(IX), f(IY), f(IZ)),
        tmin: f(TMIN),
        tmax: f(TMAX),
        octant_mask: (axes >> 8) as u8,
        kz: axes as u8,
        shear: Vec3::new(f(SX), f(SY), f(SZ)),
        pad: [0; 6],
    }
}
