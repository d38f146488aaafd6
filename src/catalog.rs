//! The one list of structures: [`AccelKind`] names each kind, [`AnyAccel`] holds a structure of
//! any kind behind one type.
//!
//! The list below (`structures!`) is the only place that enumerates the kinds: it makes the
//! kind enum, its names and summaries, the private enum of concrete trees behind [`AnyAccel`],
//! and [`AnyAccel::run`], which runs code generic over the structure ([`KindTask`]) on the
//! concrete tree. [`AccelKind::build`] then has one arm per kind. The command line, the
//! benchmarks, the peers and the tests iterate over [`AccelKind::ALL`], and scenes place
//! [`AnyAccel`]s, so a new structure is one line in the list plus one build arm; the
//! compiler points at both.

use std::any::Any;
use std::sync::Arc;

use crate::accel::{Accel, Footprint, RayStream, StreamLayout};
use crate::batch::BatchOptions;
use crate::bvh::{AabbTree, BuildError, BuildOptions, QuantizedAabbTree};
use crate::geom::{Aabb, Kernel, PreparedRay, Ray, TriangleTest};
use crate::grid::{GridOptions, SpatialHash, UniformGrid};
use crate::hit::{Hit, Visitor};
use crate::kdtree::KdTree;
use crate::mesh::Mesh;
use crate::permuted::Permuted;
use crate::query::{BatchError, BatchQueries, RayQueries};
use crate::wide::{QuantizedWideTree, QuantizedWideTree8, WideTree, WideTree8};
use crate::zbt::{HybridOptions, HybridTree, Rejected, ZbtError, ZbtOptions, ZeroByteTree};

/// What every structure of the list is: the bound [`KindTask::run`] gets its tree with.
pub trait Structure: RayQueries + BatchQueries + Footprint + Send + Sync + 'static {}

impl<A: RayQueries + BatchQueries + Footprint + Send + Sync + 'static> Structure for A {}

/// Code generic over the structure, run on the concrete tree inside an [`AnyAccel`] by
/// [`AnyAccel::run`] (one `match` per call, then the tree's own code).
pub trait KindTask {
    /// What the task returns.
    type Output;
    /// Runs the task on `tree`, of kind `kind`.
    fn run<A: Structure>(self, kind: AccelKind, tree: &A) -> Self::Output;
}

