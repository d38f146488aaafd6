//! The wide BVHs: the binary SAH tree collapsed so that each node holds four (`WideTree`) or
//! eight (`WideTree8`, the default) children's boxes, tested against a ray in one SIMD pass:
//! fewer, slightly longer node visits than the binary tree's, and fewer stack entries.
//!
//! Node layouts, each with its box test and its [`NodeKind`] implementation:
//! - [`node4`]: the 4-wide node layout.
//! - [`node8`]: the 8-wide node layout.
//! - [`node4q`], [`node8q`]: the 4- and 8-wide nodes with 8-bit child boxes on a per-node
//!   grid (`quantize`), decoded before the same box tests.
//!
//! What the layouts share:
//! - `kind`: [`NodeKind`], what the walks need of a node layout, so that one tree type, one
//!   collapse, one one-ray loop and one side-by-side engine serve every layout.
//! - `ray`: what the box tests take: a ray's constants and a node's planes as it meets them.
//! - `order`: a node's child words and per-octant child orders, built from its children.
//! - `slabs`: the portable box tests (4 lanes, identical lane by lane to the scalar slab test;
//!   8 lanes as two halves).
//! - `rows`: the 8-wide node's boxes as rows aligned for AVX2.
//! - `simd`: the box tests with SSE (4 lanes) and AVX2 (8 lanes) on x86-64 (their portable
//!   twins are in `slabs` and [`node8q`]), and the stream split's AVX2 eight-ray box tests and
//!   list writes (twins in `stream`).
//! - `stack`: the one-ray loop's pending children, pushed without branches.
//!
//! Building and walking:
//! - `collapse`: binary tree to wide tree.
//! - `leaves`: a leaf word's triangles, from slot ranges over the binary tree's leaves or from
//!   `blocks`, each leaf's ids and distinct corners in one run of words (one read a leaf).
//! - `single`: the one-ray loop, children in the node's precomputed order for the ray's octant.
//! - `stream`: a stream of rays going down either tree once, split into index lists per
//!   child.
//! - `interleaved`: several rays walked side by side, one loop turn each in turn.
//! - `dispatch`: the loops' baseline and AVX2 copies, picked at run time.
//!
//! It implements [`Accel`] directly (its walk is not the binary one). Triangles are the binary
//! tree's leaves, in the same order, tested with the same kernels, so answers are those of
//! every other structure, bit for bit.

pub(crate) mod blocks;
mod boxes;
pub(crate) mod collapse;
mod cook;
pub(crate) mod dispatch;
pub(crate) mod interleaved;
pub(crate) mod kind;
pub(crate) mod leaves;
pub mod node4;
pub mod node4q;
pub mod node8;
pub mod node8q;
pub(crate) mod order;
pub(crate) mod quantize;
pub(crate) mod ray;
pub(crate) mod rows;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
pub(crate) mod simd;
pub(crate) mod single;
pub(crate) mod slabs;
// Unsafe reads (`Stack::pop`, `Stack::peek`) of slots the stack wrote.
#[allow(unsafe_code)]
pub(crate) mod stack;
pub(crate) mod stream;

use std::sync::Arc;

use glam::Vec3;

use crate::accel::{Accel, Footprint, RayStream};
use crate::batch::Interleave;
use crate::batch::group::has_dense_octant;
use crate::bvh::LeafCopy;
use crate::bvh::build::{BuildError, BuildOptions, build};
use crate::bvh::leaves::LeafTriangles;
use crate::bvh::nodes::leaf_word;
use crate::geom::{Aabb, PreparedRay, Ray, TriangleTest};
use crate::hit::Visitor;
use crate::mesh::Mesh;
use blocks::LeafBlocks;
pub use kind::NodeKind;
use leaves::WideLeaves;
use node4::WideNode;
use node4q::QuantizedWideNode;
use node8::WideNode8;
use node8q::QuantizedWideNode8;
use stack::Stack;

/// A wide BVH over a mesh (see the module docs), of nodes `N`: [`WideTree`] (4 children per
/// node), [`WideTree8`] (8), [`QuantizedWideTree`] (4, quantized) or [`QuantizedWideTree8`]
/// (8, quantized).
#[derive(Clone, Debug)]
pub struct WideBvh<N: NodeKind> {
    nodes: Vec<N>,
    /// The root: a node index, or a leaf word when the tree is a single leaf.
    root: u32,
    /// The root's box (the binary root's): wide nodes store their children's boxes only.
    root_bounds: Aabb,
    /// The leaves' triangles (the binary tree's, in its slot order), which leaf words address
    /// by slot range or by block.
    triangles: WideLeaves,
    /// Whether the tree is beyond the caches (nodes, leaf copy and mesh above
    /// [`INTERLEAVE_ABOVE_BYTES`]): its one-ray walks prefetch (`single::trace_from`), its
    /// incoherent batches take long chunks ([`LARGE_TREE_CHUNK`]).
    beyond_caches: bool,
}

/// The 4-wide tree: the fastest for batches of any-hit and camera rays (see
/// [`crate::AccelKind::DEFAULT`]), and the least memory of the trees with full boxes.
pub type WideTree = WideBvh<WideNode>;

/// The 4-wide tree with its child boxes quantized to 8 bits a plane on a per-node grid (rounded
/// outwards): one 64-byte cache line per node instead of two, the same answers.
pub type QuantizedWideTree = WideBvh<QuantizedWideNode>;

/// The 8-wide tree with its child boxes quantized to 8 bits a plane on a per-node grid (rounded
/// outwards): two 64-byte cache lines per node instead of four, the same answers.
pub type QuantizedWideTree8 = WideBvh<QuantizedWideNode8>;

