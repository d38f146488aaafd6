//! [`Counted`]: any [`Bvh`] that counts its node visits, to compare trees by the work their
//! traversals do rather than by time (quantized nodes' boxes are larger than full nodes', so
//! the same rays visit a few more nodes: how many is this count).
//!
//! A visit is a call of [`Bvh::node`], which both engines make once per node they enter. The
//! count is one relaxed atomic add per visit: cheap, but not free, so time the bare tree and
//! count on this one.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;

use super::{Bvh, Node};
use crate::geom::Aabb;

/// A tree and its visit count (see the module docs). Queries work on it as on `B`.
#[derive(Debug, Default)]
pub struct Counted<B> {
    tree: B,
    visits: AtomicU64,
}

impl<B: Bvh> Counted<B> {
    /// Wraps `tree`, with no visit counted.
    pub fn new(tree: B) -> Self {
        Self {
            tree,
            visits: AtomicU64::new(0),
        }
    }

    /// Nodes visited since the wrapping (or the last [`Counted::take`]), over all threads.
    pub fn visits(&self) -> u64 {
        self.visits.load(Ordering::Relaxed)
    }

    /// Returns the count and resets it.
    pub fn take(&self) -> u64 {
        self.visits.swap(0, Ordering::Relaxed)
    }

    /// The wrapped tree.
    pub fn inner(&self) -> &B {
        &self.tree
    }
}

impl<B: Bvh> Bvh for Counted<B> {
    type Cache = B::Cache;
    type NodeBox = B::NodeBox;
    const AVX2_TRAVERSAL: bool = B::AVX2_TRAVERSAL;
    const PACKET_WALK: bool = B::PACKET_WALK;

    fn keep(bounds: &Aabb) -> Self::NodeBox {
        B::keep(bounds)
    }

    fn len(&self) -> usize {
        self.tree.len()
    }

    fn root_bounds(&self, cache: &mut Self::Cache) -> Aabb {
        self.tree.root_bounds(cache)
    }

    fn root_bounds_uncached(&self) -> Option<Aabb> {
        self.tree.root_bounds_uncached()
    }

    #[inline(always)]
    fn child_bounds(&self, node: &Node, node_box: &B::NodeBox, cache: &mut B::Cache) -> [Aabb; 2] {
        self.tree.child_bounds(node, node_box, cache)
    }

    #[inline(always)]
    fn node(&self, index: u32) -> Node {
        self.visits.fetch_add(1, Ordering::Relaxed);
        self.tree.node(index)
    }

    #[inline(always)]
    fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]) {
        self.tree.triangle(slot)
    }

    fn depth(&self) -> usize {
        self.tree.depth()
    }
}

crate::query::compiled_queries!(Counted<super::AabbTree>, Counted<super::QuantizedAabbTree>);