macro_rules! structures {
    ($($(#[$doc:meta])* $kind:ident($tree:ty) = $code:literal, $name:literal: $summary:literal;)+) => {
        /// A kind of acceleration structure (every kind answers every query exactly alike;
        /// [`AccelKind::for_mesh`] picks one, docs/benchmarks.md compares them).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum AccelKind {
            $($(#[$doc])* $kind,)+
        }

        impl AccelKind {
            /// Every kind, in the list's order.
            pub const ALL: [AccelKind; [$(AccelKind::$kind),+].len()] = [$(AccelKind::$kind),+];

            /// The name used on the command line and in tables.
            pub fn name(self) -> &'static str {
                match self {
                    $(AccelKind::$kind => $name,)+
                }
            }

            /// One line on what the structure is, for help texts.
            pub fn summary(self) -> &'static str {
                match self {
                    $(AccelKind::$kind => $summary,)+
                }
            }

            /// Whether structures of this kind can be saved and loaded ([`AnyAccel::save`];
            /// the others return [`crate::CookError::Unsupported`]): for bindings and tools
            /// that offer the choice before they build.
            pub fn cooks(self) -> bool {
                match self {
                    $(AccelKind::$kind => <$tree as crate::cook::Cook>::COOKS,)+
                }
            }

            /// Whether structures of this kind answer shape queries ([`crate::shape`]; the
            /// others return [`crate::shape::ShapeError::Unsupported`]).
            pub fn answers_shapes(self) -> bool {
                match self {
                    $(AccelKind::$kind => <$tree as crate::shape::ShapeWalk>::WALKS,)+
                }
            }

            /// The kind's number in cooked files (`crate::cook`): fixed forever, whatever
            /// the list's order.
            pub(crate) fn code(self) -> u32 {
                match self {
                    $(AccelKind::$kind => $code,)+
                }
            }

            /// The kind numbered `code` in cooked files.
            pub(crate) fn from_code(code: u32) -> Option<Self> {
                match code {
                    $($code => Some(AccelKind::$kind),)+
                    _ => None,
                }
            }
        }

        /// Reads a cooked body of kind `kind` over `mesh` (`crate::cook`).
        fn read_tree(
            kind: AccelKind,
            mesh: Arc<Mesh>,
            body: &mut crate::cook::Reader<'_>,
        ) -> Result<Tree, crate::cook::CookError> {
            Ok(match kind {
                $(AccelKind::$kind => {
                    Tree::$kind(<$tree as crate::cook::Cook>::read_body(kind, mesh, body)?)
                })+
            })
        }

        /// The concrete trees.
        #[derive(Debug)]
        enum Tree {
            $($kind($tree),)+
        }

        /// Runs `$body` with `$t` bound to the concrete tree of `$tree` (a `&Tree`) and
        /// `$kind` to its kind.
        macro_rules! each_tree {
            ($tree_ref:expr, ($kind_var:ident, $t:ident) => $body:expr) => {
                match $tree_ref {
                    $(Tree::$kind($t) => {
                        let $kind_var = AccelKind::$kind;
                        $body
                    })+
                }
            };
        }
    };
}

structures! {
    /// [`AabbTree`]: binary SAH tree, 32-byte nodes; the only kind a scene can refit.
    Aabb(AabbTree) = 1, "aabb": "binary SAH tree, 32-byte nodes";
    /// [`QuantizedAabbTree`]: the same tree with 16-byte quantized nodes.
    Quantized(QuantizedAabbTree) = 2, "quantized": "binary SAH tree, 16-byte quantized nodes";
    /// [`WideTree`]: the same tree collapsed to 4 children per node, SIMD box tests.
    Bvh4(WideTree) = 3, "bvh4": "4-wide tree collapsed from the SAH tree, SIMD box tests";
    /// [`WideTree8`]: the same tree collapsed to 8 children per node (AVX2 box tests where
    /// the CPU has them). The default ([`AccelKind::DEFAULT`]).
    Bvh8(WideTree8) = 4, "bvh8": "8-wide tree collapsed from the SAH tree, SIMD box tests";
    /// [`QuantizedWideTree`]: the 4-wide tree with 8-bit child boxes, one 64-byte line a node.
    Bvh4q(QuantizedWideTree) = 5, "bvh4q": "4-wide tree with 8-bit child boxes, 64-byte nodes";
    /// [`QuantizedWideTree8`]: the 8-wide tree with 8-bit child boxes, two 64-byte lines a
    /// node; beyond the caches its leaves are blocks read in one trip to memory
    /// ([`crate::LeafCopy::Blocks`]), and [`AccelKind::for_mesh`] picks it there.
    Bvh8q(QuantizedWideTree8) = 6, "bvh8q": "8-wide tree with 8-bit child boxes, 128-byte nodes";
    /// [`ZeroByteTree`]: no memory beside the mesh, boxes recomputed, per-thread box cache.
    Zbt(Permuted<ZeroByteTree>) = 7, "zbt": "zero-byte tree: no memory beside the mesh, box cache";
    /// [`HybridTree`]: stored boxes down to chunks of 32 triangles, zero-byte trees below.
    Hybrid(Permuted<HybridTree>) = 8, "hybrid": "AABB tree over zero-byte trees of 32-triangle chunks";
    /// [`UniformGrid`]: cells over the bounds walked by an exact 3D-DDA, mailboxed.
    Grid(UniformGrid) = 9, "grid": "uniform grid, exact 3D-DDA walk, mailboxes";
    /// [`KdTree`]: SAH kd-tree, 8-byte nodes, front-to-back walk, mailboxed.
    Kd(KdTree) = 10, "kd": "SAH kd-tree, 8-byte nodes, front-to-back walk, mailboxes";
    /// [`SpatialHash`]: the grid's cells and walk, only non-empty cells stored, hashed.
    Hash(SpatialHash) = 11, "hash": "spatial hash: the grid's walk, only non-empty cells stored";
}

impl AccelKind {
    /// The fastest exact structure on meshes that stay in the caches, all queries together:
    /// the 8-wide tree (figures in `docs/benchmarks.md`).
    pub const DEFAULT: AccelKind = AccelKind::Bvh8;

    /// The fastest exact structure for `mesh` per ray: [`AccelKind::DEFAULT`], unless the
    /// smallest wide tree and the mesh together are beyond the caches (over 16 MiB, from
    /// about 550k triangles), where each step of a walk waits on memory: there the quantized
    /// 8-wide tree, whose leaf blocks are read in one trip to memory instead of two.
    pub fn for_mesh(mesh: &Mesh) -> AccelKind {
        if crate::wide::mesh_beyond_caches(mesh) {
            AccelKind::Bvh8q
        } else {
            AccelKind::DEFAULT
        }
    }

    /// Whether the structure follows [`BuildOptions::ordering`] (the binary trees' child-order
    /// byte); the wide trees order each node's children per ray octant from their own boxes
    /// instead, and the grids and kd-tree walk space front to back.
    pub fn uses_child_ordering(self) -> bool {
        matches!(
            self,
            AccelKind::Aabb | AccelKind::Quantized | AccelKind::Zbt | AccelKind::Hybrid
        )
    }

    /// Whether the structure is a wide tree, whose leaves follow
    /// [`BuildOptions::wide_leaf_size`].
    pub fn is_wide(self) -> bool {
        matches!(
            self,
            AccelKind::Bvh4 | AccelKind::Bvh8 | AccelKind::Bvh4q | AccelKind::Bvh8q
        )
    }

    /// The kind called `name` (see [`AccelKind::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Builds the structure over `mesh`. Every structure answers in `mesh`'s triangle ids:
    /// the zero-byte trees, which reorder the triangles, keep the permutation beside them (their
    /// [`Footprint::id_map_bytes`]) and read the options as [`ZbtOptions::from`] does; the grid
    /// and the hash take their default cells, the kd-tree only the leaf size.
    pub fn build(
        self,
        mesh: impl Into<Arc<Mesh>>,
        options: &BuildOptions,
    ) -> Result<AnyAccel, BuildError> {
        build(self, mesh.into(), options)
    }
}

/// [`AccelKind::build`], compiled once (not per caller's mesh type).
fn build(kind: AccelKind, mesh: Arc<Mesh>, options: &BuildOptions) -> Result<AnyAccel, BuildError> {
    options.validate()?;
    let bounds = mesh.bounds();
    let tree = match kind {
        AccelKind::Aabb => Tree::Aabb(AabbTree::build(mesh, options)?),
        AccelKind::Quantized => Tree::Quantized(QuantizedAabbTree::build(mesh, options)?),
        AccelKind::Bvh4 => Tree::Bvh4(WideTree::build(mesh, options)?),
        AccelKind::Bvh8 => Tree::Bvh8(WideTree8::build(mesh, options)?),
        AccelKind::Bvh4q => Tree::Bvh4q(QuantizedWideTree::build(mesh, options)?),
        AccelKind::Bvh8q => Tree::Bvh8q(QuantizedWideTree8::build(mesh, options)?),
        AccelKind::Zbt => {
            let zbt = ZbtOptions::from(options);
            let (tree, order) =
                ZeroByteTree::build(Arc::unwrap_or_clone(mesh), &zbt).map_err(too_large)?;
            Tree::Zbt(Permuted::new(tree, order))
        }
        AccelKind::Hybrid => {
            let hybrid = HybridOptions {
                zbt: ZbtOptions::from(options),
                ..HybridOptions::default()
            };
            let (tree, order) =
                HybridTree::build(Arc::unwrap_or_clone(mesh), &hybrid).map_err(too_large)?;
            Tree::Hybrid(Permuted::new(tree, order))
        }
        AccelKind::Grid => Tree::Grid(UniformGrid::build(mesh, &GridOptions::default())?),
        AccelKind::Kd => Tree::Kd(KdTree::build(mesh, options.max_leaf_size)?),
        AccelKind::Hash => Tree::Hash(SpatialHash::build(mesh, &SpatialHash::default_options())?),
    };
    Ok(AnyAccel { tree, bounds })
}

/// A zero-byte build error as the catalog's [`BuildError`] (only the size limits can occur:
/// the catalog validated the leaf size and passes the default chunk size).
fn too_large(rejected: Rejected) -> BuildError {
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

/// A structure of any kind, chosen at run time ([`AccelKind::build`]). It answers every query
/// of [`RayQueries`] and [`BatchQueries`] with its tree's own engines (one `match` per call),
/// and scenes place it under their instances.
#[derive(Debug)]
pub struct AnyAccel {
    tree: Tree,
    /// The mesh's box: every triangle the tree can report lies in it.
    bounds: Aabb,
}

impl AnyAccel {
    /// A box holding every triangle the structure may report (empty if none).
    pub fn mesh_bounds(&self) -> Aabb {
        self.bounds
    }

    /// Runs `f` on the binary AABB tree behind this structure, if it is one
    /// ([`AccelKind::Aabb`], the one kind a scene can refit after its mesh deforms), then
    /// takes the mesh's box again, whatever `f` did to the mesh.
    pub(crate) fn with_aabb<R>(&mut self, f: impl FnOnce(&mut AabbTree) -> R) -> Option<R> {
        let Tree::Aabb(tree) = &mut self.tree else {
            return None;
        };
        let result = f(tree);
        self.bounds = tree.mesh().bounds();
        Some(result)
    }
}

/// Each kind's per-thread scratch, made on first use, by kind (see [`Accel::Scratch`]).
#[derive(Default)]
pub struct AnyScratch {
    slots: Vec<Option<Box<dyn Any + Send>>>,
}

impl AnyScratch {
    /// The scratch of kind `kind`, of type `S`.
    #[inline]
    fn get<S: Default + Send + 'static>(&mut self, kind: AccelKind) -> &mut S {
        let index = kind as usize;
        if self.slots.len() <= index {
            self.slots.resize_with(AccelKind::ALL.len(), || None);
        }
        self.slots[index]
            .get_or_insert_with(|| Box::new(S::default()))
            .downcast_mut::<S>()
            .unwrap_or_else(|| unreachable!("a kind's slot holds its tree's scratch type"))
    }
}

impl AnyAccel {
    /// Runs `task` on the concrete tree.
    #[inline]
    pub fn run<T: KindTask>(&self, task: T) -> T::Output {
        each_tree!(&self.tree, (kind, tree) => task.run(kind, tree))
    }

    /// The corners of triangle `id` in the structure's triangle ids (the ids its hits
    /// report, the mesh's own even where the tree keeps the mesh reordered), or `None` past
    /// the last triangle: what a caller needs for a hit's normal without keeping the mesh.
    pub fn triangle(&self, id: u32) -> Option<[glam::Vec3; 3]> {
        let exists = (id as usize) < Footprint::triangle_count(self);
        exists.then(|| self.corners(id))
    }

    /// Runs `query`'s walk on the structure, or says it has none.
    pub(crate) fn walk_shape<Q: crate::shape::BoxQuery>(
        &self,
        query: &mut Q,
    ) -> Result<(), crate::shape::ShapeError> {
        use crate::shape::ShapeWalk;
        let kind = self.kind();
        if !kind.answers_shapes() {
            return Err(crate::shape::ShapeError::Unsupported { kind });
        }
        each_tree!(&self.tree, (_kind, tree) => tree.walk_shape(query));
        Ok(())
    }

    /// The corners of triangle `id` of the structure's mesh (an id its queries report).
    pub(crate) fn corners(&self, id: u32) -> [glam::Vec3; 3] {
        each_tree!(&self.tree, (_kind, tree) => crate::accel::Corners::corners(tree, id))
    }

    /// The structure's kind.
    pub fn kind(&self) -> AccelKind {
        each_tree!(&self.tree, (kind, _tree) => kind)
    }

    /// The mesh whose triangle ids the structure answers in: `None` for the zero-byte trees
    /// (`zbt`, `hybrid`), which keep it reordered (their hits are renamed on the way out).
    pub fn mesh(&self) -> Option<&Mesh> {
        each_tree!(&self.tree, (_kind, tree) => crate::cook::Cook::own_mesh(tree))
    }

    /// Writes the structure's mesh and body to a cooked payload (`crate::cook`).
    pub(crate) fn write_cooked(
        &self,
        out: &mut crate::cook::Writer,
    ) -> Result<(), crate::cook::CookError> {
        each_tree!(&self.tree, (kind, tree) => crate::cook::Cook::write(tree, kind, out))
    }

    /// Reads a structure of kind `kind` over `mesh` from its cooked body.
    pub(crate) fn read_cooked(
        kind: AccelKind,
        mesh: Arc<Mesh>,
        body: &mut crate::cook::Reader<'_>,
    ) -> Result<Self, crate::cook::CookError> {
        let bounds = mesh.bounds();
        let tree = read_tree(kind, mesh, body)?;
        Ok(AnyAccel { tree, bounds })
    }
}

/// Under a scene's instances: each instance visit runs its tree's own walk.
impl Accel for AnyAccel {
    type Scratch = AnyScratch;
    // Scenes hand their meshes' trees streams in lanes (they partition at the top level).
    const STREAM_LAYOUT: StreamLayout = StreamLayout::Lanes;

    #[inline]
    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut AnyScratch,
        visitor: &mut V,
    ) -> f32 {
        each_tree!(&self.tree, (kind, tree) => {
            tree.trace::<K, V>(ray, id, scratch.get(kind), visitor)
        })
    }

    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut AnyScratch,
        visitor: &mut V,
    ) {
        each_tree!(&self.tree, (kind, tree) => {
            tree.trace_stream::<K, V>(stream, scratch.get(kind), visitor)
        })
    }
}

