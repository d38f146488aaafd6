//! The one-ray loop over the 4-wide tree: test the four child boxes of a node at once, go on
//! with the nearest child hit, push the others sorted so that the nearest is popped first.
//! Entry distances are kept on the stack: a pop whose entry lies behind the best hit is dropped
//! without reading anything (`<=`, for the tie rule of [`crate::hit`]).

use super::WideTree;
use super::node::WideRay;
use crate::bvh::nodes::leaf_word;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::traverse::single::test_triangles;

/// Traces `ray` (number `id`) through the whole tree; returns the final range end.
#[inline(always)]
pub(crate) fn trace<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    ray: &PreparedRay,
    id: u32,
    stack: &mut Vec<(u32, f32)>,
    visitor: &mut V,
) -> f32 {
    let mut tmax = ray.tmax;
    if tree.is_empty() || !tree.root_bounds.hit_by(ray, tmax) {
        return tmax;
    }
    trace_from::<K, V>(tree, ray, id, tree.root, &mut tmax, stack, visitor);
    tmax
}

/// The loop, from child word `start` (whose box the ray is known to touch) with the ray's
/// current range end `tmax`. The stream engine calls it to finish a subtree for a few rays.
#[inline(always)]
pub(crate) fn trace_from<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    ray: &PreparedRay,
    id: u32,
    start: u32,
    tmax: &mut f32,
    stack: &mut Vec<(u32, f32)>,
    visitor: &mut V,
) {
    let wide_ray = WideRay::new(ray);
    stack.clear();
    stack.reserve(3 * tree.depth + 1);
    let mut item = start;
    while let Some(next) = step::<K, V>(tree, (ray, &wide_ray, id), item, tmax, stack, visitor) {
        item = next;
    }
}

/// One turn of the loop: tests `item` (a node's four boxes, or a leaf's triangles), then
/// returns the next item: the nearest child entered, else the nearest pending child still in
/// front of the best hit; `None` when the ray is done. The interleaved engine
/// ([`super::interleaved`]) takes turns between several rays with it.
#[inline(always)]
pub(crate) fn step<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    (ray, wide_ray, id): (&PreparedRay, &WideRay, u32),
    item: u32,
    tmax: &mut f32,
    stack: &mut Vec<(u32, f32)>,
    visitor: &mut V,
) -> Option<u32> {
    visitor.enter_node(id);
    if leaf_word::is_leaf(item) {
        let (first, count) = leaf_word::unpack(item);
        let triangles = (first..first + count).map(|slot| tree.triangle(slot));
        if test_triangles::<K, V>(ray, id, triangles, tmax, visitor) {
            return None;
        }
    } else {
        let node = &tree.nodes[item as usize];
        let (mask, entries) = wide_ray.hits(node, *tmax);
        if mask != 0 {
            // (Prefetching the pushed children's nodes here was measured slower: 366 vs 332 ms
            // on 1M bunny rays, 228 vs 218 on the teapot, best of 12 passes.)
            return Some(nearest_pushing_others(
                mask,
                entries.to_array(),
                &node.child,
                stack,
            ));
        }
    }
    pop_in_front(stack, *tmax)
}

/// Pops pending children until one lies in front of the best hit (`<=`, for the tie rule).
#[inline(always)]
fn pop_in_front(stack: &mut Vec<(u32, f32)>, tmax: f32) -> Option<u32> {
    while let Some((pending, entry)) = stack.pop() {
        if entry <= tmax {
            return Some(pending);
        }
    }
    None
}

/// The child word of the nearest hit child; the other hit children are pushed, farthest
/// first, so that they are popped nearest first.
#[inline(always)]
fn nearest_pushing_others(
    mut mask: u32,
    entries: [f32; 4],
    children: &[u32; 4],
    stack: &mut Vec<(u32, f32)>,
) -> u32 {
    if mask.count_ones() == 1 {
        return children[mask.trailing_zeros() as usize & 3];
    }
    // Insertion sort of at most four (entry, word) pairs, farthest first.
    let mut hits = [(0.0f32, 0u32); 4];
    let mut n = 0;
    while mask != 0 {
        let k = mask.trailing_zeros() as usize & 3;
        let mut j = n;
        while j > 0 && hits[j - 1].0 < entries[k] {
            hits[j] = hits[j - 1];
            j -= 1;
        }
        hits[j] = (entries[k], children[k]);
        n += 1;
        mask &= mask - 1;
    }
    for &(entry, word) in &hits[..n - 1] {
        stack.push((word, entry));
    }
    hits[n - 1].1
}
