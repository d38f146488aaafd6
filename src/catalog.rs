//! Every structure of the crate by name, and one dynamic type that answers every query.
//!
//! [`AccelKind`] is the one list of structures: the command-line tools, the benchmarks, the peer
//! comparison and the tests iterate over [`AccelKind::ALL`], so a new structure is one variant
//! here (with its name and its build) and shows up everywhere. [`AnyAccel`] wraps any
//! [`Accel`] behind a trait object, so structures of different types can sit in one list and
//! be chosen at run time; its methods are those of [`RayQueries`], [`BatchQueries`] and
//! [`Footprint`], at the cost of one indirect call per query.

use std::sync::Arc;

use crate::accel::{Accel, Footprint};
use crate::batch::BatchOptions;
use crate::bvh::{AabbTree, BuildError, BuildOptions, QuantizedAabbTree};
use crate::geom::{Kernel, Ray};
use crate::grid::{GridOptions, SpatialHash, UniformGrid};
use crate::hit::Hit;
use crate::kdtree::KdTree;
use crate::mesh::Mesh;
use crate::permuted::Permuted;
use crate::query::{BatchError, BatchQueries, RayQueries};
use crate::wide::{QuantizedWideTree, QuantizedWideTree8, WideTree, WideTree8};
use crate::zbt::{HybridOptions, HybridTree, Rejected, ZbtError, ZbtOptions, ZeroByteTree};

/// A kind of acceleration structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AccelKind {
    /// [`AabbTree`]: binary SAH tree, 32-byte nodes.
    Aabb,
    /// [`QuantizedAabbTree`]: the same tree with 16-byte quantized nodes.
    Quantized,
    /// [`WideTree`]: the same tree collapsed to 4 children per node, SIMD box tests.
    Bvh4,
    /// [`WideTree8`]: the same tree collapsed to 8 children per node (AVX2 box tests where
    /// the CPU has them); its batches share nodes as the 4-wide tree's do. The default.
    Bvh8,
    /// [`QuantizedWideTree`]: the 4-wide tree with 8-bit child boxes, one 64-byte line a node.
    Bvh4q,
    /// [`QuantizedWideTree8`]: the 8-wide tree with 8-bit child boxes, two 64-byte lines a
    /// node.
    Bvh8q,
    /// [`QuantizedWideTree8`] with leaf blocks ([`crate::LeafCopy::Blocks`]) by default on
    /// large trees (over 8 MiB with the mesh): each leaf one read, as Embree's are. The
    /// fastest per ray beyond the caches, where [`AccelKind::for_mesh`] picks it; 36-38 B/tri
    /// there, within the full binary tree's 38.5 (the index copy where blocks would take
    /// more), where `bvh8q` keeps to the quantized tree's 20-21.
    Bvh8qb,
    /// [`ZeroByteTree`]: no memory beside the mesh, boxes recomputed, per-thread box cache.
    Zbt,
    /// [`ZeroByteTree`] with the box cache off: every box recomputed at every visit.
    ZbtNoCache,
    /// [`HybridTree`]: stored boxes down to chunks of 32 triangles, zero-byte trees below.
    Hybrid,
    /// [`UniformGrid`]: cells over the bounds walked by an exact 3D-DDA, mailboxed.
    Grid,
    /// [`KdTree`]: SAH kd-tree, 8-byte nodes, front-to-back walk, mailboxed.
    Kd,
    /// [`SpatialHash`]: the grid's cells and walk, only non-empty cells stored, hashed.
    Hash,
}

impl AccelKind {
    /// Every kind.
    pub const ALL: [AccelKind; 13] = [
        AccelKind::Aabb,
        AccelKind::Quantized,
        AccelKind::Bvh4,
        AccelKind::Bvh8,
        AccelKind::Bvh4q,
        AccelKind::Bvh8q,
        AccelKind::Bvh8qb,
        AccelKind::Zbt,
        AccelKind::ZbtNoCache,
        AccelKind::Hybrid,
        AccelKind::Grid,
        AccelKind::Kd,
        AccelKind::Hash,
    ];

