//! Hits a game reads: [`SceneHit`] (instance, its mesh's triangle, world position and normal)
//! and the closest-hit queries that return it, per ray and batched, so that a game never
//! turns global ids back into instances itself.

use glam::{DVec3, Vec3};

use crate::batch::BatchOptions;
use crate::batch::chunks::for_each_chunk;
use crate::geom::Ray;
use crate::hit::Hit;
use crate::query::batched::check_lengths;
use crate::query::{BatchError, BatchQueries, RayQueries};
use crate::scene::filter::{FilteredBatch, RayFilter, SceneView};
use crate::scene::world::Scene;

/// A scene hit resolved to its instance: what a game reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    /// The instance hit.
    pub instance: u32,
    /// The instance's user value ([`crate::scene::InstanceDesc::user`]): which entity or
    /// material the game attached to it.
    pub user: u64,
    /// The triangle's id in the instance's mesh.
    pub triangle: u32,
    /// Distance along the world ray, in units of its direction (see [`crate::scene::Rigid`]).
    pub t: f32,
    /// Barycentric weight of the triangle's second corner.
    pub u: f32,
    /// Barycentric weight of the triangle's third corner.
    pub v: f32,
    /// The hit point in the world: `ray.at(t)` for the world ray.
    pub position: Vec3,
    /// The triangle's unit normal in the world, `(b - a) x (c - a)` of its corners `a, b, c`
    /// (the winding decides the side, whichever side the ray came from), rotated by the
    /// instance's transform.
    pub normal: Vec3,
}

impl Scene {
    /// `hit` (the answer of a scene query on `ray`, in global ids) as instance, mesh triangle,
    /// world position and normal; `None` if no triangle has its id.
    pub fn resolve(&self, ray: &Ray, hit: Hit) -> Option<SceneHit> {
        let (instance, triangle) = self.locate(hit.triangle)?;
        let placed = &self.instances[instance as usize];
        let [a, b, c] = self.meshes[placed.mesh()].corners(triangle);
        Some(SceneHit {
            instance,
            user: placed.user(),
            triangle,
            t: hit.t,
            u: hit.u,
            v: hit.v,
            position: ray.at(hit.t),
            normal: placed.transform().vector_to_world(unit_normal(a, b, c)),
        })
    }

    /// The closest hit of `ray`, resolved ([`Scene::resolve`]).
    pub fn cast_ray_resolved(&self, ray: &Ray) -> Option<SceneHit> {
        self.filtered(RayFilter::ALL).cast_ray_resolved(ray)
    }

    /// The closest hit of every ray, resolved (`out[i]` for `rays[i]`): the same answers as
    /// [`Scene::cast_ray_resolved`] on each ray. With options or a filter:
    /// [`SceneView::cast_ray_batch_resolved_with`] on [`Scene::filtered`]; a filter per ray:
    /// [`Scene::filtered_batch`].
    pub fn cast_ray_batch_resolved(
        &self,
        rays: &[Ray],
        out: &mut [Option<SceneHit>],
    ) -> Result<(), BatchError> {
        self.filtered(RayFilter::ALL)
            .cast_ray_batch_resolved(rays, out)
    }
}

impl SceneView<'_> {
    /// The closest hit of `ray` through the view's filter, resolved ([`Scene::resolve`]).
    pub fn cast_ray_resolved(&self, ray: &Ray) -> Option<SceneHit> {
        self.cast_ray(ray)
            .and_then(|hit| self.scene.resolve(ray, hit))
    }

    /// [`Scene::cast_ray_batch_resolved`] through the view's filter.
    pub fn cast_ray_batch_resolved(
        &self,
        rays: &[Ray],
        out: &mut [Option<SceneHit>],
    ) -> Result<(), BatchError> {
        self.cast_ray_batch_resolved_with(rays, out, &BatchOptions::default())
    }

    /// [`Scene::cast_ray_batch_resolved`] through the view's filter, with options: one
    /// batched query, then the hits resolved in chunks over the threads.
    pub fn cast_ray_batch_resolved_with(
        &self,
        rays: &[Ray],
        out: &mut [Option<SceneHit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        let cast = |hits: &mut [Option<Hit>]| self.cast_ray_batch_with(rays, hits, options);
        self.scene.resolve_batch(rays, out, options, cast)
    }
}

impl FilteredBatch<'_> {
    /// [`Scene::cast_ray_batch_resolved`], each ray through its filter.
    pub fn cast_ray_batch_resolved(
        &self,
        rays: &[Ray],
        out: &mut [Option<SceneHit>],
    ) -> Result<(), BatchError> {
        self.cast_ray_batch_resolved_with(rays, out, &BatchOptions::default())
    }

    /// [`FilteredBatch::cast_ray_batch_resolved`] with options.
    pub fn cast_ray_batch_resolved_with(
        &self,
        rays: &[Ray],
        out: &mut [Option<SceneHit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        let cast = |hits: &mut [Option<Hit>]| self.cast_ray_batch_with(rays, hits, options);
        self.scene.resolve_batch(rays, out, options, cast)
    }
}

impl Scene {
    /// `out[i]`: the closest hit of `rays[i]` as `cast` answers them in one batched call,
    /// resolved in chunks over the threads.
    fn resolve_batch(
        &self,
        rays: &[Ray],
        out: &mut [Option<SceneHit>],
        options: &BatchOptions,
        cast: impl FnOnce(&mut [Option<Hit>]) -> Result<(), BatchError>,
    ) -> Result<(), BatchError> {
        check_lengths(rays.len(), out.len())?;
        let mut hits = vec![None; rays.len()];
        cast(&mut hits)?;
        let hits = &hits;
        for_each_chunk(rays, out, (options, rays.len()), |offset, rays, out| {
            for (k, (ray, out)) in rays.iter().zip(out).enumerate() {
                *out = hits[offset + k].and_then(|hit| self.resolve(ray, hit));
            }
        });
        Ok(())
    }
}

/// The unit normal `(b - a) x (c - a)`, computed in `f64` so that tiny triangles (which the
/// kernel hits exactly, in `f64` where needed) still get one.
fn unit_normal(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let n: DVec3 = (b - a).cross(c - a);
    n.normalize_or_zero().as_vec3()
}
