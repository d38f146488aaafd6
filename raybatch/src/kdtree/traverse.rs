//! The kd-tree's one-ray walk: front to back, nearer child first, with early exit.
//!
//! A node's box is its parent's cut by the split plane (exact: one coordinate replaced by the
//! split position, no arithmetic), so the walk carries each node's box and tests both
//! children with the conservative slab test of [`crate::geom::aabb`], like the BVHs. The
//! child entered first is the one with the smaller entry distance; the other is pushed with
//! its entry and box, and popped only if its entry is still `<=` the range end (a box entered
//! exactly at the best `t` may hold an equal-`t` triangle with a lower id).
//!
//! **Why no hit is missed.** A reported hit lies at `t >= t*`, where `t*` is the entry
//! distance of the triangle's own box, whose slab test passes (`agree_with_bounds` in
//! [`crate::geom::triangle`]). Along the split axis the rounded intervals of the two children,
//! `[e(lo), S e(s)]` and `[e(s), S e(hi)]`, overlap (for `t >= 0`) and so cover the node's;
//! by the side rule of `super::build` a triangle kept on one side only lies strictly on that
//! side, so its box's interval, which holds `t*`, lies within that child's. By induction from
//! the root (whose box holds every triangle's), some leaf holding the triangle passes the slab
//! test at `t*`, and so does every node above it: the walk reaches it. A ray in a split plane
//! (a zero direction component, `0 * inf = NaN` in the slab test) grazes both children and
//! enters both; a triangle in the plane is in both.

use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::grid::Mailbox;
use crate::grid::uniform::test_cell;
use crate::hit::{RAY_DONE, Visitor};

use super::KdTree;
use super::node::Decoded;

/// Per-thread memory of the kd-tree walk: the stack of pending far children and the mailbox
/// (a triangle in several leaves is tested once per ray).
#[derive(Debug, Default)]
pub struct KdScratch {
    stack: Vec<(u32, f32, Aabb)>,
    mailbox: Mailbox,
}

/// Traces `ray` (number `id`) through `tree`; returns the final range end.
pub(crate) fn trace<K: TriangleTest, V: Visitor>(
    tree: &KdTree,
    ray: &PreparedRay,
    id: u32,
    scratch: &mut KdScratch,
    visitor: &mut V,
) -> f32 {
    let mut tmax = ray.tmax;
    if tree.refs.is_empty() || !tree.bounds.hit_by(ray, tmax) {
        return tmax;
    }
    let KdScratch { stack, mailbox } = scratch;
    mailbox.next_ray();
    stack.clear();
    let (mut node, mut node_box) = (0u32, tree.bounds);
    loop {
        match tree.nodes[node as usize].decode() {
            Decoded::Split {
                axis,
                position,
                above,
            } => {
                let (mut below_box, mut above_box) = (node_box, node_box);
                below_box.max[axis] = position;
                above_box.min[axis] = position;
                let below = (node + 1, below_box.entry(ray, tmax), below_box);
                let above = (above, above_box.entry(ray, tmax), above_box);
                let (near, far) = if above.1 < below.1 {
                    (above, below)
                } else {
                    (below, above)
                };
                if near.1 < f32::INFINITY {
                    if far.1 < f32::INFINITY {
                        stack.push(far);
                    }
                    (node, node_box) = (near.0, near.2);
                    continue;
                }
            }
            Decoded::Leaf { first, count } => {
                let refs = &tree.refs[first as usize..(first + count) as usize];
                if test_cell::<K, V>(&tree.mesh, refs, ray, id, mailbox, &mut tmax, visitor) {
                    return RAY_DONE;
                }
            }
        }
        // The next pending child still in front of the best hit.
        loop {
            let Some((pending, entry, pending_box)) = stack.pop() else {
                return tmax;
            };
            if entry <= tmax {
                (node, node_box) = (pending, pending_box);
                break;
            }
        }
    }
}
