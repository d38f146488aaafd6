//! One group of rays down the tree, once (seed 001).
//!
//! An explicit stack holds `(node, count)`: the rays in lanes `start..start + count` are the
//! ones that reached the node's parent. At each node the box is fetched (or dequantized) once,
//! tested against all of them, and the ones that touch it are moved to the front; only that
//! prefix goes on to the node's triangles and children. Each triangle is loaded once and tested
//! against every surviving ray. A child's partition only reorders the prefix it was given, so
//! when the second child is popped the prefix still holds the same set of rays.
//!
//! All rays of a group share the octant (when grouped by octant) so the node's ordering byte
//! applies to the whole group. The kernel `K` is the very function the single-ray path runs:
//! results are bit-identical.

use super::lanes::Lanes;
use super::partition::{PartitionKernel, partition};
use glam::Vec3;

use crate::geom::TriangleTest;
use crate::query::Hit;
use crate::query::single::{Visitor, test_triangles, traverse_below};
use crate::tree::ordering::second_child_first;
use crate::tree::{Bvh, NodeView};

/// What a batched query does with each triangle hit.
pub(crate) trait LaneVisitor {
    /// Called for a hit of ray `id` (current range end `*tmax`); may shrink `*tmax` (closest
    /// hit) or set it to `-inf` to retire the ray (any hit).
    fn visit(&mut self, id: u32, hit: Hit, tmax: &mut f32);
}

/// Runs the rays in `lanes[start..end]` through the tree. `octant_mask` orders children (0 for
/// the fixed order); `stack` is reusable scratch.
#[allow(clippy::too_many_arguments)]
pub(crate) fn traverse_group<B, K, V>(
    tree: &B,
    lanes: &mut Lanes,
    start: usize,
    end: usize,
    octant_mask: u8,
    partition_kernel: PartitionKernel,
    single_ray_below: usize,
    stack: &mut Vec<(u32, u32)>,
    visitor: &mut V,
) where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: LaneVisitor,
{
    if tree.node_count() == 0 || start == end {
        return;
    }
    stack.clear();
    stack.push((0, (end - start) as u32));
    while let Some((index, count)) = stack.pop() {
        let node = tree.node(index);
        let active = partition(
            partition_kernel,
            lanes,
            &node.bounds,
            start,
            start + count as usize,
        );
        if active == 0 {
            continue;
        }
        if active < single_ray_below {
            finish_one_by_one::<B, K, V>(tree, lanes, start, active, node, visitor);
            continue;
        }
        test_leaf::<B, K, V>(tree, lanes, start, active, &node, visitor);
        if node.first_child != 0 {
            let c = node.first_child;
            let (near, far) = if second_child_first(node.order, octant_mask) {
                (c + 1, c)
            } else {
                (c, c + 1)
            };
            stack.push((far, active as u32));
            stack.push((near, active as u32));
        }
    }
}

/// Most triangles a leaf pass keeps at once; larger triangle ranges go in several passes.
const LEAF_BATCH: usize = 16;

/// Tests the node's triangles against the `active` rays at `start..`. Each triangle is fetched
/// once (up to [`LEAF_BATCH`] at a time) for all rays, and each ray is rebuilt from its lane
/// once for all those triangles.
fn test_leaf<B, K, V>(
    tree: &B,
    lanes: &mut Lanes,
    start: usize,
    active: usize,
    node: &NodeView,
    visitor: &mut V,
) where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: LaneVisitor,
{
    let mut fetched = [(0u32, [Vec3::ZERO; 3]); LEAF_BATCH];
    let end = node.first + node.count;
    for first in (node.first..end).step_by(LEAF_BATCH) {
        let count = (end - first).min(LEAF_BATCH as u32) as usize;
        for (k, slot) in (first..).take(count).enumerate() {
            fetched[k] = tree.triangle(slot);
        }
        for lane in start..start + active {
            let mut one = OneRay {
                id: lanes.id(lane),
                tmax: lanes.tmax(lane),
                visitor: &mut *visitor,
            };
            test_triangles::<K, _>(&lanes.ray(lane), fetched[..count].iter().copied(), &mut one);
            lanes.set_tmax(lane, one.tmax);
        }
    }
}

/// Finishes the subtree under `node` for the `active` rays at `start..`, one ray at a time: when
/// only a few rays are left, the per-node cost of the batch (partition, stack) outweighs what
/// they share. The single-ray loop with the ray's current range gives the same answers (they do
/// not depend on the visiting order).
fn finish_one_by_one<B, K, V>(
    tree: &B,
    lanes: &mut Lanes,
    start: usize,
    active: usize,
    node: NodeView,
    visitor: &mut V,
) where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: LaneVisitor,
{
    for lane in start..start + active {
        let id = lanes.id(lane);
        let mut one = OneRay {
            id,
            tmax: lanes.tmax(lane),
            visitor: &mut *visitor,
        };
        traverse_below::<B, K, _>(tree, &lanes.ray(lane), node, &mut one);
        lanes.set_tmax(lane, one.tmax);
    }
}

/// Adapts a [`LaneVisitor`] to the single-ray loop for one ray.
struct OneRay<'a, V> {
    id: u32,
    tmax: f32,
    visitor: &'a mut V,
}

impl<V: LaneVisitor> Visitor for OneRay<'_, V> {
    #[inline(always)]
    fn visit(&mut self, hit: Hit) -> bool {
        self.visitor.visit(self.id, hit, &mut self.tmax);
        // An any-hit visitor retires the ray by setting its range end to -inf.
        self.tmax == f32::NEG_INFINITY
    }
    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.tmax
    }
}

/// Keeps each ray's best hit by the tie rule; `best[id].triangle == u32::MAX` means no hit yet.
pub(crate) struct ClosestLanes<'a> {
    pub best: &'a mut [Hit],
}

impl LaneVisitor for ClosestLanes<'_> {
    #[inline(always)]
    fn visit(&mut self, id: u32, hit: Hit, tmax: &mut f32) {
        // The lane's range end is always the best `t` so far and kernels only report
        // `t <= tmax`: a strictly smaller `t` wins without reading the best hit (a cache miss
        // in a batch of a million rays); only a tie needs the best hit's id.
        let best = &mut self.best[id as usize];
        if hit.t < *tmax || hit.is_before(best) {
            *best = hit;
            *tmax = hit.t;
        }
    }
}

/// Marks a ray occluded and retires it.
pub(crate) struct AnyLanes<'a> {
    pub occluded: &'a mut [bool],
}

impl LaneVisitor for AnyLanes<'_> {
    #[inline(always)]
    fn visit(&mut self, id: u32, _: Hit, tmax: &mut f32) {
        self.occluded[id as usize] = true;
        *tmax = f32::NEG_INFINITY;
    }
}

/// Reports every hit with the ray's index in the whole batch.
pub(crate) struct EveryLane<'a, F> {
    pub offset: usize,
    pub f: &'a F,
}

impl<F: Fn(usize, Hit)> LaneVisitor for EveryLane<'_, F> {
    #[inline(always)]
    fn visit(&mut self, id: u32, hit: Hit, _: &mut f32) {
        (self.f)(self.offset + id as usize, hit);
    }
}
