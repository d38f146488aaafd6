//! What a Python scene queries: nothing yet, one structure (its geometry is id 0), or a
//! [`Scene`] whose instances are the geometries (identity instances for added meshes; a loaded
//! cooked scene keeps its own). [`Target::structure`] is the one dispatch over the three.

use std::sync::{Mutex, OnceLock};

use raybatch::glam::{DVec3, Vec3};
use raybatch::scene::{InstanceDesc, Rigid};
use raybatch::{
    AnyAccel, BatchQueries, CookError, Footprint, Hit, Kernel, Ray, RayQueries, Scene, SceneError,
};
use rayon::prelude::*;

use crate::rays::Rays;

/// Open3D's id of no geometry and no triangle (a miss).
pub const INVALID_ID: u32 = u32::MAX;

/// Rays per task of the per-ray queries (counts and lists).
const CHUNK: usize = 1024;

/// Both query traits, as one trait object.
trait Queries: RayQueries + BatchQueries + Sync {}

impl<T: RayQueries + BatchQueries + Sync> Queries for T {}

/// The structure or scene a Python scene answers from.
enum Target {
    Empty,
    One(AnyAccel),
    Many(Scene),
}

/// Where a global triangle id lies: its geometry, its triangle there, the mesh it belongs to
/// and the geometry's placement.
struct Place {
    geometry: u32,
    primitive: u32,
    mesh: usize,
    transform: Rigid,
}

/// A Python scene's geometries and, per mesh, its unit triangle normals once asked for.
pub struct Geometries {
    target: Target,
    normals: Vec<OnceLock<Vec<Vec3>>>,
    /// Buffers kept between queries (see [`Scratch`]).
    scratch: Mutex<Scratch>,
}

/// A query's working buffers: the rays converted from NumPy's rows and the closest hits.
/// Kept between queries, because a block of a million rays takes 52 MB, which the allocator
/// would otherwise map afresh and the kernel zero at every call (a third of a closest-hit
/// query's time on a mesh that fits the caches). A query that finds them in use (another
/// Python thread querying the same scene) makes its own.
#[derive(Default)]
struct Scratch {
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
}

/// Closest hits: per ray `t`, geometry, triangle, `(u, v)` and, if asked, the world normal.
pub struct Closest {
    pub t: Vec<f32>,
    pub geometry: Vec<u32>,
    pub primitive: Vec<u32>,
    pub uv: Vec<[f32; 2]>,
    pub normal: Vec<[f32; 3]>,
}

/// Every hit of every ray: ray `i`'s are `splits[i]..splits[i + 1]` of the flat arrays, by
/// `t` then geometry and triangle.
#[derive(Default)]
pub struct List {
    pub splits: Vec<u32>,
    pub ray: Vec<u32>,
    pub geometry: Vec<u32>,
    pub primitive: Vec<u32>,
    pub uv: Vec<f32>,
    pub t: Vec<f32>,
}

impl Geometries {
    /// No geometry: every ray misses.
    pub fn new() -> Self {
        Self::of(Target::Empty)
    }

    fn of(target: Target) -> Self {
        let meshes = match &target {
            Target::Empty => 0,
            Target::One(_) => 1,
            Target::Many(scene) => scene.meshes().len(),
        };
        let normals = (0..meshes).map(|_| OnceLock::new()).collect();
        let scratch = Mutex::default();
        Self {
            target,
            normals,
            scratch,
        }
    }

    /// Runs `f` on the scene's buffers, or on new ones while another query holds them.
    fn with_scratch<R>(&self, f: impl FnOnce(&mut Scratch) -> R) -> R {
        match self.scratch.try_lock() {
            Ok(mut scratch) => f(&mut scratch),
            Err(_) => f(&mut Scratch::default()),
        }
    }

    /// The geometries of a cooked file's bytes: a structure (one geometry) or a scene.
    pub fn from_cooked(bytes: &[u8]) -> Result<Self, CookError> {
        match AnyAccel::from_cooked(bytes) {
            Ok(tree) => Ok(Self::of(Target::One(tree))),
            Err(CookError::WrongContent { .. }) => {
                Ok(Self::of(Target::Many(Scene::from_cooked(bytes)?)))
            }
            Err(e) => Err(e),
        }
    }

    /// The cooked file's bytes: one geometry as a structure, none or several as a scene.
    pub fn to_cooked(&self) -> Result<Vec<u8>, CookError> {
        match &self.target {
            Target::Empty => Scene::new(Vec::new(), &[])
                .map_err(CookError::Scene)?
                .to_cooked(),
            Target::One(tree) => tree.to_cooked(),
            Target::Many(scene) => scene.to_cooked(),
        }
    }

