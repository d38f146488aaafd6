//! What a structure must offer to answer shape queries: a walk that enters every node whose
//! box the query may touch and offers it the triangles of the leaves it reaches.

use glam::Vec3;

use crate::bvh::build::MAX_DEPTH;
use crate::bvh::nodes::NodeFormat;
use crate::bvh::{AabbTree, Bvh};
use crate::geom::Aabb;
use crate::grid::{SpatialHash, UniformGrid};
use crate::kdtree::KdTree;
use crate::permuted::Permuted;
use crate::wide::{NodeKind, WideBvh};
use crate::zbt::{HybridTree, ZeroByteTree};

/// One shape query during a walk.
pub(crate) trait BoxQuery {
    /// Whether the walk takes the children it enters nearest first (by [`BoxQuery::entry`]):
    /// a sweep's best contact then comes early and prunes the rest.
    const NEAREST_FIRST: bool = false;

    /// When the query may first touch anything inside `bounds` (0 for an overlap), or `None`:
    /// a promise that nothing in the box can answer it. An empty box must give `None`.
    fn entry(&self, bounds: &Aabb) -> Option<f64>;

    /// Whether a box entered at `entry` may still answer (a sweep's best contact may have
    /// come before it since).
    fn still_reaches(&self, entry: f64) -> bool {
        let _ = entry;
        true
    }

    /// Tests triangle `id` of corners `corners`; true ends the walk.
    fn triangle(&mut self, id: u32, corners: &[Vec3; 3]) -> bool;
}

/// A node's children the query enters, in the order the walk pushes them: in slot order, or
/// farthest first (so the nearest is popped first) for [`BoxQuery::NEAREST_FIRST`].
pub(crate) fn push_order<T: Copy, Q: BoxQuery>(entered: &mut [(T, f64)]) {
    if Q::NEAREST_FIRST {
        entered.sort_unstable_by(|x, y| y.1.total_cmp(&x.1));
    }
}

/// A structure's walk for shape queries, if it has one.
pub(crate) trait ShapeWalk {
    /// Whether the structure walks ([`crate::AccelKind::answers_shapes`]).
    const WALKS: bool = false;

    /// Offers `query` every triangle of every leaf whose box (and whose ancestors' boxes) it
    /// enters, each once, until it asks to stop; nothing if the structure does not walk.
    fn walk_shape<Q: BoxQuery>(&self, query: &mut Q) {
        let _ = query;
    }
}

impl<N: NodeKind> ShapeWalk for WideBvh<N> {
    const WALKS: bool = true;

    fn walk_shape<Q: BoxQuery>(&self, query: &mut Q) {
        self.walk_boxes(query);
    }
}

impl<N: NodeFormat> ShapeWalk for AabbTree<N> {
    const WALKS: bool = true;

    fn walk_shape<Q: BoxQuery>(&self, query: &mut Q) {
        walk_binary(self, query);
    }
}

// Their boxes are recomputed (the zero-byte trees) or they are no trees: not yet walked.
impl ShapeWalk for Permuted<ZeroByteTree> {}
impl ShapeWalk for Permuted<HybridTree> {}
impl ShapeWalk for UniformGrid {}
impl ShapeWalk for KdTree {}
impl ShapeWalk for SpatialHash {}

/// The walk over a binary tree: a node's triangles, then its children the query enters.
fn walk_binary<T: Bvh, Q: BoxQuery>(tree: &T, query: &mut Q) {
    if tree.is_empty() {
        return;
    }
    let mut cache = T::Cache::default();
    let root = tree.root_bounds(&mut cache);
    let Some(entry) = query.entry(&root) else {
        return;
    };
    // A pop pushes at most two children, and a path is at most `MAX_DEPTH` nodes long.
    let mut stack = [(0u32, T::keep(&root), entry); MAX_DEPTH + 2];
    let mut len = 1;
    while len > 0 {
        len -= 1;
        let (index, kept, entry) = stack[len];
        if !query.still_reaches(entry) {
            continue;
        }
        let node = tree.node(index);
        for slot in node.first..node.first + node.count {
            let (id, corners) = tree.triangle(slot);
            if query.triangle(id, &corners) {
                return;
            }
        }
        if node.has_children() {
            let boxes = tree.child_bounds(&node, &kept, &mut cache);
            let mut entered = [((0u32, T::keep(&root)), 0.0); 2];
            let mut count = 0;
            for (&child, bounds) in node.children.iter().zip(boxes) {
                if let Some(entry) = query.entry(&bounds) {
                    entered[count] = ((child, T::keep(&bounds)), entry);
                    count += 1;
                }
            }
            push_order::<_, Q>(&mut entered[..count]);
            for &((child, kept), entry) in &entered[..count] {
                stack[len] = (child, kept, entry);
                len += 1;
            }
        }
    }
}
