//! Rays and segments, and the per-ray constants that traversal precomputes.
//!
//! A [`Ray`] is the half-open line `origin + t * dir` restricted to `tmin <= t <= tmax` (both ends
//! inclusive). `dir` does not need to be normalised: `t` is measured in units of `dir`, so a
//! segment from `a` to `b` is simply `dir = b - a`, `tmax = 1`.
//!
//! Queries never panic on a bad ray: a ray whose origin or direction is NaN or infinite, whose
//! direction is zero, or whose range is empty or NaN misses everything. [`Ray::validate`] says why.

use glam::{BVec3A, Vec3, Vec3A, Vec3Swizzles};

/// A ray `origin + t * dir` for `t` in `[tmin, tmax]`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Ray {
    /// Where the ray starts (at `t = 0`).
    pub origin: Vec3,
    /// The direction; any length except zero.
    pub dir: Vec3,
    /// Smallest accepted `t` (inclusive); must be `>= 0`.
    pub tmin: f32,
    /// Largest accepted `t` (inclusive); `f32::INFINITY` for an unbounded ray.
    pub tmax: f32,
}

// Eight `f32`s in this order: batches load eight rays as eight rows (`batch::prepare_avx2`).
const _: () = {
    use std::mem::offset_of;
    assert!(offset_of!(Ray, origin) == 0 && offset_of!(Ray, dir) == 12);
    assert!(offset_of!(Ray, tmin) == 24 && offset_of!(Ray, tmax) == 28 && size_of::<Ray>() == 32);
};

/// Why a ray can never hit anything. Queries treat such rays as misses that are occluded
/// (no hit, no hits, and `occluded` true: line of sight fails closed); this says why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayError {
    /// A component of the origin is NaN or infinite.
    NonFiniteOrigin,
    /// A component of the direction is NaN or infinite.
    NonFiniteDirection,
    /// The direction is zero (or every component is below `f32::MIN_POSITIVE`, see
    /// [`Ray::validate`]).
    ZeroDirection,
    /// `tmin` or `tmax` is NaN, `tmin` is negative or infinite, or `tmin > tmax`.
    InvalidRange,
}

impl std::fmt::Display for RayError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            RayError::NonFiniteOrigin => "ray origin is NaN or infinite",
            RayError::NonFiniteDirection => "ray direction is NaN or infinite",
            RayError::ZeroDirection => "ray direction is zero",
            RayError::InvalidRange => {
                "ray range is empty, negative or NaN (need 0 <= tmin <= tmax)"
            }
        })
    }
}

impl std::error::Error for RayError {}

impl Ray {
    /// An unbounded ray: `tmin = 0`, `tmax = +inf`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self::with_range(origin, dir, 0.0, f32::INFINITY)
    }

    /// A ray restricted to `[tmin, tmax]`.
    pub fn with_range(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Self {
            origin,
            dir,
            tmin,
            tmax,
        }
    }

    /// The segment from `from` to `to`, both ends included: `dir = to - from`, `t` in `[0, 1]`.
    /// A hit's `t` is the fraction of the way from `from` to `to`.
    pub fn segment(from: Vec3, to: Vec3) -> Self {
        Self::with_range(from, to - from, 0.0, 1.0)
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// Checks that the ray can hit something; queries treat an invalid ray as a miss that is
    /// occluded (see [`RayError`]).
    ///
    /// Direction components smaller in magnitude than `f32::MIN_POSITIVE` (subnormals) are
    /// treated as zero by every query (their reciprocal would overflow); a direction made only of
    /// such components is reported as [`RayError::ZeroDirection`].
    pub fn validate(&self) -> Result<(), RayError> {
        if !self.origin.is_finite() {
            return Err(RayError::NonFiniteOrigin);
        }
        if !self.dir.is_finite() {
            return Err(RayError::NonFiniteDirection);
        }
        if flush_subnormals(self.dir) == Vec3::ZERO {
            return Err(RayError::ZeroDirection);
        }
        // Written so that NaN fails every comparison and lands in the error.
        let range_ok = self.tmin >= 0.0 && self.tmin <= self.tmax && self.tmin.is_finite();
        if !range_ok {
            return Err(RayError::InvalidRange);
        }
        Ok(())
    }

    /// True if [`Ray::validate`] passes.
    pub fn is_valid(&self) -> bool {
        self.validate().is_ok()
    }
}

/// Replaces subnormal components (and -0) by +0 or -0 of the same sign: `1 / x` must not overflow.
#[inline]
pub(crate) fn flush_subnormals(v: Vec3) -> Vec3 {
    // Lane-wise: a NaN compares false and is kept, as the scalar rule would keep it.
    let v = Vec3A::from(v);
    let tiny = v.abs().cmplt(Vec3A::splat(f32::MIN_POSITIVE));
    Vec3::from(Vec3A::select(tiny, Vec3A::ZERO.copysign(v), v))
}

