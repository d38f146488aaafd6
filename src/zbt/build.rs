//! The zero-byte tree's SAH build: at each node, keep the few triangles that define
//! its box ([`super::cover`]), take them out of the rest of the build, and split the rest with
//! the binned SAH of the AABB trees.
//!
//! **Inherited faces.** Every visit of a node tests the triangles that define its box, so they
//! are the zero-byte tree's main cost. A child's set lies inside its parent's box and usually
//! almost touches most of the parent's faces (all but the split side); for each such face the
//! child may *inherit* the parent's face instead of owning a triangle that reaches it. Its box
//! is then the parent's on inherited faces and its own triangles' elsewhere: still a box around
//! everything below it (the parent's face is at or beyond the child's set), a little looser on
//! those faces. A face is inherited when the gap is at most [`super::ZbtOptions::inherit_slack`]
//! times the child's extent on that axis. The parent stores both children's 6-bit masks in its
//! aux word, so an internal node owns at least 2 triangles (a cover of 1 takes one more).
//!
//! **Layout.** The triangles are reordered in place so that a node's own triangles come first,
//! then its first child's subtree, then its second child's: node `P` owns positions
//! `P..P + count`, its first child starts at `P + count`, and the second at `P + offset`. The
//! build writes the [`super::layout`] words of every position into `high` (parallel to the
//! triangles), to be packed into the index bits once the triangles are in their final order.

use glam::{BVec3A, Vec3A};

use super::cover;
use super::layout::{MAX_NODE_TRIANGLES, aux_word, node_word};
use crate::bvh::build::{Box3A, Extent, Prim, split_in_two};
use crate::bvh::ordering::{ChildOrdering, ordering_byte};

/// Subtrees with more triangles than this are built on two rayon tasks.
const PARALLEL_THRESHOLD: usize = 16 * 1024;
/// Every face.
const ALL_FACES: u8 = 0b11_1111;

/// How one zero-byte (sub)tree is built.
#[derive(Clone, Copy)]
pub(crate) struct RangeBuilder {
    /// Sets of at most this many triangles (1..=8) become leaves.
    pub(crate) leaf_size: u32,
    /// Largest gap (relative to the child's extent) at which a child inherits a face.
    pub(crate) inherit_slack: f32,
    pub(crate) ordering: ChildOrdering,
    /// Build large subtrees in parallel (rayon is known to work).
    pub(crate) parallel: bool,
}

/// What a node gets from its parent: the faces it inherits and its box at run time.
#[derive(Clone, Copy)]
struct Given {
    inherited: u8,
    bounds: Box3A,
}

impl RangeBuilder {
    /// The builder `options` describe (parallel only where rayon works).
    pub(crate) fn new(options: &super::ZbtOptions) -> Self {
        Self {
            leaf_size: options.leaf_size,
            inherit_slack: options.inherit_slack,
            ordering: options.ordering,
            parallel: crate::parallel::enabled(options.parallel),
        }
    }

    /// Builds the tree over `prims` (at least one), reordering them, and writes each position's
    /// high word into `high` (same length). The root inherits nothing. Returns the tree's depth
    /// in nodes; `depth` is the depth of its root in an enclosing tree (it only switches the
    /// SAH to median splits).
    pub(crate) fn build(&self, prims: &mut [Prim], high: &mut [u32], depth: usize) -> usize {
        debug_assert!(!prims.is_empty() && prims.len() == high.len());
        let root = Given {
            inherited: 0,
            bounds: Extent::of(prims).bounds,
        };
        self.node(prims, high, depth, root)
    }

    /// [`RangeBuilder::build`] for a tree whose root's box is stored by its parent (the
    /// hybrid tree's top node) as the exact box of `prims`: the root inherits every face.
    pub(crate) fn build_inside(&self, prims: &mut [Prim], high: &mut [u32], depth: usize) -> usize {
        debug_assert!(!prims.is_empty() && prims.len() == high.len());
        let root = Given {
            inherited: ALL_FACES,
            bounds: Extent::of(prims).bounds,
        };
        self.node(prims, high, depth, root)
    }

    fn node(&self, prims: &mut [Prim], high: &mut [u32], depth: usize, given: Given) -> usize {
        let m = prims.len();
        if m <= self.leaf_size as usize {
            return leaf(high, m);
        }
        let extent = Extent::of(prims);
        let cover = cover::choose(prims, &extent.bounds, ALL_FACES & !given.inherited);
        // An internal node owns at least 2 triangles: the second holds its aux word.
        let c = cover.max(2);
        if m - c <= 1 {
            // The box's triangles and at most one more: a leaf (at most 7 triangles).
            return leaf(high, m);
        }
        let (own_high, rest_high) = high.split_at_mut(c);
        let rest = &mut prims[c..];
        let (axis, mid, left, right) = split_in_two(rest, &Extent::of(rest), depth);
        let [gl, gr] = [(&left, mid), (&right, rest.len() - mid)]
            .map(|(part, len)| self.child(&given.bounds, &part.bounds, len));
        let order = ordering_byte(self.ordering, &gl.bounds.aabb(), &gr.bounds.aabb(), axis);
        own_high[0] = node_word(c as u32, (c + mid) as u32);
        own_high[1] = aux_word(order, [gl.inherited, gr.inherited]);
        let (lp, rp) = rest.split_at_mut(mid);
        let (lh, rh) = rest_high.split_at_mut(mid);
        let (dl, dr) = crate::parallel::join(
            self.parallel && m > PARALLEL_THRESHOLD,
            || self.node(lp, lh, depth + 1, gl),
            || self.node(rp, rh, depth + 1, gr),
        );
        1 + dl.max(dr)
    }

    /// What a child whose set has box `own` (and `len` triangles) gets from a parent whose
    /// box is `parent`: the faces within the slack (none for a leaf-sized set, which owns all
    /// its triangles anyway) and the box it will have at run time.
    fn child(&self, parent: &Box3A, own: &Box3A, len: usize) -> Given {
        if len <= self.leaf_size as usize {
            return Given {
                inherited: 0,
                bounds: *own,
            };
        }
        let slack = (own.max - own.min) * self.inherit_slack;
        let low = (own.min - parent.min).cmple(slack);
        let high = (parent.max - own.max).cmple(slack);
        Given {
            inherited: (low.bitmask() | high.bitmask() << 3) as u8,
            bounds: Box3A {
                min: Vec3A::select(low, parent.min, own.min),
                max: Vec3A::select(high, parent.max, own.max),
            },
        }
    }
}

/// Makes the `count` (1..=8) triangles at the front of `high`'s range one leaf.
fn leaf(high: &mut [u32], count: usize) -> usize {
    debug_assert!(count as u32 <= MAX_NODE_TRIANGLES);
    high[0] = node_word(count as u32, 0);
    1
}

/// The faces of `inherited` taken from `parent`, the others from `own` (the run-time rule,
/// shared with [`super::packed`]).
#[inline(always)]
pub(crate) fn inherit(
    own: (Vec3A, Vec3A),
    parent: (Vec3A, Vec3A),
    inherited: u8,
) -> (Vec3A, Vec3A) {
    let bit = |b: u8| inherited & (1 << b) != 0;
    let low = BVec3A::new(bit(0), bit(1), bit(2));
    let high = BVec3A::new(bit(3), bit(4), bit(5));
    (
        Vec3A::select(low, parent.0, own.0),
        Vec3A::select(high, parent.1, own.1),
    )
}
