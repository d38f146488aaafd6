//! The binary-BVH family: the [`Bvh`] node interface, the SAH builder, precomputed node
//! sorting, and the AABB tree in its node formats.
//!
//! A BVH only says what its nodes hold; the traversals are written once against [`Bvh`] in
//! [`crate::traverse`] (one ray at a time, and a stream of rays going down once), which makes
//! every `Bvh` an [`crate::accel::Accel`]. A node's box is read apart from its contents, both
//! children's at once, given the parent's box ([`Bvh::child_bounds`] and [`Bvh::node`]), so
//! that a traversal computes each box once: a tree whose boxes are expensive (dequantized, or
//! recomputed from triangles like the zero-byte tree's, whose children may inherit faces of
//! their parent's box) pays for each box once per visit. Box reads take the structure's
//! per-thread cache ([`Bvh::Cache`], kept in the thread's [`crate::workspace::Workspace`]).
//!
//! A node may own triangles *and* have children (the zero-byte tree's nodes do): traversal
//! tests a node's triangles, then descends.
//!
//! - [`build`]: binned SAH build shared by every node format.
//! - [`ordering`]: the child-order byte per node (precomputed node sorting).
//! - [`nodes`]: the node formats (full 32-byte, quantized 16-byte).
//! - `leaves`: the leaf triangles in slot order, shared by every tree the builder makes.
//! - [`tree`]: [`AabbTree`], a mesh plus a node array in one of the formats.
//! - [`quantized_vertices`]: [`QuantizedVertexTree`], the same over a quantized-vertex mesh.

pub mod build;
mod cook;
pub(crate) mod leaves;
pub mod nodes;
pub mod ordering;
pub mod quantized_vertices;
pub mod tree;

use glam::Vec3;

use crate::geom::Aabb;

pub use build::{BuildError, BuildOptions, MAX_LEAF_SIZE};
pub use leaves::LeafCopy;
pub use ordering::ChildOrdering;
pub use quantized_vertices::QuantizedVertexTree;
pub use tree::{AabbTree, QuantizedAabbTree};

/// A node's contents, without its box: its triangles and its children.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Node {
    /// First of the node's triangle slots (see [`Bvh::triangle`]).
    pub first: u32,
    /// Number of triangle slots, `first..first + count` (0 for a node with none).
    pub count: u32,
    /// The two children, nearer-first order decided by `order`; `[0, 0]` when the node has
    /// none (the root is node 0, so it is never a child).
    pub children: [u32; 2],
    /// Child ordering byte: bit `o` set means rays of octant `o` visit the second child first.
    pub order: u8,
    /// Faces of this node's box each child inherits (the zero-byte tree, see
    /// [`crate::zbt`]); `[0, 0]` for trees that store their boxes.
    pub inherited: [u8; 2],
}

impl Node {
    /// A leaf owning triangle slots `first..first + count`.
    #[inline(always)]
    pub fn leaf(first: u32, count: u32) -> Self {
        Self {
            first,
            count,
            children: [0, 0],
            order: 0,
            inherited: [0, 0],
        }
    }

    /// An internal node with children `first_child` and `first_child + 1` (the pair layout of
    /// the AABB trees).
    #[inline(always)]
    pub fn internal(first_child: u32, order: u8) -> Self {
        Self {
            first: 0,
            count: 0,
            children: [first_child, first_child + 1],
            order,
            inherited: [0, 0],
        }
    }

    /// True if the node has children.
    #[inline(always)]
    pub fn has_children(&self) -> bool {
        self.children[0] != 0
    }
}