/// The 8-wide tree, the crate's default structure: about a third fewer node visits than the
/// 4-wide one per ray; its batches use the same stream engine as the 4-wide tree's (nodes
/// shared; side by side for short incoherent streams on large trees), at 0.87-1.04x its
/// speed (more box tests per ray; docs/benchmarks.md).
pub type WideTree8 = WideBvh<WideNode8>;

impl<N: NodeKind> WideBvh<N> {
    /// Builds the binary SAH tree with `options` and collapses it. An empty mesh gives an empty
    /// tree that every ray misses.
    pub fn build(mesh: impl Into<Arc<Mesh>>, options: &BuildOptions) -> Result<Self, BuildError> {
        Self::build_arc(mesh.into(), options)
    }

    /// [`WideBvh::build`], compiled once per layout.
    fn build_arc(mesh: Arc<Mesh>, options: &BuildOptions) -> Result<Self, BuildError> {
        let built = build(&mesh, options)?;
        check_size(built.triangle_order.len(), built.nodes.len(), N::FORMAT)?;
        let root_bounds = built.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds);
        let (mut nodes, mut root) =
            collapse::collapse(&built, options.wide_leaf_size, options.parallel)
                .unwrap_or((Vec::new(), 0));
        let triangles = leaves(
            (&mut nodes, &mut root),
            mesh,
            built.triangle_order,
            (options.leaf_copy, options.parallel),
        );
        Ok(Self::from_parts(nodes, root, root_bounds, triangles))
    }

    /// The tree of `nodes`, `root` (with box `root_bounds`) and leaves `triangles`.
    fn from_parts(nodes: Vec<N>, root: u32, root_bounds: Aabb, triangles: WideLeaves) -> Self {
        let mut tree = Self {
            nodes,
            root,
            root_bounds,
            triangles,
            beyond_caches: false,
        };
        tree.beyond_caches = tree.working_set_bytes() > INTERLEAVE_ABOVE_BYTES;
        if tree.beyond_caches {
            // Only there: merging pages is synchronous work at build time (see `huge_pages`).
            crate::huge_pages::advise(&tree.nodes);
            tree.triangles.advise_huge_pages();
        }
        tree
    }

    /// The mesh the tree was built over; triangle ids refer to it.
    pub fn mesh(&self) -> &Mesh {
        self.triangles.mesh()
    }

    /// True if no ray can hit anything.
    fn is_empty(&self) -> bool {
        self.triangles.len() == 0
    }

    /// Triangle `k` of leaf `word`: its id and corners.
    #[inline(always)]
    fn triangle(&self, word: u32, k: u32) -> (u32, [Vec3; 3]) {
        self.triangles.get(word, k)
    }

    /// Prefetches link `stage` of the read chain of leaf `word` (see
    /// [`LeafTriangles::prefetch`]); returns the next stage ([`LEAF_READY`] when the corners
    /// are on their way).
    #[inline(always)]
    fn prefetch_leaf(&self, word: u32, stage: u8) -> u8 {
        if self.triangles.prefetch(word, stage) {
            LEAF_READY
        } else {
            stage + 1
        }
    }

    /// Prefetches the first reads of child word `word`: a node's lines, or a leaf's first
    /// link ([`WideBvh::prefetch_leaf`]).
    #[inline(always)]
    fn prefetch_item(&self, word: u32) {
        if leaf_word::is_leaf(word) {
            self.prefetch_leaf(word, 0);
        } else {
            self.prefetch_node(word);
        }
    }

    /// Prefetches the cache lines of node `index`.
    #[inline(always)]
    fn prefetch_node(&self, index: u32) {
        self.nodes[index as usize].prefetch();
    }
}

/// The leaf triangles of `order` over `mesh` for the tree of `nodes` and `root`, with the copy
/// `asked` ([`LeafCopy::Auto`]: see [`default_leaf_copy`]):
/// blocks (the tree's leaf words rewritten to address them) if the copy is blocks, they are
/// addressable and, where `Auto` chose them, they take at most
/// [`AUTO_BLOCKS_MAX_BYTES_PER_TRIANGLE`] with the nodes; else slots (with the index copy in
/// place of blocks). Blocks are made on rayon's pool if `parallel`.
fn leaves<N: NodeKind>(
    (nodes, root): (&mut [N], &mut u32),
    mesh: Arc<Mesh>,
    order: Vec<u32>,
    (asked, parallel): (LeafCopy, bool),
) -> WideLeaves {
    let copy = asked.or(default_leaf_copy::<N>(&mesh));
    let budget = (asked == LeafCopy::Auto)
        .then(|| mesh.triangle_count() * AUTO_BLOCKS_MAX_BYTES_PER_TRIANGLE);
    if copy == LeafCopy::Blocks {
        let leaf_words: Vec<u32> = leaf_words_mut((nodes, root)).map(|word| *word).collect();
        let made = LeafBlocks::new(mesh.clone(), &order, &leaf_words, parallel);
        let fits = |blocks: &LeafBlocks| {
            budget.is_none_or(|max| size_of_val(nodes) + blocks.heap_bytes() <= max)
        };
        if let Some((blocks, block_words)) = made.filter(|(blocks, _)| fits(blocks)) {
            // The same walk over the leaf words, so the block words come in its order.
            for (word, block_word) in leaf_words_mut((nodes, root)).zip(block_words) {
                *word = block_word;
            }
            return WideLeaves::Blocks(blocks);
        }
    }
    WideLeaves::Slots(LeafTriangles::new(mesh, order, copy))
}

/// Every leaf word of the tree of `nodes` and `root` (the root, if the tree is one leaf).
fn leaf_words_mut<'a, N: NodeKind>(
    (nodes, root): (&'a mut [N], &'a mut u32),
) -> impl Iterator<Item = &'a mut u32> {
    let lone_root = nodes.is_empty().then_some(root);
    let children = nodes.iter_mut().flat_map(|node| node.children_mut());
    lone_root
        .into_iter()
        .chain(children)
        .filter(|word| leaf_word::is_leaf(**word))
}

