//! The trees, and the one traversal interface ([`Bvh`]) they all expose.
//!
//! Every query engine (single-ray here in [`crate::query`], batched later) is written once
//! against [`Bvh`]: a node gives its bounds (stored, dequantized or recomputed, the engine does
//! not care), the triangles it owns and its two children with their precomputed visit order.
//! A node may own triangles *and* have children (the zero-byte tree's nodes do), so the engines
//! test a node's triangles, then descend.

pub mod aabb_tree;
pub mod build;
pub mod full_nodes;
pub mod ordering;
pub mod quantized_nodes;

use glam::Vec3;

use crate::geom::Aabb;
use crate::mesh::Mesh;

pub use aabb_tree::{AabbTree, QuantizedAabbTree};
pub use build::{BuildError, BuildOptions};
pub use ordering::ChildOrdering;

/// One node as traversal sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeView {
    /// A box holding everything below the node (conservative: may be larger than tight).
    pub bounds: Aabb,
    /// The node's triangles: slots `first..first + count` (see [`Bvh::triangle`]).
    pub first: u32,
    pub count: u32,
    /// Children `first_child` and `first_child + 1`; 0 when the node has none (the root is
    /// node 0, so it is never a child).
    pub first_child: u32,
    /// Child ordering byte: bit `o` set means rays of octant `o` visit the second child first.
    pub order: u8,
}

impl NodeView {
    /// A leaf owning triangle slots `first..first + count`.
    #[inline(always)]
    pub fn leaf(bounds: Aabb, first: u32, count: u32) -> Self {
        Self {
            bounds,
            first,
            count,
            first_child: 0,
            order: 0,
        }
    }

    /// An internal node with children `first_child` and `first_child + 1`.
    #[inline(always)]
    pub fn internal(bounds: Aabb, first_child: u32, order: u8) -> Self {
        Self {
            bounds,
            first: 0,
            count: 0,
            first_child,
            order,
        }
    }
}

/// The traversal interface shared by all trees. Node 0 is the root; a tree with no nodes
/// (empty mesh, or only degenerate triangles) is hit by nothing.
pub trait Bvh: Sync {
    /// Whether the single-ray loop should run its AVX2-compiled copy where the CPU has AVX2
    /// (measured per node format: it speeds up full nodes and slows down quantized ones).
    const AVX2_TRAVERSAL: bool = true;

    /// The mesh the tree was built over; triangle ids refer to it.
    fn mesh(&self) -> &Mesh;

    fn node_count(&self) -> usize;

    /// Node `index` (< `node_count()`).
    fn node(&self, index: u32) -> NodeView;

    /// Triangle slot `slot`: its id in the mesh and its corners.
    fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]);

    /// Longest root-to-leaf path, in nodes (at most [`build::MAX_DEPTH`]).
    fn depth(&self) -> usize;

    /// Bytes the structure adds to the mesh (nodes and triangle order).
    fn heap_bytes(&self) -> usize;

    /// Short name for tables.
    fn name(&self) -> &'static str;

    /// Extra bytes per triangle of the mesh.
    fn bytes_per_triangle(&self) -> f64 {
        self.heap_bytes() as f64 / self.mesh().triangle_count().max(1) as f64
    }
}
