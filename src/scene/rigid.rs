//! [`Rigid`]: where an instance sits in the world (a rotation, a uniform scale and a
//! translation), and the one documented way a world ray is carried into the instance's mesh
//! space.

use glam::{Mat3, Quat, Vec3};

use crate::geom::ray::flush_subnormals;
use crate::geom::{PreparedRay, Ray};
use crate::scene::error::SceneError;

/// How far a rotation's quaternion may be from unit length (squared norm within `1 +- this`)
/// before it is rejected as non-rigid rather than renormalised.
pub const RIGID_TOLERANCE: f32 = 1e-4;

/// A rigid transform with an optional uniform scale, mesh space to world space:
/// `world = rotation * (scale * mesh) + translation` (the scale 1 unless set by
/// [`Rigid::with_scale`]). Built only through [`Rigid::new`] (or the constants), so every
/// value is finite, its rotation a unit quaternion and its scale within [`Rigid::SCALES`].
///
/// **The transform contract.** A scene answers a world ray on an instance by tracing the ray
/// [`Rigid::ray_to_mesh`] returns, exactly (watertight kernel, tie rule) against the instance's
/// mesh. That function is the definition: `origin' = M * (origin - translation)` and
/// `dir' = M * dir` (the direction with subnormal components flushed, as every query does), with
/// `M` the transpose of the rotation's matrix times `1 / scale` (in `f32`, as
/// [`Rigid::with_scale`] computes it once) and
/// each product evaluated as `M.x_axis * v.x + M.y_axis * v.y + M.z_axis * v.z`, left to right,
/// without FMA; `tmin` and `tmax` are kept, so a scaled instance's `t` is the world `t` too. An
/// instance whose rotation is exactly the identity and scale exactly 1 skips the product:
/// `origin' = origin - translation`, `dir' = dir`, so at the identity transform a scene answers
/// bit for bit as the bare tree.
///
/// The direction is rotated, not renormalised: a rotation preserves lengths, so the mesh-space
/// `t` is the world `t` (in units of the world ray's direction) up to the rounding of the
/// products: the mesh-space origin and direction are each off by a few units in the last place
/// of their own size, which moves a hit at mesh-space point `p` by about
/// `10 eps (|origin - translation| + |p|)` along the ray (`eps = 2^-23`), so its `t` by that
/// over `|dir|`: small next to `t` unless the origin is far from the instance compared with the
/// hit distance. A scale divides mesh-space lengths by itself and leaves `t` as it is: the
/// same bound holds with `|origin - translation|` over the scale. Hits of different instances
/// are compared by that `t`, and the tie rule then picks the lowest global triangle id.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    rotation: Quat,
    scale: f32,
    translation: Vec3,
    /// Mesh to world matrix (columns: the rotation's times the scale), for world boxes.
    to_world: Mat3,
    /// World to mesh matrix: the rotation's transpose times `1 / scale`.
    to_mesh: Mat3,
    /// True unless the rotation is exactly the identity quaternion and the scale exactly 1.
    rotated_or_scaled: bool,
}

impl Default for Rigid {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Rigid {
    /// The identity: mesh space is world space.
    pub const IDENTITY: Rigid = Rigid {
        rotation: Quat::IDENTITY,
        scale: 1.0,
        translation: Vec3::ZERO,
        to_world: Mat3::IDENTITY,
        to_mesh: Mat3::IDENTITY,
        rotated_or_scaled: false,
    };

    /// The transform rotating by `rotation`, then moving by `translation`. The quaternion is
    /// renormalised if its squared length is within [`RIGID_TOLERANCE`] of 1; anything else
    /// (a scale, a shear, a NaN or infinity) is a [`SceneError`].
    pub fn new(rotation: Quat, translation: Vec3) -> Result<Self, SceneError> {
        if !rotation.is_finite() || !translation.is_finite() {
            return Err(SceneError::NonFiniteTransform);
        }
        let norm2 = rotation.length_squared();
        if (norm2 - 1.0).abs() > RIGID_TOLERANCE {
            return Err(SceneError::NonRigidTransform { norm2 });
        }
        let rotation = if rotation == Quat::IDENTITY {
            rotation
        } else {
            rotation.normalize()
        };
        Ok(Self::with_parts(rotation, 1.0, translation))
    }

    /// The scales [`Rigid::with_scale`] accepts: from 2^-20 to 2^20.
    pub const SCALES: std::ops::RangeInclusive<f32> = 1.0 / 1048576.0..=1048576.0;

    /// The same rotation and translation with the mesh scaled by `scale` first, replacing any
    /// scale set before (uniformly: angles, normals and `t` are kept): one mesh for boxes or
    /// rocks of many sizes. A scale outside [`Rigid::SCALES`] (or NaN) is
    /// [`SceneError::BadScale`]. Rays are carried into mesh space divided by the scale: one
    /// whose mesh-space origin or direction leaves `f32`'s range (coordinates near 2^108 at
    /// the smallest scale) misses the instance.
    pub fn with_scale(self, scale: f32) -> Result<Self, SceneError> {
        if !Self::SCALES.contains(&scale) {
            return Err(SceneError::BadScale { scale });
        }
        Ok(Self::with_parts(self.rotation, scale, self.translation))
    }

    /// The transform a cooked file holds: `rotation` as this type keeps it (unit length up to
    /// rounding, so not renormalised again: the transform is the saved one bit for bit),
    /// `scale` and `translation`, each checked as [`Rigid::new`] and [`Rigid::with_scale`]
    /// check them, the rotation within a millionth of unit length.
    pub(crate) fn from_cooked(
        rotation: Quat,
        scale: f32,
        translation: Vec3,
    ) -> Result<Self, SceneError> {
        if !rotation.is_finite() || !translation.is_finite() {
            return Err(SceneError::NonFiniteTransform);
        }
        let norm2 = rotation.length_squared();
        if (norm2 - 1.0).abs() > 1e-6 {
            return Err(SceneError::NonRigidTransform { norm2 });
        }
        if !Self::SCALES.contains(&scale) {
            return Err(SceneError::BadScale { scale });
        }
        Ok(Self::with_parts(rotation, scale, translation))
    }

