//! The one-ray loop over the wide trees: test the child boxes of a node at once, push the
//! children hit in the node's precomputed order for the ray's octant (precomputed node
//! sorting), nearest on top, and go on with the top entry in front of the best hit.
//!
//! Sorting the hit children by their entry distances instead takes fewer node visits but its
//! data-dependent branches mispredict; the precomputed order pushes without a branch and runs
//! as fast or faster on the clock (docs/benchmarks.md). A compare-exchange network on the
//! distances (branch-free, but more instructions) is no better.
//! Entry distances are kept on the stack: a pop whose entry lies behind the best hit is dropped
//! without reading anything (`<=`, for the tie rule of [`crate::hit`]).

use super::ray::{BoxSimd, WideRay};
use super::stack::Stack;
use super::{NodeKind, WideBvh};
use crate::bvh::nodes::leaf_word;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::traverse::single::test_triangle;

/// Traces `ray` (number `id`) through the whole tree, with box tests that may use `simd`,
/// prefetching the next pending child at each step if `PREFETCH` ([`trace_from`]); returns
/// the final range end.
#[inline(always)]
pub(crate) fn trace<N: NodeKind, K: TriangleTest, V: Visitor, const PREFETCH: bool>(
    tree: &WideBvh<N>,
    ray: &PreparedRay,
    id: u32,
    stack: &mut Stack,
    visitor: &mut V,
    simd: BoxSimd,
) -> f32 {
    let mut tmax = ray.tmax;
    // No root box test first (unless the visitor counts nodes): the root node's test turns
    // away the same rays, since its child boxes lie inside the root box and every rounding
    // step of the slab test is monotone in the planes (and a root that is a leaf holds only
    // triangles whose hits the box test never misses). Skipping it takes 4.5% of a `bvh8`
    // ray's instructions off.
    if tree.is_empty() || (V::COUNTS_NODES && !tree.root_bounds.hit_by(ray, tmax)) {
        return tmax;
    }
    let wide_ray = WideRay::new(ray, simd);
    let start = tree.root;
    let ray = (ray, &wide_ray, id);
    trace_from::<N, K, V, PREFETCH>(tree, ray, start, &mut tmax, stack, visitor);
    tmax
}

/// The loop, from child word `start` (whose box the ray is known to touch) with the ray's
/// current range end `tmax`. The stream engine calls it to finish a subtree for a few rays.
///
/// With `PREFETCH` (for trees beyond the caches, where a step mostly waits on memory), each
/// step also prefetches the first reads of the pending child after the one it goes on with
/// (its node's lines, or its leaf's slots or block), so that they arrive while this one is
/// visited.
/// Most steps go on with the nearest child hit, whose box test just asked for it; the one
/// below it on the stack is the next visit whenever the ray leaves this child's subtree
/// without a hit in front of it, such as after a leaf. The prefetch makes `bvh8` about 12%
/// faster per ray on the 1M-triangle terrain and 1-3% slower on meshes that stay in the
/// caches, hence only beyond the caches.
#[inline(always)]
pub(crate) fn trace_from<N: NodeKind, K: TriangleTest, V: Visitor, const PREFETCH: bool>(
    tree: &WideBvh<N>,
    (ray, wide_ray, id): (&PreparedRay, &WideRay, u32),
    start: u32,
    tmax: &mut f32,
    stack: &mut Stack,
    visitor: &mut V,
) {
    stack.reset();
    let mut item = start;
    while let Some(next) = step::<N, K, V>(tree, (ray, wide_ray, id), item, tmax, stack, visitor) {
        if PREFETCH && let Some(after) = stack.peek() {
            tree.prefetch_item(after.word);
        }
        item = next;
    }
}

/// One turn of the loop: tests `item` (a node's boxes, or a leaf's triangles), then
/// returns the next item: the nearest child entered, else the nearest pending child still in
/// front of the best hit; `None` when the ray is done. The interleaved engine
/// ([`super::interleaved`]) takes turns between several rays with it.
#[inline(always)]
pub(crate) fn step<N: NodeKind, K: TriangleTest, V: Visitor>(
    tree: &WideBvh<N>,
    (ray, wide_ray, id): (&PreparedRay, &WideRay, u32),
    item: u32,
    tmax: &mut f32,
    stack: &mut Stack,
    visitor: &mut V,
) -> Option<u32> {
    visitor.enter_node(id);
    if leaf_word::is_leaf(item) {
        // A plain loop: through an iterator of fetched triangles, its `next` was left out of
        // line on the bunny (62 instructions a triangle, a fifth of a call of 4,096 rays).
        let (_, count) = leaf_word::unpack(item);
        for k in 0..count {
            let (triangle, corners) = tree.triangle(item, k);
            if test_triangle::<K, V>(ray, id, (triangle, &corners), tmax, visitor) {
                return None;
            }
        }
    } else {
        // The hit children go on the stack, nearest on top, and the walk goes on with the
        // top entry in front of the best hit: no branch on whether any child was hit (a
        // quarter of the visits hit none, unpredictably). (Prefetching the pushed children's
        // nodes is slower: about 10% on the bunny.)
        tree.nodes[item as usize].push_hits(wide_ray, *tmax, stack);
    }
    pop_in_front(stack, *tmax)
}

/// Pops pending children until one lies in front of the best hit (`<=`, for the tie rule).
#[inline(always)]
fn pop_in_front(stack: &mut Stack, tmax: f32) -> Option<u32> {
    while let Some(pending) = stack.pop() {
        if pending.entry <= tmax {
            return Some(pending.word);
        }
    }
    None
}