/// Each query goes to the tree's own (one `match` per call).
impl RayQueries for AnyAccel {
    #[cfg_attr(test, inline)]
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        each_tree!(&self.tree, (_kind, tree) => tree.cast_ray_with(ray, kernel))
    }
    #[cfg_attr(test, inline)]
    fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32) {
        each_tree!(&self.tree, (_kind, tree) => tree.cast_ray_visits(ray, kernel))
    }
    #[cfg_attr(test, inline)]
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        each_tree!(&self.tree, (_kind, tree) => tree.occluded_with(ray, kernel))
    }
    #[cfg_attr(test, inline)]
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit)) {
        each_tree!(&self.tree, (_kind, tree) => tree.for_each_hit_with(ray, kernel, f))
    }
    fn visit<V: Visitor>(&self, ray: &Ray, kernel: Kernel, visitor: &mut V)
    where
        Self: Sized,
    {
        each_tree!(&self.tree, (_kind, tree) => tree.visit(ray, kernel, visitor))
    }
}

impl BatchQueries for AnyAccel {
    #[cfg_attr(test, inline)]
    fn cast_ray_batch_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        each_tree!(&self.tree, (_kind, tree) => tree.cast_ray_batch_with(rays, hits, options))
    }
    #[cfg_attr(test, inline)]
    fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        each_tree!(&self.tree, (_kind, tree) => tree.occluded_batch_with(rays, occluded, options))
    }
    #[cfg_attr(test, inline)]
    fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: &(dyn Fn(usize, Hit) + Sync),
    ) {
        each_tree!(&self.tree, (_kind, tree) => tree.for_each_hit_batch_with(rays, options, f))
    }
}

impl Footprint for AnyAccel {
    fn name(&self) -> &'static str {
        self.kind().name()
    }
    fn triangle_count(&self) -> usize {
        each_tree!(&self.tree, (_kind, tree) => tree.triangle_count())
    }
    fn node_count(&self) -> usize {
        each_tree!(&self.tree, (_kind, tree) => tree.node_count())
    }
    fn heap_bytes(&self) -> usize {
        each_tree!(&self.tree, (_kind, tree) => tree.heap_bytes())
    }
    fn id_map_bytes(&self) -> usize {
        each_tree!(&self.tree, (_kind, tree) => tree.id_map_bytes())
    }
}