    /// The fastest exact structure on our measurements, all queries together: the 8-wide
    /// tree. Against the 4-wide tree (`peers --race`, 1M rays, one thread; fandisk, teapot,
    /// bunny, city): single rays 1.13-1.29x as fast (closest hit, incoherent), calls of 4,096
    /// rays 0.97-1.15x, whole batches of closest hits 0.95-1.04x; but batched any hit
    /// 0.88-0.98x and batched camera rays 0.87-0.92x (more box tests per ray in a stream).
    /// Memory 28.4-35.6 B/tri against 26.6-28.4. The quantized 4-wide tree takes 11.3-12.2
    /// B/tri for about 0.8x the 4-wide tree's speed per ray and 0.9x batched. The quantized
    /// 8-wide tree ([`AccelKind::Bvh8q`]) is 0.81-0.90x this one per ray on meshes that stay
    /// in the caches, at 12.2-15.8 B/tri; with leaf blocks ([`AccelKind::Bvh8qb`]) it is the
    /// faster one beyond the caches: [`AccelKind::for_mesh`] picks by size.
    pub const DEFAULT: AccelKind = AccelKind::Bvh8;

    /// The fastest exact structure for `mesh` per ray: [`AccelKind::DEFAULT`], unless the
    /// smallest wide tree and the mesh together are beyond the caches (over 16 MiB, from
    /// about 550k triangles), where each step of a walk waits on memory: there the quantized
    /// 8-wide tree with leaf blocks ([`AccelKind::Bvh8qb`]), whose leaves are read in one trip
    /// to memory instead of two, at 36-38 B/tri, under the full binary tree's 38.5 (or with
    /// the index copy, 20-21 B/tri, where blocks would take more). Against the 8-wide tree on
    /// two 1M-triangle meshes, one thread, 1M incoherent rays: 1.33-1.40x per ray alternated
    /// in one process (best of 3), 1.04-1.28x in four races with Embree (`peers --race`, where
    /// it reached 0.83-0.91 of Embree per ray).
    pub fn for_mesh(mesh: &Mesh) -> AccelKind {
        if crate::wide::mesh_beyond_caches(mesh) {
            AccelKind::Bvh8qb
        } else {
            AccelKind::DEFAULT
        }
    }