/// The ray's direction with subnormals flushed ([`flush_subnormals`]) if the ray is valid
/// ([`Ray::validate`]'s checks, without branching between them), else `None`.
#[inline]
pub(crate) fn flushed_if_valid(ray: &Ray) -> Option<Vec3> {
    let finite = Vec3A::from(ray.origin).is_finite_mask() & Vec3A::from(ray.dir).is_finite_mask();
    let dir = flush_subnormals(ray.dir);
    // Written so that NaN fails every comparison and lands in the error.
    let range_ok = (ray.tmin >= 0.0) & (ray.tmin <= ray.tmax) & ray.tmin.is_finite();
    (finite.all() & (dir != Vec3::ZERO) & range_ok).then_some(dir)
}

/// Index (0..8) of a direction's octant: bit 0 set if `x` is negative, bit 1 for `y`, bit 2 for
/// `z`. The sign bit is used, so `-0.0` counts as negative, consistently everywhere.
pub fn octant(dir: Vec3) -> u32 {
    (dir.x.is_sign_negative() as u32)
        | ((dir.y.is_sign_negative() as u32) << 1)
        | ((dir.z.is_sign_negative() as u32) << 2)
}

/// The per-ray constants every kernel needs, computed once per query.
///
/// Both the box test and the triangle tests read the same (subnormal-flushed) direction, so they
/// agree on which ray they test.
///
/// The layout is fixed (`repr(C)`, one 64-byte cache line): the box test's eight values
/// (origin, inverse direction, range) come first, so the 4-wide stream split loads them as one
/// 32-byte row per ray and transposes eight rows into eight SIMD columns.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct PreparedRay {
    /// The ray's origin.
    pub origin: Vec3,
    /// `1 / dir`, `+-inf` on zero components (see [`crate::geom::aabb`] for why that is safe).
    pub inv_dir: Vec3,
    /// Smallest accepted `t`.
    pub tmin: f32,
    /// Largest accepted `t` (the current range end during traversal).
    pub tmax: f32,
    /// The direction, subnormal components flushed to (signed) zero.
    pub dir: Vec3,
    /// Watertight kernel: shear constants `dir[kx]/dir[kz]`, `dir[ky]/dir[kz]`, `1/dir[kz]`.
    pub shear: Vec3,
    /// `1 << octant(dir)`: ANDed with a node's ordering byte to pick the child visited first.
    pub octant_mask: u8,
    /// Watertight kernel: the axis of largest `|dir|`, which becomes z after the shear;
    /// x and y are the next two axes cyclically (`kx = (kz + 1) % 3`, `ky = (kz + 2) % 3`).
    pub kz: u8,
    /// The rest of the cache line, zero: set so that the 4-wide stream's leaves may load the
    /// second half of the record as eight values (`wide::simd::RayOctet`) and read no
    /// uninitialised byte.
    pub(crate) pad: [u8; 6],
}

// The box test's row: origin x, y, z, inverse direction x, y, z, `tmin`, `tmax`.
const _: () = {
    use std::mem::offset_of;
    assert!(offset_of!(PreparedRay, origin) == 0 && offset_of!(PreparedRay, inv_dir) == 12);
    assert!(offset_of!(PreparedRay, tmin) == 24 && offset_of!(PreparedRay, tmax) == 28);
    assert!(offset_of!(PreparedRay, shear) == 44 && offset_of!(PreparedRay, kz) == 57);
    assert!(size_of::<PreparedRay>() == 64 && offset_of!(PreparedRay, pad) == 58);
};

impl PreparedRay {
    /// Precomputes the kernel constants; `None` if the ray is invalid (it misses everything).
    /// The same checks as [`Ray::validate`], written to flush the direction once.
    #[inline]
    pub fn new(ray: &Ray) -> Option<Self> {
        flushed_if_valid(ray).map(|dir| Self::from_flushed(ray, dir))
    }

    pub(crate) fn from_valid(ray: &Ray) -> Self {
        debug_assert!(ray.is_valid());
        Self::from_flushed(ray, flush_subnormals(ray.dir))
    }