/// What a tree over `mesh` copies of its leaves by default: the layout's `LEAF_COPY_LARGE` if
/// the smallest wide tree and the mesh take over [`LARGE_TREE_BYTES`], else its `LEAF_COPY`.
fn default_leaf_copy<N: NodeKind>(mesh: &Mesh) -> LeafCopy {
    if smallest_working_set(mesh) > LARGE_TREE_BYTES {
        N::LEAF_COPY_LARGE
    } else {
        N::LEAF_COPY
    }
}

/// Whether the smallest wide tree over `mesh`, with the mesh, is beyond the caches (above
/// [`INTERLEAVE_ABOVE_BYTES`]). Known before a build, for [`crate::AccelKind::for_mesh`].
pub(crate) fn mesh_beyond_caches(mesh: &Mesh) -> bool {
    smallest_working_set(mesh) > INTERLEAVE_ABOVE_BYTES
}

/// The bytes of the smallest wide tree over `mesh` (the quantized 8-wide tree's nodes and slot
/// order, about [`QUANTIZED_TREE_BYTES_PER_TRIANGLE`] without a leaf copy) and the mesh.
fn smallest_working_set(mesh: &Mesh) -> usize {
    mesh.triangle_count() * QUANTIZED_TREE_BYTES_PER_TRIANGLE + mesh.heap_bytes()
}

/// The quantized 8-wide tree's nodes and slot order per triangle (12.2-12.9 bytes measured on
/// the fandisk, teapot, bunny, a 1M-triangle terrain and a 500k-triangle heightfield).
const QUANTIZED_TREE_BYTES_PER_TRIANGLE: usize = 13;

/// Above this many bytes (smallest tree and mesh) a tree takes its layout's leaf copy for large
/// trees ([`NodeKind`]'s `LEAF_COPY_LARGE`: leaf blocks for the quantized 8-wide tree). Below
/// it the tree mostly stays in cache and memory is the quantized trees' point. Above it the
/// copy pays: on a 500k-triangle heightfield (15.5 MB) leaf blocks take about a quarter off the
/// quantized 8-wide tree's time per ray (docs/benchmarks.md).
const LARGE_TREE_BYTES: usize = 8 << 20;

/// The most bytes a triangle a tree's nodes and leaf blocks may take when the blocks are the
/// default's choice ([`LeafCopy::Auto`]): the full binary tree's 38.5 on the bench's scenes.
/// Blocks that would take more (a city of small leaves: 41.7) give way to the index copy.
const AUTO_BLOCKS_MAX_BYTES_PER_TRIANGLE: usize = 38;

/// A leaf's stage once its whole read chain is prefetched.
const LEAF_READY: u8 = 2;

/// Fails if leaf words cannot address `slots` triangle slots, or child words the wide nodes
/// of a binary tree of `binary_nodes` nodes (fewer than that); `format` names the layout.
fn check_size(slots: usize, binary_nodes: usize, format: &'static str) -> Result<(), BuildError> {
    let max_nodes = leaf_word::LEAF_BIT as usize;
    if slots > leaf_word::MAX_SLOTS || binary_nodes > max_nodes {
        return Err(BuildError::TooLarge {
            format,
            needed: slots.max(binary_nodes),
            max: leaf_word::MAX_SLOTS.min(max_nodes),
        });
    }
    Ok(())
}

/// Per-thread scratch of the wide traversals.
#[derive(Debug)]
pub struct WideScratch {
    /// The one-ray loop's stack for [`Accel::trace`] (a scene's rays, which come with this
    /// scratch) and for the stream engine's lists finished one ray at a time. A ray traced
    /// alone brings its own (`trace_alone`).
    stack: Stack,
    /// Stream: the index lists and what splitting them needs.
    lists: stream::Lists,
    /// Stream: copies of the rays of a stream in lanes, and their batch positions.
    copies: Vec<PreparedRay>,
    batch_ids: Vec<u32>,
    /// Interleaved engine: one stack per walker, on the heap (a stack is 8 KiB, held inline).
    stacks: Box<[Stack; interleaved::LANES]>,
}

impl Default for WideScratch {
    fn default() -> Self {
        // The walkers' stacks are made one at a time straight into the heap, so that making a
        // scratch on a thread with a small stack never holds them all there at once.
        let stacks: Box<[Stack]> = (0..interleaved::LANES).map(|_| Stack::default()).collect();
        Self {
            stack: Stack::default(),
            lists: stream::Lists::default(),
            copies: Vec::new(),
            batch_ids: Vec::new(),
            stacks: stacks
                .try_into()
                .unwrap_or_else(|_| unreachable!("LANES stacks were made")),
        }
    }
}

impl<N: NodeKind> Accel for WideBvh<N> {
    type Scratch = WideScratch;
    /// A chunk's small octant groups are one stream of mixed octants, and chunks are shorter
    /// than other structures' (see `wide::stream::CHUNK`).
    const MIXES_SMALL_OCTANTS: bool = true;
    const DEFAULT_MAX_CHUNK: usize = stream::CHUNK;

    /// 1,048,576 rays (`LARGE_TREE_CHUNK`) for incoherent rays on a tree beyond the caches
    /// (over 16 MiB with its mesh), else 65,536 (`stream::CHUNK`). A batch with a dense octant
    /// (`batch::group::has_dense_octant`: a camera's rays) keeps 65,536: its rays share nodes
    /// well enough in such chunks, and a longer chunk costs them more in records out of the
    /// caches than it saves (about 14% slower in chunks of 1M on the terrain's camera rays).
    fn max_chunk(&self, rays: &[Ray]) -> usize {
        if self.beyond_caches && !has_dense_octant(rays) {
            LARGE_TREE_CHUNK
        } else {
            Self::DEFAULT_MAX_CHUNK
        }
    }