    /// The name used on the command line and in tables.
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::Aabb => "aabb",
            AccelKind::Quantized => "quantized",
            AccelKind::Bvh4 => "bvh4",
            AccelKind::Bvh8 => "bvh8",
            AccelKind::Bvh4q => "bvh4q",
            AccelKind::Bvh8q => "bvh8q",
            AccelKind::Bvh8qb => "bvh8qb",
            AccelKind::Zbt => "zbt",
            AccelKind::ZbtNoCache => "zbt-nocache",
            AccelKind::Hybrid => "hybrid",
            AccelKind::Grid => "grid",
            AccelKind::Kd => "kd",
            AccelKind::Hash => "hash",
        }
    }

    /// One line on what the structure is, for help texts.
    pub fn summary(self) -> &'static str {
        match self {
            AccelKind::Aabb => "binary SAH tree, 32-byte nodes",
            AccelKind::Quantized => "binary SAH tree, 16-byte quantized nodes",
            AccelKind::Bvh4 => "4-wide tree collapsed from the SAH tree, SIMD box tests",
            AccelKind::Bvh8 => "8-wide tree collapsed from the SAH tree, SIMD box tests",
            AccelKind::Bvh4q => "4-wide tree with 8-bit child boxes, 64-byte nodes",
            AccelKind::Bvh8q => "8-wide tree with 8-bit child boxes, 128-byte nodes",
            AccelKind::Bvh8qb => "bvh8q with leaf blocks on large trees: one read a leaf",
            AccelKind::Zbt => "zero-byte tree: no memory beside the mesh, box cache",
            AccelKind::ZbtNoCache => "zero-byte tree without the box cache",
            AccelKind::Hybrid => "AABB tree over zero-byte trees of 32-triangle chunks",
            AccelKind::Grid => "uniform grid, exact 3D-DDA walk, mailboxes",
            AccelKind::Kd => "SAH kd-tree, 8-byte nodes, front-to-back walk, mailboxes",
            AccelKind::Hash => "spatial hash: the grid's walk, only non-empty cells stored",
        }
    }

    /// Whether the structure follows [`BuildOptions::ordering`] (the binary trees' child-order
    /// byte); the wide trees order each node's children per ray octant from their own boxes
    /// instead, so building them with another ordering gives the same structure.
    pub fn uses_child_ordering(self) -> bool {
        match self {
            AccelKind::Aabb
            | AccelKind::Quantized
            | AccelKind::Zbt
            | AccelKind::ZbtNoCache
            | AccelKind::Hybrid => true,
            AccelKind::Bvh4
            | AccelKind::Bvh8
            | AccelKind::Bvh4q
            | AccelKind::Bvh8q
            | AccelKind::Bvh8qb
            | AccelKind::Grid
            | AccelKind::Kd
            | AccelKind::Hash => false,
        }
    }

    /// Whether the structure is a wide tree, whose leaves follow
    /// [`BuildOptions::wide_leaf_size`].
    pub fn is_wide(self) -> bool {
        matches!(
            self,
            AccelKind::Bvh4
                | AccelKind::Bvh8
                | AccelKind::Bvh4q
                | AccelKind::Bvh8q
                | AccelKind::Bvh8qb
        )
    }

    /// The kind called `name` (see [`AccelKind::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Builds the structure over `mesh`. Every structure answers in `mesh`'s triangle ids:
    /// the zero-byte trees, which reorder the triangles, are wrapped in [`Permuted`] (their
    /// [`Footprint::id_map_bytes`]). They read the options as [`ZbtOptions::from`] does.
    pub fn build(
        self,
        mesh: impl Into<Arc<Mesh>>,
        options: &BuildOptions,
    ) -> Result<AnyAccel, BuildError> {
        let mesh = mesh.into();
        options.validate()?;
        Ok(match self {
            AccelKind::Aabb => AnyAccel::new(<AabbTree>::build(mesh, options)?),
            AccelKind::Quantized => AnyAccel::new(QuantizedAabbTree::build(mesh, options)?),
            AccelKind::Bvh4 => AnyAccel::new(WideTree::build(mesh, options)?),
            AccelKind::Bvh8 => AnyAccel::new(WideTree8::build(mesh, options)?),
            AccelKind::Bvh4q => AnyAccel::new(QuantizedWideTree::build(mesh, options)?),
            AccelKind::Bvh8q => AnyAccel::new(QuantizedWideTree8::build(mesh, options)?),
            AccelKind::Bvh8qb => {
                AnyAccel::new(QuantizedWideTree8::build_with_blocks(mesh, options)?)
            }
            AccelKind::Zbt | AccelKind::ZbtNoCache => {
                let zbt = ZbtOptions {
                    box_cache: self == AccelKind::Zbt,
                    ..ZbtOptions::from(options)
                };
                let (tree, permutation) =
                    ZeroByteTree::build(Arc::unwrap_or_clone(mesh), &zbt).map_err(too_large)?;
                AnyAccel::new(Permuted::new(tree, permutation))
            }
            AccelKind::Hybrid => {
                let hybrid = HybridOptions {
                    zbt: ZbtOptions::from(options),
                    ..HybridOptions::default()
                };
                let (tree, permutation) =
                    HybridTree::build(Arc::unwrap_or_clone(mesh), &hybrid).map_err(too_large)?;
                AnyAccel::new(Permuted::new(tree, permutation))
            }
            AccelKind::Grid => AnyAccel::new(UniformGrid::build(mesh, &GridOptions::default())?),
            AccelKind::Kd => AnyAccel::new(KdTree::build(mesh, options.max_leaf_size)?),
            AccelKind::Hash => {
                AnyAccel::new(SpatialHash::build(mesh, &SpatialHash::default_options())?)
            }
        })
    }
}

/// A zero-byte build error as the catalog's [`BuildError`] (only the size limits can occur:
/// the catalog passes valid leaf and chunk sizes).
pub(crate) fn too_large(rejected: Rejected) -> BuildError {
    let (needed, max, format) = match rejected.error {
        ZbtError::TooManyTriangles { count, max } => (count, max, "zbt (triangles)"),
        ZbtError::TooManyVertices { count, max } => (count, max, "zbt (vertices)"),
        ZbtError::BadLeafSize(n) | ZbtError::BadChunkSize(n) => {
            unreachable!("the catalog passes valid sizes, not {n}")
        }
    };
    BuildError::TooLarge {
        format,
        needed,
        max,
    }
}

/// Any structure, behind one type (see the module docs).
pub struct AnyAccel {
    inner: Box<dyn Erased>,
}