/// The node interface of a binary BVH. Node 0 is the root; a tree with no nodes (an empty mesh,
/// or only degenerate triangles) is hit by nothing.
///
/// Contract the traversals rely on: every node's box contains its triangles' bounding boxes and
/// its children's boxes (boxes may be larger than tight, never smaller), and is the same
/// whenever it is read; child indices are
/// below [`Bvh::len`] and every path from the root is at most [`Bvh::depth`] nodes long.
/// Internal nodes have two children; a node with one child pads the pair with a node whose box
/// is [`Aabb::EMPTY`] (no ray enters it, so its contents are never read).
pub trait Bvh: Sync {
    /// Per-thread state box reads need (the zero-byte tree's box cache); `()` for stored boxes.
    type Cache: Default + Send + 'static;

    /// What the one-ray loop keeps of a pending node's box (on its stack) to read the node's
    /// children's boxes later: `()` for trees whose boxes stand alone, so they pay nothing;
    /// the box itself for the zero-byte trees, whose children inherit faces of it.
    type NodeBox: Copy + Default + std::fmt::Debug + Send + 'static;

    /// What to keep of a node's box `bounds` (see [`Bvh::NodeBox`]).
    fn keep(bounds: &Aabb) -> Self::NodeBox;

    /// Whether the single-ray loop should run its AVX2-compiled copy where the CPU has AVX2
    /// (measured per node format: it speeds up full nodes and slows down quantized ones).
    const AVX2_TRAVERSAL: bool = true;

    /// Whether the stream engine finishes few-ray subtrees with the packet walk
    /// (`traverse::packet`, [`crate::batch::BatchOptions::packet_from`]) rather than one ray
    /// at a time: worth it where a node visit is dear (the zero-byte tree recomputes boxes and
    /// tests triangles at every node); the AABB tree's one-ray loop was faster on the clock.
    const PACKET_WALK: bool = false;

    /// Number of nodes (0 for an empty tree). (`Footprint::node_count` says the same for
    /// tables; this one is what traversal needs.)
    fn len(&self) -> usize;

    /// True if the tree has no node: every ray misses.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The box of the root (node 0; the tree is not empty).
    fn root_bounds(&self, cache: &mut Self::Cache) -> Aabb;

    /// [`Bvh::root_bounds`] without a cache, for the batch preparation's cull test
    /// ([`crate::accel::Accel::cull_bounds`]): `None` (no culling) unless the tree overrides it.
    fn root_bounds_uncached(&self) -> Option<Aabb> {
        None
    }

    /// The boxes of the two children of `node`, of whose own box `node_box` was kept (a child's
    /// box may depend on its parent's: the zero-byte tree's children inherit faces of it).
    fn child_bounds(
        &self,
        node: &Node,
        node_box: &Self::NodeBox,
        cache: &mut Self::Cache,
    ) -> [Aabb; 2];

    /// The contents of node `index` (< `len()`).
    fn node(&self, index: u32) -> Node;

    /// Triangle slot `slot`: its id in the mesh and its corners.
    fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]);

    /// Longest root-to-leaf path, in nodes: traversal stacks are sized from it.
    fn depth(&self) -> usize;
}

/// Per-thread scratch of the BVH traversals: the stacks of both engines and the tree's cache.
/// Sized on first use and reused, so no query allocates or clears a stack.
#[derive(Debug, Default)]
pub struct BvhScratch<C, N = ()> {
    /// Single-ray stack: pending node, its entry distance and what is kept of its box. For
    /// [`crate::accel::Accel::trace`] (a scene's rays, the stream engine's few-ray subtrees)
    /// and the zero-byte trees' rays traced alone; the other trees' rays traced alone bring
    /// their own.
    pub(crate) stack: Vec<(u32, f32, N)>,
    /// Batched stack: pending node, how many rays of the stream reach its parent, its box.
    pub(crate) stream_stack: Vec<(u32, u32, Aabb)>,
    /// The packet walk's stack (`traverse::packet`): pending node, the lanes that touch its
    /// box, their entry distances, what is kept of its box.
    #[cfg(target_arch = "x86_64")]
    pub(crate) packet_stack: Vec<(u32, u32, [f32; 8], N)>,
    /// The tree's box cache.
    pub(crate) cache: C,
}
