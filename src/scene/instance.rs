//! Instances: a mesh placed in the world by a rigid transform, with a filter mask and the
//! first global triangle id of its triangles; and the padded world boxes that make the
//! top-level culling conservative.
//!
//! **Why boxes are padded.** A scene traces the world ray carried into mesh space
//! ([`crate::scene::Rigid::ray_to_mesh`]), which is rounded; the top level culls with the world
//! ray against world boxes. For the culling never to drop a hit the mesh-space trace would
//! find, a hit at `t` in mesh space must put the *world* ray near the instance's world box at
//! `t`. The rounding of the transform (of `origin - translation`, of the rotation's products
//! and of the rotation matrix itself) moves that point by a few units in the last place of
//! `|origin| + |translation| + |p|`, `p` the hit point in mesh space (its `t * |dir|` is bounded
//! by the same terms). So each world box is grown by [`PAD`] times `|translation|_1 + max
//! |corner|_1` (the instance's part, stored in the box) and, at query time, by `PAD *
//! |origin|_1` (the ray's part). `PAD = 2^-16` is 256 units in the last place: a wide margin over
//! the dozen or so the analysis needs, and still invisible to culling speed.

use glam::Vec3;

use crate::geom::Aabb;
use crate::scene::rigid::Rigid;

/// Relative padding of world boxes (see the module docs).
pub const PAD: f32 = 1.0 / 65536.0;

/// The filter mask an instance gets unless told otherwise: visible to every query.
pub const ALL_LAYERS: u32 = u32::MAX;

/// What [`crate::scene::Scene::new`] needs for one instance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceDesc {
    /// Index of the mesh in the scene's mesh list.
    pub mesh: usize,
    /// Where the mesh sits in the world.
    pub transform: Rigid,
    /// Filter layers: a query with mask `m` sees the instance if `mask & m != 0`.
    pub mask: u32,
    /// The caller's own value for the instance (an entity id, an index into a material
    /// table): carried to [`crate::scene::SceneHit::user`], never read by the scene.
    pub user: u64,
}

impl InstanceDesc {
    /// Mesh `mesh` at `transform`, on every layer, with user value 0.
    pub fn new(mesh: usize, transform: Rigid) -> Self {
        Self {
            mesh,
            transform,
            mask: ALL_LAYERS,
            user: 0,
        }
    }

    /// The same instance on layers `mask`.
    pub fn with_mask(self, mask: u32) -> Self {
        Self { mask, ..self }
    }

    /// The same instance with user value `user`.
    pub fn with_user(self, user: u64) -> Self {
        Self { user, ..self }
    }
}

/// An instance of a scene.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    pub(crate) mesh: u32,
    pub(crate) transform: Rigid,
    pub(crate) mask: u32,
    pub(crate) user: u64,
    pub(crate) first_id: u32,
    pub(crate) world_box: Aabb,
    /// Taken out of every query ([`crate::scene::Scene::remove_instance`]).
    pub(crate) removed: bool,
}

impl Instance {
    /// Index of its mesh.
    pub fn mesh(&self) -> usize {
        self.mesh as usize
    }

    /// Where it sits.
    pub fn transform(&self) -> Rigid {
        self.transform
    }

    /// Its filter layers.
    pub fn mask(&self) -> u32 {
        self.mask
    }

    /// True once [`crate::scene::Scene::remove_instance`] took it out of every query.
    pub fn is_removed(&self) -> bool {
        self.removed
    }

    /// The caller's value for it ([`InstanceDesc::user`]).
    pub fn user(&self) -> u64 {
        self.user
    }

    /// The global id of its triangle 0 (its triangle `i` is global id `first_id + i`).
    pub fn first_id(&self) -> u32 {
        self.first_id
    }

    /// Its world box, padded (see the module docs).
    pub fn world_box(&self) -> Aabb {
        self.world_box
    }
}

