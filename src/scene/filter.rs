//! What a query lets count, per ray: [`RayFilter`] (layers, an instance to pass through, back
//! faces, the range's end points), and the two ways to apply it: [`SceneView`], a scene seen
//! through one filter (every per-ray and batched query), and [`FilteredBatch`], a batch whose
//! rays each bring their own (an agent's sightline ignoring its own body beside one on other
//! layers).
//!
//! **Layers**, as game engines have them: each instance has a mask of layers
//! ([`super::Instance::mask`]), a filter a mask of the layers it sees, and an instance takes
//! part only if the two share a bit. The layers are tested in the top-level tree first (each
//! node knows the union of its instances' masks), so an instance filtered out costs no
//! transform and no triangle test; **an ignored instance** is skipped the same way.
//!
//! **Back faces.** A triangle's front is the side its winding normal `(b - a) x (c - a)`
//! points to. With [`RayFilter::cull_back_faces`], a hit whose ray travels along that normal
//! (`normal . dir > 0` in the mesh's space, computed in `f64`) does not count: the ray passes
//! through, for one-sided walls and windows. Hits on triangles seen edge-on count.
//!
//! **End points.** By default a hit at exactly `tmin` or `tmax` counts (a closed segment: a
//! sightline ending on a wall is blocked by it). With [`RayFilter::include_ends`] off, the
//! range is open: the filter shrinks it to the next `f32` inside each end before tracing.
//!
//! Answers are those of the filter applied to each ray alone, bit for bit, whatever the
//! batch: the filter is a function of the ray, the instance and the triangle only.

use glam::{DVec3, Vec3};

use crate::batch::BatchOptions;
use crate::geom::{PreparedRay, Ray};
use crate::hit::Hit;
use crate::query::RayQueries;
use crate::query::batched::{self, BatchError};
use crate::scene::instance::{ALL_LAYERS, Instance};
use crate::scene::world::Scene;

/// What counts for one ray (see the module docs). The default counts everything: all
/// layers, no instance ignored, both faces, both end points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RayFilter {
    /// Layers the ray sees: an instance takes part if its mask shares a bit with these.
    pub layers: u32,
    /// An instance the ray passes through (the agent's own body), by index.
    pub ignore: Option<u32>,
    /// Hits on back faces (winding normal along the ray) do not count.
    pub cull_back_faces: bool,
    /// Hits at exactly `tmin` or `tmax` count (a closed range).
    pub include_ends: bool,
}

impl Default for RayFilter {
    fn default() -> Self {
        Self::ALL
    }
}

impl RayFilter {
    /// Everything counts.
    pub const ALL: RayFilter = RayFilter {
        layers: ALL_LAYERS,
        ignore: None,
        cull_back_faces: false,
        include_ends: true,
    };

    /// Everything on layers `mask` counts.
    pub const fn on_layers(mask: u32) -> Self {
        Self {
            layers: mask,
            ..Self::ALL
        }
    }

    /// The same filter, passing through instance `instance`.
    pub const fn ignoring(self, instance: u32) -> Self {
        Self {
            ignore: Some(instance),
            ..self
        }
    }

    /// The same filter, passing through back faces.
    pub const fn culling_back_faces(self) -> Self {
        Self {
            cull_back_faces: true,
            ..self
        }
    }

    /// The same filter on the open range: hits at exactly `tmin` or `tmax` do not count.
    pub const fn without_ends(self) -> Self {
        Self {
            include_ends: false,
            ..self
        }
    }

    /// True if instance number `index` takes part in this ray's query.
    #[inline(always)]
    pub(crate) fn admits(&self, index: u32, instance: &Instance) -> bool {
        seen(instance.mask, self.layers) && self.ignore != Some(index)
    }

    /// The range the ray is traced over: `[tmin, tmax]`, or the floats strictly inside it
    /// without the ends; `None` if that holds none.
    #[inline(always)]
    pub(crate) fn range(&self, tmin: f32, tmax: f32) -> Option<(f32, f32)> {
        if self.include_ends {
            return Some((tmin, tmax));
        }
        let (lo, hi) = (tmin.next_up(), tmax.next_down());
        (lo <= hi).then_some((lo, hi))
    }

