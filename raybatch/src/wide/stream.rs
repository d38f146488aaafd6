//! A stream of rays down the 4-wide tree once (seed 001, with four children per node).
//!
//! The stack holds `(node, slot, count)`: the child in `slot` of wide node `node`, to be tested
//! against rays `0..count` of the stream (the rays that reached its parent). Popping it
//! partitions those rays against the child's box, read from the parent once for all of them;
//! the rays that touch it go on to its triangles (a leaf) or push its own children. When the
//! stream's rays share an octant, children are pushed so that the one nearer along the octant's
//! diagonal is popped first (the precomputed-node-sorting criterion, evaluated once per node
//! visit for the whole stream). Few-ray subtrees finish with the one-ray loop.

use super::node::{WIDTH, WideNode};
use super::{WideScratch, WideTree};
use crate::accel::RayStream;
use crate::bvh::nodes::leaf_word;
use crate::geom::TriangleTest;
use crate::hit::Visitor;
use crate::traverse::stream::test_leaf;

/// Runs every ray of `stream` through the tree.
pub(crate) fn trace_stream<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    stream: &mut RayStream<'_>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    if tree.is_empty() || stream.is_empty() {
        return;
    }
    let active = stream.partition(stream.len(), &tree.root_bounds);
    if active == 0 {
        return;
    }
    let diagonal = octant_diagonal(stream.octant_mask());
    let mut pending = std::mem::take(&mut scratch.stream_stack);
    pending.clear();
    let mut walk = Walk {
        tree,
        diagonal,
        pending: &mut pending,
    };
    walk.visit::<K, V>(tree.root, active, stream, &mut scratch.stack, visitor);
    while let Some((node, slot, count)) = walk.pending.pop() {
        let parent = &tree.nodes[node as usize];
        let bounds = parent.slot_bounds(slot as usize);
        let active = stream.partition(count as usize, &bounds);
        if active > 0 {
            let word = parent.child[slot as usize];
            walk.visit::<K, V>(word, active, stream, &mut scratch.stack, visitor);
        }
    }
    scratch.stream_stack = pending;
}

/// The state of one stream's walk.
struct Walk<'a> {
    tree: &'a WideTree,
    /// The octant's diagonal (zero when the rays' octants differ: fixed order).
    diagonal: [f32; 3],
    pending: &'a mut Vec<(u32, u32, u32)>,
}

impl Walk<'_> {
    /// Rays `0..active` touch the box of child word `word`: test its triangles, or push its
    /// children, or finish its subtree one ray at a time when few rays are left.
    fn visit<K: TriangleTest, V: Visitor>(
        &mut self,
        word: u32,
        active: usize,
        stream: &mut RayStream<'_>,
        stack: &mut Vec<(u32, f32)>,
        visitor: &mut V,
    ) {
        let tree = self.tree;
        if leaf_word::is_leaf(word) {
            let (first, count) = leaf_word::unpack(word);
            let slots = first..first + count;
            test_leaf::<K, V>(stream, active, slots, |slot| tree.triangle(slot), visitor);
        } else if active < stream.options().single_ray_below {
            for i in 0..active {
                let ray = stream.ray(i);
                let mut tmax = ray.tmax;
                super::single::trace_from::<K, V>(
                    tree,
                    &ray,
                    stream.id(i),
                    word,
                    &mut tmax,
                    stack,
                    visitor,
                );
                stream.set_tmax(i, tmax);
            }
        } else {
            let node = &tree.nodes[word as usize];
            for slot in farthest_first(node, self.diagonal) {
                self.pending.push((word, slot as u32, active as u32));
            }
        }
    }
}

/// The diagonal `(+-1, +-1, +-1)` of the octant in `octant_mask`, or zero for mask 0.
fn octant_diagonal(octant_mask: u8) -> [f32; 3] {
    if octant_mask == 0 {
        return [0.0; 3];
    }
    let octant = octant_mask.trailing_zeros();
    [0, 1, 2].map(|axis| if octant & (1 << axis) != 0 { -1.0 } else { 1.0 })
}

/// The node's used slots, farthest first along `diagonal` (so that the nearest is popped
/// first); by slot when the diagonal is zero.
fn farthest_first(node: &WideNode, diagonal: [f32; 3]) -> impl Iterator<Item = usize> {
    let mut order = [(0.0f32, 0usize); WIDTH];
    let mut n = 0;
    for slot in 0..WIDTH {
        let b = node.slot_bounds(slot);
        if b.is_empty() {
            continue;
        }
        let c = b.center();
        let key = -(c.x * diagonal[0] + c.y * diagonal[1] + c.z * diagonal[2]);
        order[n] = (key, slot);
        n += 1;
    }
    order[..n].sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
    order.into_iter().take(n).map(|(_, slot)| slot)
}