    fn with_parts(rotation: Quat, scale: f32, translation: Vec3) -> Self {
        let turn = Mat3::from_quat(rotation);
        Self {
            rotation,
            scale,
            translation,
            to_world: turn * scale,
            to_mesh: turn.transpose() * (1.0 / scale),
            rotated_or_scaled: rotation != Quat::IDENTITY || scale != 1.0,
        }
    }

    /// A pure translation (exact: the ray's origin is shifted, its direction kept).
    pub fn from_translation(translation: Vec3) -> Result<Self, SceneError> {
        Self::new(Quat::IDENTITY, translation)
    }

    /// True for the identity (no rotation, translation `+0` on every axis): mesh space is
    /// world space and `ray_to_mesh` returns every ray bit for bit (`x - (+0) = x`, even for
    /// `x = -0`; a `-0` translation would turn a `-0` origin into `+0`, so it is excluded).
    pub fn is_identity(&self) -> bool {
        !self.rotated_or_scaled && self.translation.to_array().iter().all(|c| c.to_bits() == 0)
    }

    /// The rotation (unit length).
    pub fn rotation(&self) -> Quat {
        self.rotation
    }

    /// The uniform scale (1 unless set by [`Rigid::with_scale`]).
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// The translation.
    pub fn translation(&self) -> Vec3 {
        self.translation
    }

    /// The world ray `ray` in mesh space: the definition every scene query follows (see the
    /// module docs).
    #[inline]
    pub fn ray_to_mesh(&self, ray: &Ray) -> Ray {
        let dir = flush_subnormals(ray.dir);
        let offset = ray.origin - self.translation;
        let (origin, dir) = if self.rotated_or_scaled {
            (mul(&self.to_mesh, offset), mul(&self.to_mesh, dir))
        } else {
            (offset, dir)
        };
        Ray::with_range(origin, dir, ray.tmin, ray.tmax)
    }

    /// [`Rigid::ray_to_mesh`] of the valid ray `ray` with range end `tmax`, prepared: `None`
    /// if the mesh-space ray is invalid. Without a rotation only the origin changes, so the
    /// world ray's constants are kept (the very values `PreparedRay::new` would compute from
    /// the same direction): the fast path of translated instances, such as terrain tiles.
    #[inline]
    pub(crate) fn prepared_to_mesh(&self, ray: &PreparedRay, tmax: f32) -> Option<PreparedRay> {
        if self.rotated_or_scaled {
            let world = Ray::with_range(ray.origin, ray.dir, ray.tmin, tmax);
            return PreparedRay::new(&self.ray_to_mesh(&world));
        }
        let origin = ray.origin - self.translation;
        let range_ok = ray.tmin <= tmax;
        (origin.is_finite() && range_ok).then_some(PreparedRay {
            origin,
            tmax,
            ..*ray
        })
    }

    /// A mesh-space direction in the world, rotated (not scaled; rounded).
    pub fn vector_to_world(&self, v: Vec3) -> Vec3 {
        if self.rotation == Quat::IDENTITY {
            v
        } else {
            self.rotation * v
        }
    }

    /// A mesh-space point in the world (rounded; only used for boxes, which are padded).
    pub fn point_to_world(&self, p: Vec3) -> Vec3 {
        mul(&self.to_world, p) + self.translation
    }
}

/// `m * v` in the documented order: `x_axis * v.x + y_axis * v.y + z_axis * v.z`.
#[inline(always)]
fn mul(m: &Mat3, v: Vec3) -> Vec3 {
    let x = m.x_axis * v.x;
    let y = m.y_axis * v.y;
    let z = m.z_axis * v.z;
    (x + y) + z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_keeps_rays_bit_for_bit() {
        let ray = Ray::with_range(
            Vec3::new(-0.0, 1.5, 3.0),
            Vec3::new(-0.0, 0.0, -1.0),
            0.5,
            9.0,
        );
        let r = Rigid::IDENTITY.ray_to_mesh(&ray);
        assert_eq!(r.origin.x.to_bits(), (-0.0f32).to_bits());
        assert_eq!(r.dir.x.to_bits(), (-0.0f32).to_bits());
        assert_eq!((r.tmin, r.tmax), (0.5, 9.0));
    }

    #[test]
    fn rejects_scale_and_non_finite() {
        assert_eq!(
            Rigid::new(Quat::from_xyzw(0.0, 0.0, 0.0, 2.0), Vec3::ZERO),
            Err(SceneError::NonRigidTransform { norm2: 4.0 })
        );
        assert_eq!(
            Rigid::new(Quat::IDENTITY, Vec3::new(f32::NAN, 0.0, 0.0)),
            Err(SceneError::NonFiniteTransform)
        );
        assert_eq!(
            Rigid::new(Quat::from_xyzw(f32::INFINITY, 0.0, 0.0, 1.0), Vec3::ZERO),
            Err(SceneError::NonFiniteTransform)
        );
    }

    #[test]
    fn rotation_round_trips_points() {
        let r = Rigid::new(Quat::from_rotation_y(0.7), Vec3::new(1.0, 2.0, 3.0)).unwrap();
        let p = Vec3::new(0.3, -0.2, 0.9);
        let ray = Ray::new(r.point_to_world(p), Vec3::X);
        let back = r.ray_to_mesh(&ray).origin;
        assert!((back - p).length() < 1e-5);
    }
}