    /// `ray` with its range as traced ([`RayFilter::range`]).
    #[inline(always)]
    pub(crate) fn prepare(&self, ray: &PreparedRay) -> Option<PreparedRay> {
        let (tmin, tmax) = self.range(ray.tmin, ray.tmax)?;
        Some(PreparedRay { tmin, tmax, ..*ray })
    }
}

/// True if an instance (or top-level node) on layers `layers` is seen by a query on layers
/// `mask`.
#[inline(always)]
pub(crate) fn seen(layers: u32, mask: u32) -> bool {
    layers & mask != 0
}

/// True if a ray along `dir` (mesh space) meets the triangle `a, b, c` from behind: its
/// winding normal points along the ray.
pub(crate) fn back_face([a, b, c]: [Vec3; 3], dir: Vec3) -> bool {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let normal: DVec3 = (b - a).cross(c - a);
    normal.dot(dir.as_dvec3()) > 0.0
}

/// A scene seen through one filter, for every ray of a query (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct SceneView<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) filter: RayFilter,
}

/// A scene seen by each ray of a batch through its own filter: `filters[i]` for `rays[i]`
/// (see the module docs and [`FilteredBatch::occluded_batch`]).
#[derive(Clone, Copy, Debug)]
pub struct FilteredBatch<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) filters: &'a [RayFilter],
}

impl Scene {
    /// The scene as seen by queries through `filter`.
    pub fn filtered(&self, filter: RayFilter) -> SceneView<'_> {
        SceneView {
            scene: self,
            filter,
        }
    }

    /// The scene as seen by a batch whose ray `i` goes through `filters[i]`.
    pub fn filtered_batch<'a>(&'a self, filters: &'a [RayFilter]) -> FilteredBatch<'a> {
        FilteredBatch {
            scene: self,
            filters,
        }
    }
}

impl<'a> SceneView<'a> {
    /// The scene.
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// The view's filter.
    pub fn filter(&self) -> RayFilter {
        self.filter
    }
}

impl<'a> FilteredBatch<'a> {
    /// The closest hit of every ray through its filter (`hits[i]` for `rays[i]`), identical to
    /// `scene.filtered(filters[i]).cast_ray(&rays[i])`.
    pub fn cast_ray_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), BatchError> {
        self.cast_ray_batch_with(rays, hits, &BatchOptions::default())
    }

    /// [`FilteredBatch::cast_ray_batch`] with options.
    pub fn cast_ray_batch_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        self.check(rays, hits.len())?;
        if batched::ray_by_ray(rays, options) {
            batched::each_ray(self, (rays, hits), options, |i, ray, hit| {
                *hit = self.filtered(i).cast_ray_with(ray, options.kernel)
            });
            return Ok(());
        }
        batched::cast_ray_batch_with(self, rays, hits, options)
    }

    /// Occlusion of every ray through its filter (`occluded[i]` for `rays[i]`), identical to
    /// `scene.filtered(filters[i]).occluded(&rays[i])`: what a frame's sightlines need when
    /// each agent ignores its own body.
    pub fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) -> Result<(), BatchError> {
        self.occluded_batch_with(rays, occluded, &BatchOptions::default())
    }

    /// [`FilteredBatch::occluded_batch`] with options.
    pub fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        self.check(rays, occluded.len())?;
        if batched::ray_by_ray(rays, options) {
            batched::each_ray(self, (rays, occluded), options, |i, ray, out| {
                *out = self.filtered(i).occluded_with(ray, options.kernel)
            });
            return Ok(());
        }
        batched::occluded_batch_with(self, rays, occluded, options)
    }

    /// The scene through ray `i`'s filter.
    pub(crate) fn filtered(&self, i: usize) -> SceneView<'a> {
        self.scene.filtered(self.filters[i])
    }

    /// A filter for every ray and an output for every ray.
    fn check(&self, rays: &[Ray], outputs: usize) -> Result<(), BatchError> {
        if self.filters.len() != rays.len() {
            return Err(BatchError::FilterCount {
                rays: rays.len(),
                filters: self.filters.len(),
            });
        }
        batched::check_lengths(rays.len(), outputs)
    }

    /// The scene.
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// The rays' filters.
    pub fn filters(&self) -> &'a [RayFilter] {
        self.filters
    }
}
