//! What the wide box tests take, shared by the node layouts, their SIMD and the walks: a ray's
//! constants ([`WideRay`], with what its box tests may use, [`BoxSimd`]) and a node's planes as
//! a ray of one direction octant meets them, four lanes ([`Planes`]) or up to eight for a
//! stream ([`StreamPlanes`]).

use glam::{Vec3, Vec4};

use crate::geom::PreparedRay;

/// What the 8-lane box test may use: the AVX2 token where the CPU has AVX2 and the loop's
/// copy may use it (x86-64), nothing elsewhere. Found once per loop, not per ray.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BoxSimd {
    #[cfg(target_arch = "x86_64")]
    avx2: Option<crate::x86::Avx2>,
}

impl BoxSimd {
    /// The portable box test: the loops' baseline copies, and the 4-wide tree's loops (whose
    /// box test needs no token).
    pub(crate) const PORTABLE: BoxSimd = BoxSimd {
        #[cfg(target_arch = "x86_64")]
        avx2: None,
    };

    /// AVX2 if `wanted` and the CPU has it, else [`BoxSimd::PORTABLE`].
    pub(crate) fn detect(wanted: bool) -> Self {
        #[cfg(target_arch = "x86_64")]
        if wanted {
            return BoxSimd {
                avx2: crate::x86::Avx2::detect(),
            };
        }
        let _ = wanted;
        Self::PORTABLE
    }

    /// The AVX2 token, if the 8-lane test may use it.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn avx2(self) -> Option<crate::x86::Avx2> {
        self.avx2
    }
}

/// Per-ray constants of the box tests (4 and 8 lanes), computed once per ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WideRay {
    pub(crate) origin: [Vec4; 3],
    pub(crate) inv_dir: [Vec4; 3],
    /// The ray's direction octant ([`crate::geom::octant`] of the sign bits of `inv_dir`,
    /// which are the direction's): which planes of a node are near.
    pub(crate) octant: u32,
    pub(crate) tmin: Vec4,
    /// What the 8-wide node's box test may use (read on x86-64 only: elsewhere there is
    /// nothing to choose).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) simd: BoxSimd,
}

impl WideRay {
    /// The constants of `ray`, for box tests that may use `simd`.
    #[inline(always)]
    pub(crate) fn new(ray: &PreparedRay, simd: BoxSimd) -> Self {
        let (origin, inv_dir, tmin) = (ray.origin, ray.inv_dir, ray.tmin);
        let splat = |v: Vec3| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        Self {
            origin: splat(origin),
            inv_dir: splat(inv_dir),
            octant: (inv_dir.x < 0.0) as u32
                | ((inv_dir.y < 0.0) as u32) << 1
                | ((inv_dir.z < 0.0) as u32) << 2,
            tmin: Vec4::splat(tmin),
            simd,
        }
    }
}

/// A node's six planes as one ray (or a stream of rays of one direction octant) meets them:
/// per axis the near plane (the max plane when the direction is negative) and the far plane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Planes {
    pub(crate) near: [Vec4; 3],
    pub(crate) far: [Vec4; 3],
}

/// The most children a node has: the lanes of [`StreamPlanes`] and of the stream engine's
/// per-child arrays.
pub(crate) const MAX_WIDTH: usize = 8;

/// A node's child planes as a stream of rays of one direction octant meets them (see
/// [`Planes`]), lane `k` for slot `k` of up to [`MAX_WIDTH`].
/// (Read by the AVX2 split only, on x86-64.)
#[derive(Clone, Copy, Debug)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) struct StreamPlanes {
    pub(crate) near: [[f32; MAX_WIDTH]; 3],
    pub(crate) far: [[f32; MAX_WIDTH]; 3],
}

impl StreamPlanes {
    /// The planes of an 8-wide node's rows (min x, y, z, max x, y, z; see
    /// [`super::node8::WideNode8`]) as rays of direction octant `octant` meet them.
    pub(crate) fn from_rows(rows: &[[f32; MAX_WIDTH]; 6], octant: u32) -> Self {
        let negative = |axis: usize| ((octant >> axis) & 1) as usize;
        StreamPlanes {
            near: std::array::from_fn(|axis| rows[axis + 3 * negative(axis)]),
            far: std::array::from_fn(|axis| rows[axis + 3 * (1 - negative(axis))]),
        }
    }

    /// The planes of a 4-wide node ([`Planes`]), in lanes 0 to 3.
    pub(crate) fn from_four(planes: &Planes) -> Self {
        let lanes = |row: Vec4| {
            let mut lanes = [0.0; MAX_WIDTH];
            lanes[..4].copy_from_slice(&row.to_array());
            lanes
        };
        StreamPlanes {
            near: planes.near.map(lanes),
            far: planes.far.map(lanes),
        }
    }
}