    /// The root box: every child box of the root node lies inside it (the one-ray loop leaves
    /// the test to the root node, see `single::trace`).
    fn cull_bounds(&self) -> Option<Aabb> {
        (!self.is_empty()).then_some(self.root_bounds)
    }

    #[inline]
    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut WideScratch,
        visitor: &mut V,
    ) -> f32 {
        let prefetch = self.beyond_caches;
        dispatch::trace::<N, K, V>((true, prefetch), self, ray, id, &mut scratch.stack, visitor)
    }

    /// The one-ray loop with a stack of its own on the call stack (made without writing to
    /// it, see `wide::stack::Stack`), not the workspace's.
    #[inline(always)]
    fn trace_alone<K: TriangleTest, V: Visitor>(&self, ray: &PreparedRay, visitor: &mut V) {
        let mut stack = Stack::default();
        let prefetch = self.beyond_caches;
        dispatch::trace::<N, K, V>((true, prefetch), self, ray, 0, &mut stack, visitor);
    }

    /// Rays side by side for short incoherent streams on large trees ([`Interleave::Auto`]: see
    /// `interleaves`), else nodes shared by the rays that reach them (`stream`, for every
    /// layout).
    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut WideScratch,
        visitor: &mut V,
    ) {
        if self.walks_side_by_side(stream, V::ENDS_RAYS) {
            dispatch::trace_side_by_side::<N, K, V>(true, self, stream, scratch, visitor)
        } else {
            dispatch::trace_shared::<N, K, V>(true, self, stream, scratch, visitor)
        }
    }
}

/// [`Interleave::Auto`] interleaves rays above this many bytes of nodes, leaf order and mesh.
/// Below it the tree mostly stays in cache and sharing nodes does less work; above it each
/// ray waits on memory at most nodes, and walking rays side by side hides the wait. On
/// incoherent rays side by side is slower on the bunny and the city (4-5 MB) and faster on
/// the terrain (54 MB); 16 MiB is about the geometric middle (docs/benchmarks.md).
const INTERLEAVE_ABOVE_BYTES: usize = 16 << 20;

/// Streams shorter than this share few node fetches, so [`Interleave::Auto`] interleaves them
/// from the smaller working set [`SHORT_INTERLEAVE_ABOVE_BYTES`] on. Streams this short are a
/// scene's octant streams, an octant kept apart in a small call, and the last chunks of a
/// batch split over threads (a call of 4,096 incoherent rays makes one stream,
/// [`stream::CHUNK`]). The measurements are in docs/benchmarks.md.
const SHORT_STREAM_RAYS: usize = 2048;
/// See [`SHORT_STREAM_RAYS`]. With the collapse's merged leaves (`collapse`) each one-ray step
/// of the side-by-side engine tests more triangles, and below this size (the bunny and the
/// city take under 3 MB with their meshes) sharing nodes is the faster engine even in calls of
/// 4,096 rays, about 15% on the bunny's closest hits; on the terrain (33 MB) side by side
/// runs 2.6 times as fast (docs/benchmarks.md).
const SHORT_INTERLEAVE_ABOVE_BYTES: usize = 8 << 20;

/// A stream at least this long shares nodes on any tree, whatever its rays' directions: enough
/// rays reach each node that one fetch of it serves many of them, where side by side each ray
/// waits on its own fetch. Halved for visitors that end rays ([`Visitor::ENDS_RAYS`]: any
/// hit), whose streams thin out as rays are occluded and gain more from sharing. On the
/// 1M-triangle terrain sightlines (any hit) share nodes faster from streams of about 32,768
/// rays on, incoherent closest-hit rays only beyond 65,536 (docs/benchmarks.md).
const DENSE_STREAM_RAYS: usize = 1 << 17;

/// The chunk of a tree beyond the caches (working set above [`INTERLEAVE_ABOVE_BYTES`]),
/// instead of [`stream::CHUNK`]: on such a tree every node fetch is a trip to memory, and a
/// longer chunk shares each one among more rays (its streams are long enough to share nodes,
/// [`DENSE_STREAM_RAYS`]), which pays for the records falling out of the caches: on the
/// terrain (`bvh8`) incoherent closest-hit rays take about a fifth less time in chunks of 1M
/// than side by side in chunks of 65,536 (docs/benchmarks.md). A chunk takes some 90 bytes a
/// ray: 90 MB for a thread's chunk of 1M rays.
const LARGE_TREE_CHUNK: usize = 1 << 20;

/// What [`interleaves`] looks at in a stream.
#[derive(Clone, Copy, Debug)]
struct StreamShape {
    rays: usize,
    /// All its rays share one direction octant.
    one_octant: bool,
    /// It is a dense octant of its chunk ([`RayStream::is_dense_octant`]).
    dense_octant: bool,
}

/// A stream of one octant at least this long shares nodes on trees beyond the caches even when
/// its octant is not dense (the `SeparateOctants` ordering, or closest-hit chunks that the
/// thread's mixing choice keeps apart): each node's children come nearest first for all its
/// rays, so a closest-hit stream drops far children early: the terrain's sightlines (closest
/// hit, octants apart) take about 30% less time sharing nodes (docs/benchmarks.md).
const SHARED_OCTANT_RAYS: usize = 4_096;