    /// The constants of a valid ray whose direction, subnormals flushed, is `dir`.
    #[inline]
    pub(crate) fn from_flushed(ray: &Ray, dir: Vec3) -> Self {
        let abs = dir.abs();
        // Selects rather than branches: the dominant axis of random rays is unpredictable.
        let x_wins = (abs.x >= abs.y) & (abs.x >= abs.z);
        let y_wins = abs.y >= abs.z;
        let kz = if x_wins { 0 } else { 1 + !y_wins as usize };
        // Woop et al. swap kx and ky when dir[kz] < 0 to keep the projected winding; since both
        // windings are accepted, that swap only negates U, V, W, det and T exactly, leaving
        // t, u, v bit-identical, so it is skipped and the axes depend on kz alone.
        // (kx, ky, kz) = (kz + 1, kz + 2, kz) mod 3: the direction rotated so that kz comes
        // last, picked by selects (indexing an array by kz went through memory, on the path
        // from the ray to its first triangle test).
        let d = Vec3A::from(dir);
        let kz_is = |axis| BVec3A::splat(kz == axis);
        let rotated = Vec3A::select(kz_is(0), d.yzx(), Vec3A::select(kz_is(1), d.zxy(), d));
        // One vector division: the same IEEE quotients as three scalar ones.
        let shear = Vec3::from(Vec3A::new(rotated.x, rotated.y, 1.0) / Vec3A::splat(rotated.z));
        // One vector division; the same IEEE quotients as three scalar ones.
        let inv_dir = Vec3::from(Vec3A::ONE / Vec3A::from(dir));
        Self {
            origin: ray.origin,
            dir,
            inv_dir,
            tmin: ray.tmin,
            tmax: ray.tmax,
            octant_mask: 1u8 << octant(dir),
            kz: kz as u8,
            shear,
            pad: [0; 6],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane-wise flush and the branch-free dominant axis agree with their scalar
    /// definitions on every special value, ties included (the kernel's axes depend on them).
    #[test]
    fn flush_and_dominant_axis_match_their_scalar_definitions() {
        let flush = |x: f32| {
            if x.abs() < f32::MIN_POSITIVE {
                0.0f32.copysign(x)
            } else {
                x
            }
        };
        let special = [
            0.0,
            -0.0,
            1e-40,
            -1e-40,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1.0,
            -1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for &x in &special {
            for &y in &special {
                for &z in &special {
                    let v = Vec3::new(x, y, z);
                    let got = flush_subnormals(v).to_array().map(f32::to_bits);
                    let want = [flush(x), flush(y), flush(z)].map(f32::to_bits);
                    assert_eq!(got, want, "{v:?}");
                    let Some(ray) = PreparedRay::new(&Ray::new(Vec3::ZERO, v)) else {
                        continue;
                    };
                    let a = ray.dir.abs();
                    let kz = if a.x >= a.y && a.x >= a.z {
                        0
                    } else if a.y >= a.z {
                        1
                    } else {
                        2
                    };
                    assert_eq!(ray.kz, kz, "{v:?}");
                    assert_eq!(ray.octant_mask, 1 << octant(ray.dir), "{v:?}");
                }
            }
        }
    }

    #[test]
    fn validation_names_the_problem() {
        let o = Vec3::ZERO;
        let d = Vec3::X;
        assert_eq!(
            Ray::new(Vec3::NAN, d).validate(),
            Err(RayError::NonFiniteOrigin)
        );
        assert_eq!(
            Ray::new(o, Vec3::new(f32::INFINITY, 0.0, 0.0)).validate(),
            Err(RayError::NonFiniteDirection)
        );
        assert_eq!(
            Ray::new(o, Vec3::ZERO).validate(),
            Err(RayError::ZeroDirection)
        );
        assert_eq!(
            Ray::new(o, Vec3::splat(1e-40)).validate(),
            Err(RayError::ZeroDirection)
        );
        assert_eq!(
            Ray::with_range(o, d, 2.0, 1.0).validate(),
            Err(RayError::InvalidRange)
        );
        assert_eq!(
            Ray::with_range(o, d, -1.0, 1.0).validate(),
            Err(RayError::InvalidRange)
        );
        assert_eq!(
            Ray::with_range(o, d, f32::NAN, 1.0).validate(),
            Err(RayError::InvalidRange)
        );
        assert_eq!(
            Ray::with_range(o, d, 0.0, f32::NAN).validate(),
            Err(RayError::InvalidRange)
        );
        assert!(Ray::new(o, d).is_valid());
        assert!(Ray::segment(o, Vec3::ONE).is_valid());
        assert!(Ray::segment(o, o).validate() == Err(RayError::ZeroDirection));
    }

    #[test]
    fn octant_uses_sign_bits() {
        assert_eq!(octant(Vec3::new(1.0, 1.0, 1.0)), 0);
        assert_eq!(octant(Vec3::new(-0.0, 1.0, 1.0)), 1);
        assert_eq!(octant(Vec3::new(1.0, -2.0, -0.0)), 6);
    }
}