    /// Adds `tree` as the next geometry and returns its id. On error nothing changes.
    pub fn push(&mut self, tree: AnyAccel) -> Result<u32, SceneError> {
        let total = (self.triangle_count() + tree.triangle_count()) as u64;
        if total > raybatch::mesh::MAX_TRIANGLES as u64 {
            return Err(SceneError::TooManyTriangles { count: total });
        }
        let id = self.geometry_count() as u32;
        self.target = match std::mem::replace(&mut self.target, Target::Empty) {
            Target::Empty => Target::One(tree),
            Target::One(first) => {
                let at = InstanceDesc::new(0, Rigid::IDENTITY);
                Target::Many(place(Scene::new(vec![first], &[at])?, tree)?)
            }
            Target::Many(scene) => Target::Many(place(scene, tree)?),
        };
        self.normals.push(OnceLock::new());
        Ok(id)
    }

    /// Geometries (a loaded scene's instances, removed ones included, so that ids stay).
    pub fn geometry_count(&self) -> usize {
        match &self.target {
            Target::Empty => 0,
            Target::One(_) => 1,
            Target::Many(scene) => scene.instances().len(),
        }
    }

    /// Triangles over all geometries.
    pub fn triangle_count(&self) -> usize {
        match &self.target {
            Target::Empty => 0,
            Target::One(tree) => tree.triangle_count(),
            Target::Many(scene) => scene.triangle_count(),
        }
    }

