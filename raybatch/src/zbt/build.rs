//! The zero-byte tree's SAH build (seed 002): at each node, keep the few triangles that define
//! its box ([`super::cover`]), take them out of the rest of the build, and split the rest with
//! the binned SAH of the AABB trees.
//!
//! The triangles are reordered in place so that a node's own triangles come first, then its
//! first child's subtree, then its second child's: node `P` owns positions `P..P + count`, its
//! first child starts at `P + count`, and the second at `P + offset`. The build writes the
//! [`super::layout`] words of every position into `high` (parallel to the triangles), to be
//! packed into the index bits once the triangles are in their final order.

use super::BoxVertices;
use super::cover;
use super::layout::{MAX_NODE_TRIANGLES, MAX_SELECTORS, aux_word, node_word};
use crate::bvh::build::{Extent, Prim, split_in_two};
use crate::bvh::ordering::{ChildOrdering, ordering_byte};
use crate::mesh::Mesh;

/// Subtrees with more triangles than this are built on two rayon tasks.
const PARALLEL_THRESHOLD: usize = 16 * 1024;

/// How one zero-byte (sub)tree is built.
#[derive(Clone, Copy)]
pub(crate) struct RangeBuilder<'a> {
    pub(crate) mesh: &'a Mesh,
    /// Sets of at most this many triangles (1..=8) become leaves.
    pub(crate) leaf_size: u32,
    pub(crate) vertices: BoxVertices,
    pub(crate) ordering: ChildOrdering,
    /// Build large subtrees in parallel (rayon is known to work).
    pub(crate) parallel: bool,
}

impl RangeBuilder<'_> {
    /// Builds the tree over `prims` (at least one), reordering them, and writes each position's
    /// high word into `high` (same length). Returns the tree's depth in nodes; `depth` is the
    /// depth of its root in an enclosing tree (it only switches the SAH to median splits).
    pub(crate) fn build(&self, prims: &mut [Prim], high: &mut [u32], depth: usize) -> usize {
        debug_assert!(!prims.is_empty() && prims.len() == high.len());
        let m = prims.len();
        if m <= self.leaf_size as usize {
            self.leaf(prims, high, None);
            return 1;
        }
        let extent = Extent::of(prims);
        let cover = cover::choose(prims, &extent.bounds, self.mesh, self.vertices);
        let c = cover.count;
        if m - c <= 1 {
            // The box's triangles and at most one more: a leaf (at most 7 triangles).
            self.leaf(prims, high, cover.selectors);
            return 1;
        }
        let (rest, rest_high) = (&mut prims[c..], &mut high[c..]);
        let (axis, mid, left, right) = split_in_two(rest, &Extent::of(rest), depth);
        let order = ordering_byte(
            self.ordering,
            &left.bounds.aabb(),
            &right.bounds.aabb(),
            axis,
        );
        let (lp, rp) = rest.split_at_mut(mid);
        let (lh, rh) = rest_high.split_at_mut(mid);
        let (dl, dr) = if self.parallel && m > PARALLEL_THRESHOLD {
            rayon::join(
                || self.build(lp, lh, depth + 1),
                || self.build(rp, rh, depth + 1),
            )
        } else {
            (self.build(lp, lh, depth + 1), self.build(rp, rh, depth + 1))
        };
        high[0] = node_word(c as u32, (c + mid) as u32);
        if c >= 2 {
            high[1] = aux_word(order, cover.selectors.as_deref());
        }
        1 + dl.max(dr)
    }

    /// Makes `prims` (1..=8 triangles) one leaf. `selectors` are those of a cover already at
    /// the front; without them, one is looked for if the options ask for selected corners.
    fn leaf(&self, prims: &mut [Prim], high: &mut [u32], selectors: Option<Vec<u8>>) {
        let count = prims.len();
        debug_assert!(count as u32 <= MAX_NODE_TRIANGLES);
        high[0] = node_word(count as u32, 0);
        if count < 2 {
            return;
        }
        let selectors = match selectors {
            Some(s) => Some(s),
            None if self.vertices == BoxVertices::Selected => {
                let extent = Extent::of(prims);
                cover::choose(prims, &extent.bounds, self.mesh, self.vertices).selectors
            }
            None => None,
        };
        // Triangles beyond the cover lend any corner: each lies inside the box anyway.
        let selectors = selectors.map(|mut s| {
            s.resize(count.min(MAX_SELECTORS), 0);
            s
        });
        high[1] = aux_word(0, selectors.as_deref());
    }
}
