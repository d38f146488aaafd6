//! Audio occlusion: how much sound a segment from a source to a listener loses to the
//! surfaces it crosses, from per-triangle materials.
//!
//! Each triangle of each mesh has a transmission loss in decibels ([`Materials`]). For a
//! segment, every hit is found (all hits, watertight), the hits are grouped into
//! **crossings**, and the losses of the crossings add up ([`Occlusion`]).
//!
//! **What a crossing is.** A ray through an edge or a vertex shared by several triangles hits
//! each of them (the watertight kernel guarantees it hits at least one, and reports every
//! triangle it touches), at the same point; a ray along a seam between two instances (terrain
//! tiles) does the same. Those hits are one surface crossed, not two. Their `t` values agree
//! only up to rounding (each triangle computes its own), so hits are grouped by distance: sorted
//! by `t` then global id, a crossing starts at a hit and takes in every following hit whose
//! `t` is within [`CROSSING_TOLERANCE`] (relative) of that first hit's `t`; the next hit beyond
//! starts the next crossing. A crossing's loss is the largest loss among its triangles (a
//! seam between glass and concrete lets through what concrete does). Two distinct surfaces
//! closer together than the tolerance (coincident double-sided walls, decals) count once, which
//! is what a listener hears. The grouping reads only the set of hits, which per-ray and batched
//! queries find identically, so both give the same answer bit for bit.

use std::sync::Mutex;

use crate::accel::Footprint;
use crate::batch::BatchOptions;
use crate::batch::chunks::for_each_chunk;
use crate::geom::Ray;
use crate::hit::Hit;
use crate::query::batched::check_lengths;
use crate::query::{BatchError, BatchQueries, RayQueries};
use crate::scene::Scene;

/// Relative distance (of `t`) within which hits are one crossing: `2^-16`, far above the
/// rounding of `t` (a few units in the last place, plus the instance transform's) and far below
/// the spacing of real walls (6 mm at 400 m).
///
/// Known limit: the tolerance is relative to `t` only, while a rotated instance's rounding of
/// `t` grows with the distance from the ray's origin to the instance (see
/// [`crate::Rigid`]); at a seam between two *rotated* instances far from a source that
/// is close to the seam, the two sides' `t` may differ by more, and the seam would count as two
/// crossings. Seams between translated instances and shared edges within a mesh are exact.
pub const CROSSING_TOLERANCE: f32 = 1.0 / 65536.0;

/// Why a material table was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum AudioError {
    /// One table per mesh of the scene is needed.
    WrongTableCount {
        /// Meshes in the scene.
        meshes: usize,
        /// Tables given.
        tables: usize,
    },
    /// A mesh's table has fewer entries than the mesh has triangles.
    TableTooShort {
        /// The mesh.
        mesh: usize,
        /// Its triangles.
        triangles: usize,
        /// Entries given.
        entries: usize,
    },
    /// A loss is negative, NaN or infinite.
    BadLoss {
        /// The mesh.
        mesh: usize,
        /// The triangle.
        triangle: usize,
    },
}

impl std::fmt::Display for AudioError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AudioError::WrongTableCount { meshes, tables } => {
                write!(f, "{tables} material tables for {meshes} meshes")
            }
            AudioError::TableTooShort {
                mesh,
                triangles,
                entries,
            } => write!(
                f,
                "material table of mesh {mesh} has {entries} entries for {triangles} triangles"
            ),
            AudioError::BadLoss { mesh, triangle } => write!(
                f,
                "loss of triangle {triangle} of mesh {mesh} is negative or not finite"
            ),
        }
    }
}

impl std::error::Error for AudioError {}

/// Transmission loss (decibels, `>= 0`) of every triangle of every mesh of a scene, looked up
/// by the global ids scene queries return.
#[derive(Clone, Debug)]
pub struct Materials {
    /// Per instance: the loss of each of its triangles, as a slice of `by_mesh`.
    per_instance: Vec<(u32, u32)>,
    /// Per global id start: the instance's first global id (for the lookup).
    first_ids: Vec<u32>,
    by_mesh: Vec<Vec<f32>>,
}

impl Materials {
    /// The losses of `scene`'s meshes: `tables[m][t]` for triangle `t` of mesh `m` (extra
    /// entries are ignored). Errors, and builds nothing, on a missing or short table or a
    /// negative or non-finite loss. The table follows the scene's instances as they are now:
    /// make it again after [`Scene::add_instances`] (until then, added instances lose 0 dB).
    pub fn new(scene: &Scene, tables: Vec<Vec<f32>>) -> Result<Self, AudioError> {
        if tables.len() != scene.meshes().len() {
            return Err(AudioError::WrongTableCount {
                meshes: scene.meshes().len(),
                tables: tables.len(),
            });
        }
        for (mesh, (tree, table)) in scene.meshes().iter().zip(&tables).enumerate() {
            let triangles = tree.triangle_count();
            if table.len() < triangles {
                return Err(AudioError::TableTooShort {
                    mesh,
                    triangles,
                    entries: table.len(),
                });
            }
            if let Some(triangle) = table[..triangles]
                .iter()
                .position(|l| !(*l >= 0.0 && l.is_finite()))
            {
                return Err(AudioError::BadLoss { mesh, triangle });
            }
        }
        let per_instance = scene
            .instances()
            .iter()
            .map(|i| (i.mesh() as u32, i.first_id()))
            .collect();
        let first_ids = scene.instances().iter().map(|i| i.first_id()).collect();
        // Entries past a mesh's triangles were not checked: drop them, so that an id beyond
        // the instances known here (one added later) finds no loss rather than an unchecked one.
        let by_mesh = (tables.into_iter().zip(scene.meshes()))
            .map(|(mut table, tree)| {
                table.truncate(tree.triangle_count());
                table
            })
            .collect();
        Ok(Self {
            per_instance,
            first_ids,
            by_mesh,
        })
    }