impl AnyAccel {
    /// Wraps `accel`.
    pub fn new<A: Accel + Footprint + Send + 'static>(accel: A) -> Self {
        Self {
            inner: Box::new(accel),
        }
    }

    /// [`RayQueries::cast_ray`].
    pub fn cast_ray(&self, ray: &Ray) -> Option<Hit> {
        self.inner.cast_ray_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::cast_ray_with`].
    pub fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        self.inner.cast_ray_with(ray, kernel)
    }

    /// [`RayQueries::cast_ray_visits`].
    pub fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32) {
        self.inner.cast_ray_visits(ray, kernel)
    }

    /// [`RayQueries::occluded`].
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.inner.occluded_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::occluded_with`].
    pub fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        self.inner.occluded_with(ray, kernel)
    }

    /// [`RayQueries::for_each_hit`].
    pub fn for_each_hit(&self, ray: &Ray, mut f: impl FnMut(Hit)) {
        self.inner
            .for_each_hit_with(ray, Kernel::Watertight, &mut f)
    }

    /// [`RayQueries::for_each_hit_with`].
    pub fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, mut f: impl FnMut(Hit)) {
        self.inner.for_each_hit_with(ray, kernel, &mut f)
    }

    /// [`RayQueries::all_hits`].
    pub fn all_hits(&self, ray: &Ray) -> Vec<Hit> {
        self.inner.all_hits(ray)
    }

    /// [`BatchQueries::cast_rays`].
    pub fn cast_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), BatchError> {
        self.cast_rays_with(rays, hits, &BatchOptions::default())
    }

    /// [`BatchQueries::cast_rays_with`].
    pub fn cast_rays_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        self.inner.cast_rays_with(rays, hits, options)
    }

    /// [`BatchQueries::occluded_batch`].
    pub fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) -> Result<(), BatchError> {
        self.occluded_batch_with(rays, occluded, &BatchOptions::default())
    }

    /// [`BatchQueries::occluded_batch_with`].
    pub fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        self.inner.occluded_batch_with(rays, occluded, options)
    }

    /// [`BatchQueries::for_each_hit_batch`].
    pub fn for_each_hit_batch(&self, rays: &[Ray], f: impl Fn(usize, Hit) + Sync) {
        self.inner
            .for_each_hit_batch_with(rays, &BatchOptions::default(), &f)
    }

    /// [`BatchQueries::for_each_hit_batch_with`].
    pub fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: impl Fn(usize, Hit) + Sync,
    ) {
        self.inner.for_each_hit_batch_with(rays, options, &f)
    }
}

impl Footprint for AnyAccel {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn triangle_count(&self) -> usize {
        self.inner.triangle_count()
    }
    fn node_count(&self) -> usize {
        self.inner.node_count()
    }
    fn heap_bytes(&self) -> usize {
        self.inner.heap_bytes()
    }
    fn id_map_bytes(&self) -> usize {
        self.inner.id_map_bytes()
    }
}

impl std::fmt::Debug for AnyAccel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AnyAccel")
            .field("name", &self.name())
            .field("nodes", &self.node_count())
            .finish()
    }
}

/// The queries without generic parameters, so that they can be called through `dyn`.
trait Erased: Footprint + Send + Sync {
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit>;
    fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32);
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool;
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit));
    fn all_hits(&self, ray: &Ray) -> Vec<Hit>;
    fn cast_rays_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError>;
    fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError>;
    fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: &(dyn Fn(usize, Hit) + Sync),
    );
}

impl<A: Accel + Footprint + Send> Erased for A {
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        RayQueries::cast_ray_with(self, ray, kernel)
    }
    fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32) {
        RayQueries::cast_ray_visits(self, ray, kernel)
    }
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        RayQueries::occluded_with(self, ray, kernel)
    }
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit)) {
        RayQueries::for_each_hit_with(self, ray, kernel, f)
    }
    fn all_hits(&self, ray: &Ray) -> Vec<Hit> {
        RayQueries::all_hits(self, ray)
    }
    fn cast_rays_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        BatchQueries::cast_rays_with(self, rays, hits, options)
    }
    fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        BatchQueries::occluded_batch_with(self, rays, occluded, options)
    }
    fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: &(dyn Fn(usize, Hit) + Sync),
    ) {
        BatchQueries::for_each_hit_batch_with(self, rays, options, f)
    }
}