/// [`Interleave::Auto`]'s choice for a tree whose walks read `working_set` bytes and a
/// `stream`, for a visitor that ends rays (`ends_rays`) or not: true to walk the rays side by
/// side.
///
/// A dense octant's rays are coherent (a camera's) and take much the same paths: they share
/// nodes even on trees beyond the caches, however short the stream. On the 1M-triangle
/// terrain (`bvh8`) a camera's rays take about 40% less time sharing nodes than side by side,
/// in one call or in calls of 4,096 rays (docs/benchmarks.md).
fn interleaves(working_set: usize, stream: StreamShape, ends_rays: bool) -> bool {
    let rays = stream.rays;
    let shares_paths = stream.dense_octant || (stream.one_octant && rays >= SHARED_OCTANT_RAYS);
    let long = rays >= DENSE_STREAM_RAYS >> u32::from(ends_rays);
    !(shares_paths || long)
        && (working_set > INTERLEAVE_ABOVE_BYTES
            || (rays < SHORT_STREAM_RAYS && working_set > SHORT_INTERLEAVE_ABOVE_BYTES))
}

impl<N: NodeKind> WideBvh<N> {
    /// True if `stream` is to be walked by the side-by-side engine ([`BatchOptions::interleave`],
    /// [`Interleave::Auto`] deciding by [`interleaves`]), for a visitor that ends rays
    /// (`ends_rays`) or not.
    ///
    /// [`BatchOptions::interleave`]: crate::BatchOptions::interleave
    fn walks_side_by_side(&self, stream: &RayStream<'_>, ends_rays: bool) -> bool {
        match stream.options().interleave {
            Interleave::Always => true,
            Interleave::Never => false,
            Interleave::Auto => {
                let shape = StreamShape {
                    rays: stream.len(),
                    one_octant: stream.octant_mask() != 0,
                    dense_octant: stream.is_dense_octant(),
                };
                interleaves(self.working_set_bytes(), shape, ends_rays)
            }
        }
    }

    /// What a walk through the tree may read: nodes, leaf order or copy, and the mesh (which
    /// walks over leaf blocks never read).
    fn working_set_bytes(&self) -> usize {
        let mesh = match self.triangles {
            WideLeaves::Slots(_) => self.mesh().heap_bytes(),
            WideLeaves::Blocks(_) => 0,
        };
        self.heap_bytes() + mesh
    }
}

crate::query::compiled_queries!(WideTree, WideTree8, QuantizedWideTree, QuantizedWideTree8);

impl<N: NodeKind> crate::accel::Corners for WideBvh<N> {
    fn corners(&self, id: u32) -> [Vec3; 3] {
        self.mesh().triangle(id)
    }
}

