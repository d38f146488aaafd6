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

use crate::geom::aabb::EXIT_SCALE;
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::grid::Mailbox;
use crate::grid::uniform::test_cell;
use crate::hit::{RAY_DONE, Visitor};
use crate::traverse::origin_order::{OriginOrder, WithOriginOrder};

use super::KdTree;
use super::node::Decoded;

/// Per-thread memory of the kd-tree walk: the stack of pending far children, the mailbox (a
/// triangle in several leaves is tested once per ray) and the order a batch's rays are walked
/// in (Morton order of their origins: `crate::traverse::origin_order`).
#[derive(Debug, Default)]
pub struct KdScratch {
    stack: Vec<(u32, Span)>,
    mailbox: Mailbox,
    order: OriginOrder,
}

impl WithOriginOrder for KdScratch {
    fn origin_order(&mut self) -> &mut OriginOrder {
        &mut self.order
    }
}

/// A node's slab-test result for the ray: the entry distance (at least `tmin`) and the exit
/// distance over its planes only (the range end is applied when it is used, since it shrinks).
/// Exactly what [`Aabb::entry`] computes, kept in two parts so that a child's span is its
/// parent's with one plane replaced (see [`Span::split`]).
#[derive(Clone, Copy, Debug)]
struct Span {
    near: f32,
    far: f32,
}

impl Span {
    /// The span of `bounds`: the slab test's arithmetic, lane by lane, NaN lanes (a ray in a
    /// face's plane) dropped by the same compare-and-select.
    #[inline(always)]
    fn of(bounds: &Aabb, ray: &PreparedRay) -> Self {
        let mut span = Self {
            near: ray.tmin,
            far: f32::MAX,
        };
        for a in 0..3 {
            let (lo, hi) = (bounds.min[a], bounds.max[a]);
            let (near, far) = if ray.inv_dir[a] < 0.0 {
                (hi, lo)
            } else {
                (lo, hi)
            };
            span.raise(plane_enter(near, ray, a));
            span.lower(plane_exit(far, ray, a));
        }
        span
    }

    /// The entry distance if the node is touched within `[tmin, tmax]`, else `+inf` (the
    /// value [`Aabb::entry`] returns for the node's box).
    #[inline(always)]
    fn entry(&self, tmax: f32) -> f32 {
        if self.near <= self.far.min(tmax) {
            self.near
        } else {
            f32::INFINITY
        }
    }

    #[inline(always)]
    fn raise(&mut self, enter: f32) {
        if enter > self.near {
            self.near = enter;
        }
    }

    #[inline(always)]
    fn lower(&mut self, exit: f32) {
        if exit < self.far {
            self.far = exit;
        }
    }

    /// The spans of the children below and above the plane `position` on `axis`. The plane is
    /// the far face of one child and the near face of the other (which is which depends on the
    /// direction's sign); the child's other faces are the parent's, whose terms are already in
    /// `self`, and the face the plane replaces gave a smaller entry (or larger exit) by
    /// monotonicity, so folding the plane in gives the child's slab test exactly.
    #[inline(always)]
    fn split(&self, ray: &PreparedRay, axis: usize, position: f32) -> (Span, Span) {
        let (mut near_side, mut far_side) = (*self, *self);
        near_side.lower(plane_exit(position, ray, axis));
        far_side.raise(plane_enter(position, ray, axis));
        if ray.inv_dir[axis] < 0.0 {
            (far_side, near_side)
        } else {
            (near_side, far_side)
        }
    }
}

/// The slab test's entry term for a plane (`(p - o) * inv`).
#[inline(always)]
fn plane_enter(p: f32, ray: &PreparedRay, axis: usize) -> f32 {
    (p - ray.origin[axis]) * ray.inv_dir[axis]
}

/// The slab test's exit term for a plane, scaled up (`(p - o) * inv * EXIT_SCALE`).
#[inline(always)]
fn plane_exit(p: f32, ray: &PreparedRay, axis: usize) -> f32 {
    (p - ray.origin[axis]) * ray.inv_dir[axis] * EXIT_SCALE
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
    if tree.refs.is_empty() {
        return tmax;
    }
    let root = Span::of(&tree.bounds, ray);
    if root.entry(tmax) == f32::INFINITY {
        return tmax;
    }
    let KdScratch { stack, mailbox, .. } = scratch;
    mailbox.next_ray();
    stack.clear();
    let (mut node, mut span) = (0u32, root);
    loop {
        visitor.enter_node(id);
        match tree.nodes[node as usize].decode() {
            Decoded::Split {
                axis,
                position,
                above,
            } => {
                let (below_span, above_span) = span.split(ray, axis, position);
                let below = (node + 1, below_span.entry(tmax), below_span);
                let above = (above, above_span.entry(tmax), above_span);
                let (near, far) = if above.1 < below.1 {
                    (above, below)
                } else {
                    (below, above)
                };
                if near.1 < f32::INFINITY {
                    if far.1 < f32::INFINITY {
                        stack.push((far.0, far.2));
                    }
                    (node, span) = (near.0, near.2);
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
            let Some((pending, pending_span)) = stack.pop() else {
                return tmax;
            };
            if pending_span.near <= tmax {
                (node, span) = (pending, pending_span);
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::geom::Ray;

    /// The split spans give the children's slab tests bit for bit, also for rays in the plane.
    #[test]
    fn split_spans_equal_the_childrens_slab_tests() {
        let bounds = Aabb::new(Vec3::ZERO, Vec3::splat(4.0));
        let mut rng = crate::test_support::TestRng::new(5);
        for i in 0..2000 {
            let o = (rng.vec3(6.0) * 2.0).round() * 0.5 + Vec3::splat(2.0);
            let d = (rng.vec3(2.0) * 2.0).round() * 0.5;
            let Some(ray) = PreparedRay::new(&Ray::with_range(o, d, 0.0, 9.0)) else {
                continue;
            };
            let axis = i % 3;
            let s = [1.0, 2.0, 2.5][i % 3];
            let (mut below, mut above) = (bounds, bounds);
            below.max[axis] = s;
            above.min[axis] = s;
            let (b, a) = Span::of(&bounds, &ray).split(&ray, axis, s);
            for tmax in [9.0, 2.0] {
                let want = [below.entry(&ray, tmax), above.entry(&ray, tmax)];
                let got = [b.entry(tmax), a.entry(tmax)];
                assert_eq!(want.map(f32::to_bits), got.map(f32::to_bits), "{ray:?}");
            }
        }
    }
}