/// The padded world box of a mesh box placed by `transform` (empty for an empty mesh box).
pub(crate) fn world_box(mesh_box: Aabb, transform: &Rigid) -> Aabb {
    if mesh_box.is_empty() {
        return Aabb::EMPTY;
    }
    let (mut world, mut reach) = (Aabb::EMPTY, 0.0f32);
    for c in mesh_box.corners() {
        world = world.grow(transform.point_to_world(c));
        reach = reach.max(l1(c));
    }
    let pad = PAD * (reach * transform.scale() + l1(transform.translation()));
    Aabb::new(world.min - pad, world.max + pad)
}

/// The ray's part of the padding (see the module docs).
#[inline(always)]
pub(crate) fn ray_pad(origin: Vec3) -> f32 {
    (PAD * l1(origin)).min(f32::MAX)
}

/// `|x| + |y| + |z|`.
#[inline(always)]
fn l1(v: Vec3) -> f32 {
    let a = v.abs();
    a.x + a.y + a.z
}

/// `b` grown by `pad` on every side.
#[inline(always)]
pub(crate) fn grown(b: &Aabb, pad: f32) -> Aabb {
    Aabb::new(b.min - pad, b.max + pad)
}

#[cfg(test)]
mod tests {
    use glam::Quat;

    use super::*;
    use crate::geom::Ray;
    use crate::test_support::TestRng;

    /// The padding argument, checked where it is tightest: instances far from the origin,
    /// rotated, seen from rays whose origins are far from both. For a point `p` of the mesh
    /// box, the world ray through `p`'s world image is carried into mesh space as the scene
    /// does; at the `t` where that mesh-space ray passes closest to `p` (where a hit on `p`'s
    /// triangle would be found), the *world* ray, evaluated exactly in f64, must lie in the
    /// padded world box. Without the padding this fails (checked below), so the test has teeth.
    #[test]
    fn padded_boxes_hold_the_world_ray_at_every_mesh_space_hit() {
        let mut rng = TestRng::new(5);
        let mut unpadded_misses = 0;
        for round in 0..20_000 {
            let scale = [1.0, 1e3, 1e5][round % 3];
            let axis = rng.vec3(1.0).try_normalize().unwrap_or(Vec3::Y);
            // Half the instances unrotated: their mesh box's faces are world box faces.
            let angle = if round % 4 < 2 {
                0.0
            } else {
                rng.range(0.0, 6.3)
            };
            let rotation = Quat::from_axis_angle(axis, angle);
            let size = [1.0, 1e-3, 37.5, 1.0 / 1048576.0][round % 4];
            let transform = Rigid::new(rotation, rng.vec3(scale))
                .unwrap()
                .with_scale(size)
                .unwrap();
            let a = rng.vec3(10.0);
            let mesh_box = Aabb::new(a, a + rng.vec3(5.0).abs() + 1e-3);
            // A point on a face of the box, where rounding can carry it outside.
            let mut p = mesh_box.min + (mesh_box.max - mesh_box.min) * rng.vec3(1.0).abs();
            let face = if round % 2 == 0 {
                mesh_box.min
            } else {
                mesh_box.max
            };
            p[round % 3] = face[round % 3];
            let origin = rng.vec3(scale * 2.0);
            let target = transform.point_to_world(p);
            let world = Ray::new(origin, target - origin);
            let mesh = transform.ray_to_mesh(&world);
            // t where the mesh-space ray passes closest to p, and the world ray there, in f64.
            let (o, d) = (mesh.origin.as_dvec3(), mesh.dir.as_dvec3());
            let t = (p.as_dvec3() - o).dot(d) / d.length_squared();
            let at = world.origin.as_dvec3() + world.dir.as_dvec3() * t;
            let boxed = |b: Aabb| {
                let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
                at.cmpge(lo).all() && at.cmple(hi).all()
            };
            let padded = grown(&world_box(mesh_box, &transform), ray_pad(origin));
            assert!(
                boxed(padded),
                "{transform:?} {mesh_box:?} {world:?} at {at:?}"
            );
            // The same box without either pad: the world image of the mesh box's corners.
            let unpadded = mesh_box
                .corners()
                .into_iter()
                .fold(Aabb::EMPTY, |b, c| b.grow(transform.point_to_world(c)));
            unpadded_misses += !boxed(unpadded) as u32;
        }
        assert!(
            unpadded_misses > 100,
            "the padding was needed {unpadded_misses} times"
        );
    }
}