impl<N: NodeKind> Footprint for WideBvh<N> {
    fn name(&self) -> &'static str {
        N::NAME
    }

    fn triangle_count(&self) -> usize {
        self.mesh().triangle_count()
    }

    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    fn heap_bytes(&self) -> usize {
        self.nodes.len() * size_of::<N>() + self.triangles.heap_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{AabbTree, LeafCopy};
    use crate::geom::Watertight;
    use crate::query::{BatchQueries, RayQueries};
    use crate::test_support::{bunny, random_rays};
    use crate::{BatchOptions, Hit, Interleave, Kernel, Ray};

    /// The automatic choice: small trees share nodes; trees beyond the caches walk short
    /// streams side by side, but share nodes among a dense octant's rays (a camera's coherent
    /// rays) and among long streams (half as long for any hit).
    #[test]
    fn the_automatic_engine_choice() {
        let (small, mid, large) = (4 << 20, 12 << 20, 64 << 20);
        let mixed = |rays| StreamShape {
            rays,
            one_octant: false,
            dense_octant: false,
        };
        let octant = |rays| StreamShape {
            one_octant: true,
            ..mixed(rays)
        };
        let dense = |rays| StreamShape {
            dense_octant: true,
            ..octant(rays)
        };
        for ends in [false, true] {
            assert!(!interleaves(small, mixed(100), ends));
            assert!(!interleaves(small, dense(100_000), ends));
            assert!(interleaves(mid, mixed(1_000), ends));
            assert!(!interleaves(mid, mixed(4_096), ends));
            assert!(interleaves(large, mixed(32_768), ends));
            assert!(!interleaves(large, dense(300), ends));
            assert!(interleaves(large, octant(SHARED_OCTANT_RAYS - 1), ends));
            assert!(!interleaves(large, octant(SHARED_OCTANT_RAYS), ends));
            assert!(!interleaves(large, mixed(DENSE_STREAM_RAYS), ends));
        }
        assert!(interleaves(large, mixed(65_536), false));
        assert!(!interleaves(large, mixed(65_536), true));
    }

    /// Trees beyond the caches take longer chunks; a permuted tree takes its inner tree's.
    #[test]
    fn large_trees_take_long_chunks() {
        let small = WideTree8::build(bunny(), &BuildOptions::default()).unwrap();
        assert!(small.working_set_bytes() < INTERLEAVE_ABOVE_BYTES);
        let incoherent = random_rays(&bunny(), 5_000, 3);
        assert_eq!(small.max_chunk(&incoherent), stream::CHUNK);
        let large = WideTree8::build(large_grid_mesh(), &BuildOptions::default()).unwrap();
        assert!(large.working_set_bytes() > INTERLEAVE_ABOVE_BYTES);
        assert_eq!(large.max_chunk(&incoherent), LARGE_TREE_CHUNK);
        // A camera's rays looking down, into four octants.
        let camera: Vec<Ray> = (0..5_000)
            .map(|i| {
                let (x, z) = ((i % 70) as f32 - 34.5, (i / 70) as f32 - 35.0);
                Ray::new(Vec3::new(0.0, 100.0, 0.0), Vec3::new(x, -50.0, z))
            })
            .collect();
        assert!(has_dense_octant(&camera) && !has_dense_octant(&incoherent));
        assert!(!has_dense_octant(&[]));
        // Invalid rays (a zero direction's signs say octant 0) are not counted.
        let mut padded = incoherent.clone();
        padded.extend(std::iter::repeat_n(Ray::new(Vec3::ZERO, Vec3::ZERO), 5_000));
        assert!(!has_dense_octant(&padded));
        assert_eq!(large.max_chunk(&camera), stream::CHUNK);
        let ids = (0..large.triangle_count() as u32).collect();
        let permuted = crate::permuted::Permuted::new(large, ids);
        assert_eq!(permuted.max_chunk(&incoherent), LARGE_TREE_CHUNK);
    }

    /// The quantized 8-wide tree copies nothing by default on small trees and takes leaf
    /// blocks on large ones (where [`crate::AccelKind::for_mesh`] picks it), under the full
    /// binary tree's 38.5 bytes a triangle. Told otherwise, it does as told, and it answers as
    /// the 8-wide tree does with every copy.
    #[test]
    fn quantized_trees_copy_by_size() {
        let node_bytes = |tree: &QuantizedWideTree8| tree.nodes.len() * 128;
        let small = QuantizedWideTree8::build(bunny(), &BuildOptions::default()).unwrap();
        assert!(!small.beyond_caches && !mesh_beyond_caches(small.mesh()));
        assert_eq!(
            crate::AccelKind::for_mesh(small.mesh()),
            crate::AccelKind::Bvh8
        );
        assert_eq!(
            small.heap_bytes(),
            node_bytes(&small) + small.triangle_count() * 4
        );
        let mesh = Arc::new(large_grid_mesh());
        assert!(mesh_beyond_caches(&mesh));
        assert_eq!(crate::AccelKind::for_mesh(&mesh), crate::AccelKind::Bvh8q);
        let blocks = QuantizedWideTree8::build(mesh.clone(), &BuildOptions::default()).unwrap();
        assert!(blocks.beyond_caches);
        assert!(matches!(blocks.triangles, WideLeaves::Blocks(_)));
        let per_triangle = blocks.heap_bytes() as f64 / blocks.triangle_count() as f64;
        assert!(per_triangle < 38.5, "{per_triangle} bytes a triangle");
        let told = |leaf_copy| BuildOptions {
            leaf_copy,
            ..BuildOptions::default()
        };
        let plain = QuantizedWideTree8::build(mesh.clone(), &told(LeafCopy::Nothing)).unwrap();
        assert_eq!(
            plain.heap_bytes(),
            node_bytes(&plain) + plain.triangle_count() * 4
        );
        let indices = QuantizedWideTree8::build(mesh.clone(), &told(LeafCopy::Indices)).unwrap();
        assert_eq!(
            indices.heap_bytes(),
            node_bytes(&indices) + indices.triangle_count() * 12
        );
        let full = WideTree8::build(mesh.clone(), &BuildOptions::default()).unwrap();
        let rays = random_rays(&mesh, 3_000, 9);
        let per_ray: Vec<Option<Hit>> = rays.iter().map(|r| full.cast_ray(r)).collect();
        assert!(per_ray.iter().filter(|hit| hit.is_some()).count() > 100);
        for tree in [&blocks, &plain, &indices] {
            let answers: Vec<Option<Hit>> = rays.iter().map(|r| tree.cast_ray(r)).collect();
            assert!(answers == per_ray);
            let mut batched = vec![None; rays.len()];
            tree.cast_ray_batch(&rays, &mut batched).unwrap();
            assert!(batched == per_ray);
        }
    }

    /// On a large tree whose blocks would pass the budget (a soup of 150k triangles sharing no
    /// corner: 12 bytes of corners a triangle more than a mesh whose triangles share them), a
    /// default build copies the indices instead; blocks asked for are blocks.
    #[test]
    fn default_blocks_keep_to_the_budget() {
        let vertices: Vec<Vec3> = (0..150_000u32)
            .flat_map(|k| {
                let at = Vec3::new((k % 400) as f32, (k / 400) as f32, (k % 7) as f32);
                [at, at + Vec3::X * 0.9, at + Vec3::Y * 0.9]
            })
            .collect();
        let triangles = (0..150_000u32)
            .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
            .collect();
        let mesh = Arc::new(Mesh::new(vertices, triangles).unwrap());
        assert!(smallest_working_set(&mesh) > LARGE_TREE_BYTES);
        let auto = QuantizedWideTree8::build(mesh.clone(), &BuildOptions::default()).unwrap();
        let indices = auto.nodes.len() * size_of::<QuantizedWideNode8>() + 12 * 150_000;
        assert_eq!(auto.heap_bytes(), indices);
        let options = BuildOptions::default().with_leaf_copy(LeafCopy::Blocks);
        let asked = QuantizedWideTree8::build(mesh.clone(), &options).unwrap();
        assert!(matches!(asked.triangles, WideLeaves::Blocks(_)));
        assert!(asked.heap_bytes() > 38 * 150_000);
    }

    /// Leaf blocks on the smallest trees (no triangle, a root that is one leaf, a few leaves)
    /// and on a mesh whose degenerate triangles get no slot: every answer is brute force's,
    /// per ray and batched.
    #[test]
    fn blocks_serve_tiny_trees() {
        let fan = |n: u32| {
            let mut vertices = vec![Vec3::ZERO];
            vertices.extend((0..=n).map(|k| Vec3::new((k as f32).cos(), (k as f32).sin(), 0.1)));
            let mut triangles: Vec<[u32; 3]> = (1..=n).map(|k| [0, k, k + 1]).collect();
            triangles.push([1, 1, 2]);
            Mesh::new(vertices, triangles).unwrap()
        };
        let options = BuildOptions::default().with_leaf_copy(LeafCopy::Blocks);
        for mesh in [
            Mesh::new(Vec::new(), Vec::new()).unwrap(),
            fan(1),
            fan(3),
            fan(40),
        ] {
            let mesh = Arc::new(mesh);
            let tree = QuantizedWideTree8::build(mesh.clone(), &options).unwrap();
            assert!(matches!(tree.triangles, WideLeaves::Blocks(_)));
            let rays: Vec<Ray> = (0..400)
                .map(|k| {
                    let at = Vec3::new(
                        (k % 20) as f32 * 0.1 - 1.0,
                        (k / 20) as f32 * 0.1 - 1.0,
                        1.0,
                    );
                    Ray::new(at, Vec3::new(0.01, -0.02, -1.0))
                })
                .collect();
            let mut batched = vec![None; rays.len()];
            tree.cast_ray_batch(&rays, &mut batched).unwrap();
            let hits = batched.iter().filter(|hit| hit.is_some()).count();
            assert_eq!(hits > 0, !mesh.is_empty());
            for (ray, batched) in rays.iter().zip(&batched) {
                let expected = crate::query::brute_force::cast_ray(&mesh, ray, Kernel::Watertight);
                assert_eq!(bits(tree.cast_ray(ray)), bits(expected), "{ray:?}");
                assert_eq!(bits(*batched), bits(expected), "{ray:?}");
            }
        }
    }

    /// A flat grid of some 600k triangles: a tree beyond [`INTERLEAVE_ABOVE_BYTES`].
    fn large_grid_mesh() -> Mesh {
        let side = 550u32;
        let vertices = (0..=side)
            .flat_map(|z| {
                (0..=side).map(move |x| Vec3::new(x as f32, ((x * z) % 7) as f32, z as f32))
            })
            .collect();
        let at = |x: u32, z: u32| z * (side + 1) + x;
        let triangles = (0..side)
            .flat_map(|z| {
                (0..side).flat_map(move |x| {
                    [
                        [at(x, z), at(x + 1, z), at(x, z + 1)],
                        [at(x + 1, z), at(x + 1, z + 1), at(x, z + 1)],
                    ]
                })
            })
            .collect();
        Mesh::new(vertices, triangles).unwrap()
    }

    fn bits(h: Option<Hit>) -> Option<(u32, u32, u32, u32)> {
        h.map(|h| (h.triangle, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()))
    }

    /// The run-time dispatched loop (AVX2 where available), the baseline one and the
    /// prefetching one (for trees beyond the caches) agree bit for bit.
    #[test]
    fn dispatched_and_portable_loops_agree() {
        dispatched_and_portable_loops_agree_for::<WideNode>();
        dispatched_and_portable_loops_agree_for::<WideNode8>();
    }

    fn dispatched_and_portable_loops_agree_for<N: NodeKind>() {
        #[cfg(target_arch = "x86_64")]
        crate::x86::Avx2::detect_or_note("the dispatched wide loop is the portable one");
        let mesh = Arc::new(bunny());
        let tree = WideBvh::<N>::build(mesh.clone(), &BuildOptions::default()).unwrap();
        let mut stack = Stack::default();
        for ray in random_rays(&mesh, 20_000, 8) {
            let prepared = PreparedRay::new(&ray).unwrap();
            // AVX2, baseline, AVX2 prefetching (a prefetch never changes a value).
            let copies = [(true, false), (false, false), (true, true)];
            let mut answers = [Hit::none_before(prepared.tmax); 3];
            for (copy, answer) in copies.into_iter().zip(&mut answers) {
                let mut best = [Hit::none_before(prepared.tmax)];
                let mut closest = crate::hit::Closest { best: &mut best };
                dispatch::trace::<N, Watertight, _>(
                    copy,
                    &tree,
                    &prepared,
                    0,
                    &mut stack,
                    &mut closest,
                );
                *answer = best[0];
            }
            for other in &answers[1..] {
                assert_eq!(bits(answers[0].found()), bits(other.found()), "{ray:?}");
            }
        }
    }

    /// Rays that miss the root box are answered while the batch is prepared
    /// ([`Accel::cull_bounds`]): closest, any and every hit equal the one-ray answers when most
    /// rays start outside the box, some aimed past it and some through it, with segments that
    /// stop short of it, in one call and in calls shorter than eight rays.
    #[test]
    fn culled_rays_answer_as_one_ray_does() {
        let mesh = Arc::new(bunny());
        let tree = WideTree::build(mesh.clone(), &BuildOptions::default()).unwrap();
        let bounds = mesh.bounds();
        let mut rng = crate::test_support::TestRng::new(21);
        let rays: Vec<Ray> = (0..20_000)
            .map(|i| {
                let origin = bounds.center() + bounds.extent() * rng.vec3(2.0);
                let target = bounds.center() + bounds.extent() * rng.vec3(0.7);
                let tmax = if i % 3 == 0 { 0.3 } else { f32::INFINITY };
                Ray::with_range(origin, target - origin, 0.0, tmax)
            })
            .collect();
        let culled = rays
            .iter()
            .filter(|r| !bounds.hit_by(&PreparedRay::new(r).unwrap(), r.tmax))
            .count();
        assert!(
            culled > 2_000 && culled < 18_000,
            "{culled} rays miss the box"
        );
        for calls_of in [rays.len(), 4_096, 7] {
            let batch = BatchOptions::default().with_min_batch(1);
            let mut closest = vec![None; rays.len()];
            let mut occluded = vec![false; rays.len()];
            for (i, chunk) in rays.chunks(calls_of).enumerate() {
                let at = i * calls_of..i * calls_of + chunk.len();
                tree.cast_ray_batch_with(chunk, &mut closest[at.clone()], &batch)
                    .unwrap();
                tree.occluded_batch_with(chunk, &mut occluded[at], &batch)
                    .unwrap();
            }
            let every = std::sync::Mutex::new(vec![Vec::new(); rays.len()]);
            tree.for_each_hit_batch_with(&rays, &batch, &|i, hit| {
                every.lock().unwrap()[i].push(hit);
            });
            let mut every = every.into_inner().unwrap();
            for (i, ray) in rays.iter().enumerate() {
                assert_eq!(bits(closest[i]), bits(tree.cast_ray(ray)), "{ray:?}");
                assert_eq!(occluded[i], tree.occluded(ray), "{ray:?}");
                Hit::sort(&mut every[i]);
                assert_eq!(every[i], tree.all_hits(ray), "{ray:?}");
            }
        }
    }

    /// Meshes whose slots or nodes the words cannot address are a typed error, not wrong answers.
    #[test]
    fn too_large_is_an_error() {
        assert!(check_size(1000, 2000, "test").is_ok());
        let too_many_slots = check_size(leaf_word::MAX_SLOTS + 1, 10, "test");
        assert!(matches!(too_many_slots, Err(BuildError::TooLarge { .. })));
        let too_many_nodes = check_size(10, leaf_word::LEAF_BIT as usize + 1, "test");
        assert!(matches!(too_many_nodes, Err(BuildError::TooLarge { .. })));
    }

    /// Same answers as the binary tree it was collapsed from, per ray and batched (both stream
    /// engines), for every leaf size, with leaves merged by the collapse or not, with and
    /// without the leaf-ordered corner copy (the brute-force comparisons live in the
    /// integration tests' zoo).
    #[test]
    fn answers_equal_the_binary_tree() {
        answers_equal_the_binary_tree_for::<WideNode>();
    }

    /// The same for the 8-wide tree (its batches: side by side, or nodes shared).
    #[test]
    fn eight_wide_answers_equal_the_binary_tree() {
        answers_equal_the_binary_tree_for::<WideNode8>();
    }

    /// The same for the quantized 8-wide tree.
    #[test]
    fn quantized_eight_wide_answers_equal_the_binary_tree() {
        answers_equal_the_binary_tree_for::<QuantizedWideNode8>();
    }

    /// The same for the quantized 4-wide tree.
    #[test]
    fn quantized_answers_equal_the_binary_tree() {
        answers_equal_the_binary_tree_for::<QuantizedWideNode>();
    }

    /// With every copy and leaf size, the tree's leaf words together read each triangle with
    /// a slot exactly once, with the mesh's corners: no leaf word is left addressing slots
    /// when the leaves are blocks, and none addresses another leaf's triangles.
    #[test]
    fn leaf_words_read_every_triangle_once() {
        let mesh = Arc::new(bunny());
        let slotted: Vec<u32> = (0..mesh.triangle_count() as u32)
            .filter(|&id| !mesh.is_degenerate(id))
            .collect();
        for copy in LeafCopy::ALL {
            for (leaf, wide_leaf) in [(1, 1), (4, 16), (16, 16)] {
                let options = BuildOptions::default()
                    .with_leaf_size(leaf)
                    .with_wide_leaf_size(wide_leaf)
                    .with_leaf_copy(copy);
                let tree = WideTree8::build(mesh.clone(), &options).unwrap();
                let (mut nodes, mut root) = (tree.nodes.clone(), tree.root);
                let words: Vec<u32> = leaf_words_mut((&mut nodes, &mut root))
                    .map(|word| *word)
                    .collect();
                let mut read = Vec::new();
                for word in words {
                    for k in 0..leaf_word::unpack(word).1 {
                        let (id, corners) = tree.triangle(word, k);
                        assert_eq!(corners, mesh.triangle(id), "{copy:?}");
                        read.push(id);
                    }
                }
                read.sort_unstable();
                assert!(
                    read == slotted,
                    "{copy:?}, leaf {leaf}, wide leaf {wide_leaf}"
                );
            }
        }
    }

    fn answers_equal_the_binary_tree_for<N: NodeKind>()
    where
        WideBvh<N>: RayQueries + BatchQueries,
    {
        let mesh = Arc::new(bunny());
        let rays = random_rays(&mesh, 20_000, 5);
        let cases = [
            (1, 1, LeafCopy::Nothing),
            (1, 16, LeafCopy::Auto),
            (4, 1, LeafCopy::Indices),
            (4, 8, LeafCopy::Corners),
            (16, 16, LeafCopy::Auto),
            (1, 16, LeafCopy::Blocks),
            (4, 8, LeafCopy::Blocks),
            (16, 16, LeafCopy::Blocks),
        ];
        for (leaf, wide_leaf, copy) in cases {
            let options = BuildOptions::default()
                .with_leaf_size(leaf)
                .with_wide_leaf_size(wide_leaf)
                .with_leaf_copy(copy);
            let wide = WideBvh::<N>::build(mesh.clone(), &options).unwrap();
            let binary: AabbTree = AabbTree::build(mesh.clone(), &options).unwrap();
            for interleave in [Interleave::Always, Interleave::Never] {
                let mut batched = vec![None; rays.len()];
                let batch = BatchOptions::default()
                    .with_parallel(false)
                    .with_interleave(interleave);
                wide.cast_ray_batch_with(&rays, &mut batched, &batch)
                    .unwrap();
                let mut occluded = vec![false; rays.len()];
                wide.occluded_batch_with(&rays, &mut occluded, &batch)
                    .unwrap();
                let case = format!("leaf {leaf}, wide leaf {wide_leaf}, {copy:?}, {interleave:?}");
                for (i, ray) in rays.iter().enumerate() {
                    let expected = binary.cast_ray_with(ray, Kernel::Watertight);
                    assert_eq!(bits(wide.cast_ray(ray)), bits(expected), "{case} {ray:?}");
                    assert_eq!(bits(batched[i]), bits(expected), "{case} {ray:?}");
                    assert_eq!(occluded[i], binary.occluded(ray), "{case} {ray:?}");
                    assert_eq!(wide.occluded(ray), occluded[i], "{case} {ray:?}");
                }
            }
        }
    }
}