    /// Each geometry's structure kind.
    pub fn kinds(&self) -> Vec<&'static str> {
        match &self.target {
            Target::Empty => Vec::new(),
            Target::One(tree) => vec![tree.kind().name()],
            Target::Many(scene) => {
                let meshes = scene.meshes();
                let kind = |i: &raybatch::scene::Instance| meshes[i.mesh()].kind().name();
                scene.instances().iter().map(kind).collect()
            }
        }
    }

    /// The one dispatch: the structure or scene that answers, if any.
    fn structure(&self) -> Option<&dyn Queries> {
        match &self.target {
            Target::Empty => None,
            Target::One(tree) => Some(tree),
            Target::Many(scene) => Some(scene),
        }
    }

    /// Where global triangle id `id` (an id a query reported) lies.
    fn place(&self, id: u32) -> Place {
        let one = Place {
            geometry: 0,
            primitive: id,
            mesh: 0,
            transform: Rigid::IDENTITY,
        };
        let Target::Many(scene) = &self.target else {
            return one;
        };
        let (instance, primitive) = scene.locate(id).unwrap_or((INVALID_ID, INVALID_ID));
        let placed = scene.instances().get(instance as usize);
        Place {
            geometry: instance,
            primitive,
            mesh: placed.map_or(0, |i| i.mesh()),
            transform: placed.map_or(Rigid::IDENTITY, |i| i.transform()),
        }
    }

    /// Each mesh's unit triangle normals, made on first use (12 bytes a triangle): a hit's
    /// normal is then one read. Made on the calling thread, never inside a pool, where a
    /// thread waiting for another's table could be handed work that waits on it.
    pub fn normal_tables(&self) -> Vec<&[Vec3]> {
        let trees: Vec<&AnyAccel> = match &self.target {
            Target::Empty => Vec::new(),
            Target::One(tree) => vec![tree],
            Target::Many(scene) => scene.meshes().iter().collect(),
        };
        let table = |tree: &AnyAccel| {
            let ids = 0..tree.triangle_count() as u32;
            ids.map(|id| tree.triangle(id).map_or(Vec3::ZERO, unit_normal))
                .collect()
        };
        trees
            .iter()
            .zip(&self.normals)
            .map(|(tree, cell)| cell.get_or_init(|| table(tree)).as_slice())
            .collect()
    }

    /// Closest hits (a miss: `t = inf`, ids [`INVALID_ID`], zero `uv` and normal), with world
    /// normals from `normals` ([`Geometries::normal_tables`]) if given.
    pub fn closest(&self, rays: &Rays, normals: Option<&[&[Vec3]]>) -> Result<Closest, String> {
        let n = rays.len();
        // Zeroed allocations cost nothing until written; the one pass per block writes all.
        let mut out = Closest {
            t: vec![0.0; n],
            geometry: vec![0; n],
            primitive: vec![0; n],
            uv: vec![[0.0; 2]; n],
            normal: vec![[0.0; 3]; if normals.is_some() { n } else { 0 }],
        };
        self.with_scratch(|Scratch { rays: block, hits }| {
            rays.for_each_block(block, |start, block| {
                // Every entry is written by the batch (a miss as `None`).
                hits.resize(block.len(), None);
                if let Some(structure) = self.structure() {
                    // The lengths agree, the batch's one error.
                    let _ = structure.cast_ray_batch(block, hits);
                } else {
                    hits.fill(None);
                }
                self.write_closest(&mut out, start, hits, normals);
            })
        })?;
        Ok(out)
    }

    /// Writes the answers of `hits` (rays `start..`) into `out`, in one pass on the current
    /// pool (and one more for the normals, if asked).
    fn write_closest(
        &self,
        out: &mut Closest,
        start: usize,
        hits: &[Option<Hit>],
        normals: Option<&[&[Vec3]]>,
    ) {
        let end = start + hits.len();
        let rows = out.t[start..end]
            .par_iter_mut()
            .zip(&mut out.geometry[start..end])
            .zip(&mut out.primitive[start..end])
            .zip(&mut out.uv[start..end])
            .zip(hits);
        rows.with_min_len(CHUNK)
            .for_each(|((((t, geometry), primitive), uv), hit)| match hit {
                Some(hit) => {
                    let place = self.place(hit.triangle);
                    (*t, *geometry, *primitive) = (hit.t, place.geometry, place.primitive);
                    *uv = [hit.u, hit.v];
                }
                None => (*t, *geometry, *primitive) = (f32::INFINITY, INVALID_ID, INVALID_ID),
            });
        if let Some(tables) = normals {
            let rows = out.normal[start..end].par_iter_mut().zip(hits);
            rows.with_min_len(CHUNK).for_each(|(normal, hit)| {
                if let Some(hit) = hit {
                    *normal = self.world_normal(hit, tables);
                }
            });
        }
    }

    /// The normal of `hit`'s triangle in world space, from the meshes' unit normal `tables`.
    fn world_normal(&self, hit: &Hit, tables: &[&[Vec3]]) -> [f32; 3] {
        let place = self.place(hit.triangle);
        let local = tables
            .get(place.mesh)
            .and_then(|t| t.get(place.primitive as usize));
        let world = place
            .transform
            .vector_to_world(local.copied().unwrap_or(Vec3::ZERO));
        world.to_array()
    }

    /// Whether each ray hits anything in its range.
    pub fn occluded(&self, rays: &Rays) -> Result<Vec<bool>, String> {
        let mut out = vec![false; rays.len()];
        self.with_scratch(|scratch| {
            rays.for_each_block(&mut scratch.rays, |start, block| {
                if let Some(structure) = self.structure() {
                    let answers = &mut out[start..start + block.len()];
                    // The lengths agree, the batch's one error.
                    let _ = structure.occluded_batch(block, answers);
                }
            })
        })?;
        Ok(out)
    }

    /// The number of hits of each ray.
    pub fn count(&self, rays: &Rays) -> Result<Vec<i32>, String> {
        let mut out = vec![0; rays.len()];
        self.with_scratch(|scratch| {
            rays.for_each_block(&mut scratch.rays, |start, block| {
                let Some(structure) = self.structure() else {
                    return;
                };
                let counts = &mut out[start..start + block.len()];
                counts
                    .par_iter_mut()
                    .zip(block.par_iter())
                    .with_min_len(CHUNK)
                    .for_each(|(count, ray)| {
                        structure.for_each_hit_with(ray, Kernel::Watertight, &mut |_| *count += 1)
                    });
            })
        })?;
        Ok(out)
    }

    /// Every hit of every ray ([`List`]).
    pub fn list(&self, rays: &Rays) -> Result<List, String> {
        let mut per_ray: Vec<Vec<Hit>> = Vec::new();
        let mut out = List {
            splits: vec![0],
            ..List::default()
        };
        let mut failed = None;
        self.with_scratch(|scratch| {
            rays.for_each_block(&mut scratch.rays, |start, block| {
                per_ray.clear();
                if let Some(structure) = self.structure() {
                    let hits_of = |ray| {
                        let mut hits = Vec::new();
                        structure.for_each_hit_with(ray, Kernel::Watertight, &mut |h| hits.push(h));
                        Hit::sort(&mut hits);
                        hits
                    };
                    block
                        .par_iter()
                        .with_min_len(CHUNK)
                        .map(hits_of)
                        .collect_into_vec(&mut per_ray);
                } else {
                    per_ray.resize(block.len(), Vec::new());
                }
                if failed.is_none() {
                    failed = self.append(&mut out, start, &per_ray).err();
                }
            })
        })?;
        failed.map_or(Ok(out), Err)
    }

    /// Appends the hits of rays `start..` to `out`.
    fn append(&self, out: &mut List, start: usize, per_ray: &[Vec<Hit>]) -> Result<(), String> {
        for (k, hits) in per_ray.iter().enumerate() {
            for hit in hits {
                let place = self.place(hit.triangle);
                out.ray.push((start + k) as u32);
                out.geometry.push(place.geometry);
                out.primitive.push(place.primitive);
                out.uv.extend([hit.u, hit.v]);
                out.t.push(hit.t);
            }
            let total = u32::try_from(out.t.len())
                .map_err(|_| format!("more than {} hits in one call", u32::MAX))?;
            out.splits.push(total);
        }
        Ok(())
    }
}

/// `scene` with `tree` added as a mesh and placed once, at the identity.
fn place(mut scene: Scene, tree: AnyAccel) -> Result<Scene, SceneError> {
    let mesh = scene.add_mesh(tree);
    scene.add_instances(&[InstanceDesc::new(mesh, Rigid::IDENTITY)])?;
    Ok(scene)
}

/// The unit normal of a triangle, `(b - a) x (c - a)` normalised (in `f64`, as the library's
/// resolved scene hits; zero for a degenerate triangle).
fn unit_normal([a, b, c]: [Vec3; 3]) -> Vec3 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let n: DVec3 = (b - a).cross(c - a);
    n.normalize_or_zero().as_vec3()
}