    /// One loss for every triangle of every mesh.
    pub fn uniform(scene: &Scene, loss_db: f32) -> Result<Self, AudioError> {
        let tables = scene
            .meshes()
            .iter()
            .map(|m| vec![loss_db; m.triangle_count()])
            .collect();
        Self::new(scene, tables)
    }

    /// The loss of global triangle `id` (0 for an id no instance owns).
    pub fn loss(&self, id: u32) -> f32 {
        let after = self.first_ids.partition_point(|&first| first <= id);
        let Some(instance) = after.checked_sub(1) else {
            return 0.0;
        };
        let (mesh, first) = self.per_instance[instance];
        self.by_mesh[mesh as usize]
            .get((id - first) as usize)
            .copied()
            .unwrap_or(0.0)
    }
}

/// What a source-listener segment goes through.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Occlusion {
    /// Sum of the losses of the crossings counted, in decibels.
    pub loss_db: f32,
    /// Surfaces crossed (see the module docs), up to the limit asked for.
    pub crossings: u32,
}

impl Occlusion {
    /// An invalid segment's answer: not heard (infinite loss), nothing crossed.
    pub const SILENT: Occlusion = Occlusion {
        loss_db: f32::INFINITY,
        crossings: 0,
    };
}

/// Groups `hits` (sorted by `t` then id; `hit(x)` reads one) into crossings and adds up the
/// first `limit`.
fn accumulate<T>(
    hits: &[T],
    hit: impl Fn(&T) -> &Hit,
    materials: &Materials,
    limit: u32,
) -> Occlusion {
    let mut out = Occlusion::default();
    let mut i = 0;
    while i < hits.len() && out.crossings < limit {
        let first = hit(&hits[i]).t;
        let reach = first + CROSSING_TOLERANCE * first.abs();
        let mut loss = 0.0f32;
        while i < hits.len() && hit(&hits[i]).t <= reach {
            loss = loss.max(materials.loss(hit(&hits[i]).triangle));
            i += 1;
        }
        out.loss_db += loss;
        out.crossings += 1;
    }
    out
}

/// The occlusion of the segment from `source` to `listener` through `world` (a scene or a
/// filtered view), counting at most `limit` crossings (`u32::MAX` for all; 1 for "the first
/// wall"), one ray. An invalid segment (a NaN or infinite point, length zero) is not heard:
/// infinite loss, no crossing.
pub fn occlusion<W: RayQueries>(
    world: &W,
    materials: &Materials,
    segment: &Ray,
    limit: u32,
) -> Occlusion {
    if !segment.is_valid() {
        return Occlusion::SILENT;
    }
    let hits = world.all_hits(segment);
    accumulate(&hits, |h| h, materials, limit)
}

/// [`occlusion`] for every segment (`out[i]` for `segments[i]`), batched: the segments are
/// split over rayon's threads and each part traced as one batch; the same answers as
/// [`occlusion`] on each, bit for bit.
pub fn occlusion_batch<W: BatchQueries + Sync>(
    world: &W,
    materials: &Materials,
    segments: &[Ray],
    limit: u32,
    out: &mut [Occlusion],
) -> Result<(), BatchError> {
    check_lengths(segments.len(), out.len())?;
    let options = BatchOptions::default()
        .with_parallel(false)
        .with_min_batch(0);
    // Chunks of at least 256 segments over the threads (one walk per chunk, each on one thread).
    let split = BatchOptions::default().with_min_chunk(256);
    for_each_chunk(segments, out, (&split, segments.len()), |_, rays, out| {
        let hits = Mutex::new(Vec::<(usize, Hit)>::new());
        world.for_each_hit_batch_with(rays, &options, &|i, h| {
            hits.lock().unwrap_or_else(|e| e.into_inner()).push((i, h))
        });
        let mut hits = hits.into_inner().unwrap_or_else(|e| e.into_inner());
        hits.sort_by(|(i, a), (j, b)| {
            i.cmp(j)
                .then(a.t.total_cmp(&b.t))
                .then(a.triangle.cmp(&b.triangle))
        });
        let mut start = 0;
        for (k, o) in out.iter_mut().enumerate() {
            let end = start + hits[start..].partition_point(|(i, _)| *i == k);
            *o = if rays[k].is_valid() {
                accumulate(&hits[start..end], |(_, h)| h, materials, limit)
            } else {
                Occlusion::SILENT
            };
            start = end;
        }
    });
    Ok(())
}
