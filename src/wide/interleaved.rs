//! Several rays walked side by side through a wide tree, one loop turn each in turn: the
//! batched engine of the wide trees ([`super::WideBvh`]) on large trees and short streams.
//!
//! On a mesh whose tree does not fit the L2 cache, the one-ray loop spends most of its time
//! waiting: each node read depends on the previous node's answer, and a leaf's triangles are a
//! chain of three dependent reads (slot -> id -> vertex indices -> corners), so nothing overlaps
//! the misses. Here [`LANES`] rays each keep their own loop state (the next item, a stack,
//! their range end) and take turns. After a turn a ray prefetches what its next turn reads (the
//! next node's cache lines, or the next link of the leaf's chain, one link per turn), and
//! by the time its turn comes again the other rays' turns have hidden the latency.
//!
//! A turn is the one-ray loop's own step ([`super::single::step`]), so each ray visits the same
//! nodes in the same order, with the same kernels and the same range ends, as it would alone:
//! answers are those of the one-ray loop, bit for bit. Prefetching never changes a value.

use super::ray::{BoxSimd, WideRay};
use super::single::step;
use super::stack::Stack;
use super::{LEAF_READY, NodeKind, WideBvh};
use crate::accel::RayStream;
use crate::bvh::nodes::leaf_word;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;

/// Rays walked side by side: enough turns between two turns of one ray to cover a miss to
/// memory (a turn is some 100 instructions), few enough that their states stay in L1.
pub(crate) const LANES: usize = 8;

/// One ray's loop state; `active` is false for a free slot (its other fields are stale).
struct Walker {
    active: bool,
    ray: PreparedRay,
    wide: WideRay,
    /// Index of the ray in the stream.
    index: usize,
    id: u32,
    tmax: f32,
    /// The next node or leaf to visit.
    item: u32,
    /// For a leaf item: links of its triangles' read chain prefetched so far.
    stage: u8,
}

/// Runs every ray of `stream` through the tree, [`LANES`] at a time; `stacks` is scratch.
#[inline(always)]
pub(crate) fn trace_stream<N: NodeKind, K: TriangleTest, V: Visitor>(
    tree: &WideBvh<N>,
    stream: &mut RayStream<'_>,
    stacks: &mut [Stack; LANES],
    visitor: &mut V,
    simd: BoxSimd,
) {
    if tree.is_empty() || stream.is_empty() {
        return;
    }
    // Free walkers, reused in place for ray after ray (the ray is a placeholder).
    let ray = stream.ray(0);
    let free = Walker {
        active: false,
        wide: WideRay::new(&ray, simd),
        ray,
        index: 0,
        id: 0,
        tmax: 0.0,
        item: 0,
        stage: 0,
    };
    let mut walkers: [Walker; LANES] = std::array::from_fn(|_| Walker { ..free });
    let mut next = 0;
    loop {
        let mut busy = false;
        for (w, stack) in walkers.iter_mut().zip(stacks.iter_mut()) {
            if !w.active && !start(tree, stream, (&mut next, simd), w, stack) {
                continue;
            }
            busy = true;
            if !turn::<N, K, V>(tree, w, stack, visitor) {
                stream.set_tmax(w.index, w.tmax);
                w.active = false;
            }
        }
        if !busy {
            return;
        }
    }
}

/// Starts `w` on the next ray of the stream (from `*next` on) that enters the root's box
/// (all of them in a culled stream, [`RayStream::in_cull_bounds`]); false when no ray is
/// left. Rays that miss the root keep their range end.
#[inline(never)]
fn start<N: NodeKind>(
    tree: &WideBvh<N>,
    stream: &RayStream<'_>,
    (next, simd): (&mut usize, BoxSimd),
    w: &mut Walker,
    stack: &mut Stack,
) -> bool {
    while *next < stream.len() {
        let index = *next;
        *next += 1;
        let ray = stream.ray(index);
        // A culled stream's rays all touch the root box: the preparation tested it.
        if stream.in_cull_bounds() || tree.root_bounds.hit_by(&ray, ray.tmax) {
            stack.reset();
            w.active = true;
            w.wide = WideRay::new(&ray, simd);
            w.index = index;
            w.id = stream.id(index);
            w.tmax = ray.tmax;
            w.item = tree.root;
            w.stage = 0;
            w.ray = ray;
            return true;
        }
    }
    false
}

/// One turn of walker `w`: either one more link of its leaf's read chain is prefetched, or
/// its item is visited and the next item prefetched. Returns false when the ray is done.
#[inline(always)]
fn turn<N: NodeKind, K: TriangleTest, V: Visitor>(
    tree: &WideBvh<N>,
    w: &mut Walker,
    stack: &mut Stack,
    visitor: &mut V,
) -> bool {
    if leaf_word::is_leaf(w.item) && w.stage < LEAF_READY {
        w.stage = tree.prefetch_leaf(w.item, w.stage);
        return true;
    }
    let ray = (&w.ray, &w.wide, w.id);
    match step::<N, K, V>(tree, ray, w.item, &mut w.tmax, stack, visitor) {
        Some(item) => {
            w.item = item;
            w.stage = 0;
            if leaf_word::is_leaf(item) {
                w.stage = tree.prefetch_leaf(item, 0);
            } else {
                tree.prefetch_node(item);
            }
            true
        }
        None => false,
    }
}
