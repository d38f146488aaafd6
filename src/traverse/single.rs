//! The single-ray loop over a [`Bvh`]: the reference every other engine must match bit for bit.
//!
//! Depth first, with an explicit stack ([`PendingStack`]): the thread's scratch's (sized from
//! [`Bvh::depth`] on first use, never zeroed per ray), or one on the call stack for a ray
//! traced alone. At an internal node both children's boxes are read once
//! ([`Bvh::child_bounds`]) and tested; if both are touched, the one the precomputed ordering
//! byte names as nearer is visited now and the other is pushed with its entry distance and its
//! box, so that a later pop can drop it without reading it again when the best hit has moved in
//! front of it, and a pop that keeps it reads only its contents (its box is on the stack: its
//! children's boxes may depend on it). Entry distances are compared with `<=`: a box entered
//! exactly at the best `t` may still hold an equal-`t` triangle with a lower id (the tie rule
//! of [`crate::hit`]).

use glam::Vec3;

use super::stack::PendingStack;
use crate::bvh::ordering::second_child_first;
use crate::bvh::{Bvh, Node};
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::{Hit, RAY_DONE, Visitor};

/// A pending node on the loop's stack: its index, the distance at which the ray enters its box,
/// and what is kept of the box ([`Bvh::NodeBox`]).
pub(crate) type Pending<B> = (u32, f32, <B as Bvh>::NodeBox);

/// The loop's working memory: its stack and the tree's box cache.
pub(crate) type Memory<'a, B, S> = (&'a mut S, &'a mut <B as Bvh>::Cache);

/// Traces `ray` (number `id`) through the whole tree; returns the final range end.
#[inline(always)]
pub(crate) fn trace<B, K, V, S>(
    tree: &B,
    ray: &PreparedRay,
    id: u32,
    (stack, cache): Memory<'_, B, S>,
    visitor: &mut V,
) -> f32
where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: Visitor,
    S: PendingStack<Pending<B>>,
{
    let mut tmax = ray.tmax;
    if tree.is_empty() {
        return tmax;
    }
    let root_box = tree.root_bounds(cache);
    if !root_box.hit_by(ray, tmax) {
        return tmax;
    }
    let start = (0, B::keep(&root_box));
    trace_below::<B, K, V, S>(tree, ray, id, start, &mut tmax, (stack, cache), visitor);
    tmax
}

/// The traversal loop, starting at node `start` with its box, which the ray is known to touch,
/// with the ray's current range end `tmax`. The batched engine calls it to finish a subtree for
/// the few rays that reach it.
#[inline(always)]
pub(crate) fn trace_below<B, K, V, S>(
    tree: &B,
    ray: &PreparedRay,
    id: u32,
    start: (u32, B::NodeBox),
    tmax: &mut f32,
    (stack, cache): Memory<'_, B, S>,
    visitor: &mut V,
) where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: Visitor,
    S: PendingStack<Pending<B>>,
{
    stack.start(tree.depth());
    let (mut index, mut node_box) = start;
    loop {
        visitor.enter_node(id);
        let node = tree.node(index);
        if test_node_triangles::<B, K, V>(tree, &node, ray, id, tmax, visitor) {
            return;
        }
        if node.has_children() {
            let [a, b] = node.children;
            let [first, second] = tree.child_bounds(&node, &node_box, cache);
            let ((near, near_box), (far, far_box)) =
                if second_child_first(node.order, ray.octant_mask) {
                    ((b, second), (a, first))
                } else {
                    ((a, first), (b, second))
                };
            let near_entry = near_box.entry(ray, *tmax);
            let far_entry = far_box.entry(ray, *tmax);
            match (near_entry < f32::INFINITY, far_entry < f32::INFINITY) {
                (true, true) => {
                    stack.push((far, far_entry, B::keep(&far_box)));
                    (index, node_box) = (near, B::keep(&near_box));
                    continue;
                }
                (true, false) => {
                    (index, node_box) = (near, B::keep(&near_box));
                    continue;
                }
                (false, true) => {
                    (index, node_box) = (far, B::keep(&far_box));
                    continue;
                }
                (false, false) => {}
            }
        }
        // Pop the next pending node that is still in front of the best hit.
        loop {
            let Some((pending, entry, pending_box)) = stack.pop() else {
                return;
            };
            if entry <= *tmax {
                (index, node_box) = (pending, pending_box);
                break;
            }
        }
    }
}

/// Tests a node's triangles; true if the visitor ended the ray.
#[inline(always)]
fn test_node_triangles<B, K, V>(
    tree: &B,
    node: &Node,
    ray: &PreparedRay,
    id: u32,
    tmax: &mut f32,
    visitor: &mut V,
) -> bool
where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: Visitor,
{
    // A plain loop, as in the wide trees' loop (`wide::single`): an iterator of fetched
    // triangles may leave its `next` out of line.
    for slot in node.first..node.first + node.count {
        let (triangle, corners) = tree.triangle(slot);
        if test_triangle::<K, V>(ray, id, (triangle, &corners), tmax, visitor) {
            return true;
        }
    }
    false
}

/// Tests one ray against `(id, corners)` triangles, reporting hits to `visitor`; true if the
/// visitor ended the ray. The batched leaves pass their fetched batches; the one-ray loops call
/// [`test_triangle`] slot by slot instead (an iterator that fetches was left out of line).
#[inline(always)]
pub(crate) fn test_triangles<K, V>(
    ray: &PreparedRay,
    id: u32,
    triangles: impl IntoIterator<Item = (u32, [Vec3; 3])>,
    tmax: &mut f32,
    visitor: &mut V,
) -> bool
where
    K: TriangleTest,
    V: Visitor,
{
    for (triangle, corners) in triangles {
        if test_triangle::<K, V>(ray, id, (triangle, &corners), tmax, visitor) {
            return true;
        }
    }
    false
}

/// [`test_triangles`] for one triangle `(id, corners)`.
#[inline(always)]
pub(crate) fn test_triangle<K, V>(
    ray: &PreparedRay,
    id: u32,
    (triangle, corners): (u32, &[Vec3; 3]),
    tmax: &mut f32,
    visitor: &mut V,
) -> bool
where
    K: TriangleTest,
    V: Visitor,
{
    let Some(h) = K::intersect(ray, corners, *tmax) else {
        return false;
    };
    let hit = Hit {
        t: h.t,
        triangle,
        u: h.u,
        v: h.v,
    };
    visitor.visit(id, hit, tmax);
    *tmax == RAY_DONE
}
