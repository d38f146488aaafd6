//! What the wide walks need of a node, so that one tree type, one collapse, one one-ray loop,
//! one stream engine and one side-by-side engine serve nodes of four children
//! ([`WideNode`](super::node4::WideNode)), of eight ([`WideNode8`](super::node8::WideNode8), the
//! default tree), of four in a quantized 64-byte node
//! ([`QuantizedWideNode`](super::node4q::QuantizedWideNode)) and of eight in a quantized
//! 128-byte node ([`QuantizedWideNode8`](super::node8q::QuantizedWideNode8)).
//!
//! Eight children take about a third fewer node visits per walk (12.8 -> 8.8 per incoherent
//! fandisk ray; each a dependent load: the one-ray loop is bound by their latency, not by its
//! instruction count), for a wider box test and push. Each layout implements the traits beside
//! its node, in `node4.rs`, `node8.rs`, `node4q.rs` and `node8q.rs`; all of them order their
//! children per octant with [`octant_orders`](super::order::octant_orders).

use std::fmt::Debug;

use super::order::slot_order;
use super::ray::{StreamPlanes, WideRay};
use super::stack::Stack;
use crate::bvh::LeafCopy;
use crate::geom::Aabb;

/// A wide node layout: [`WideNode`](super::node4::WideNode),
/// [`WideNode8`](super::node8::WideNode8),
/// [`QuantizedWideNode`](super::node4q::QuantizedWideNode) or
/// [`QuantizedWideNode8`](super::node8q::QuantizedWideNode8) (sealed: what the walks need of a
/// node is the crate's own, in the private `layout::Layout`).
pub trait NodeKind: layout::Layout + Clone + Copy + Debug + Send + Sync + 'static {}

// The walk's types are the crate's own; the trait cannot be named outside the crate (its module
// is private), so nothing outside can call these methods.
#[allow(private_interfaces)]
pub(crate) mod layout {
    use super::*;

    /// What the collapse and the walks need of a node layout.
    pub trait Layout: Sized {
        /// Children per node.
        const WIDTH: usize;
        /// The structure's name in tables ([`crate::Footprint::name`]).
        const NAME: &'static str;
        /// The layout's name in error messages.
        const FORMAT: &'static str;
        /// What the tree copies of its leaves by default ([`crate::LeafCopy::Auto`]).
        const LEAF_COPY: LeafCopy;
        /// What it copies by default on large trees (over 8 MiB with the mesh), where a leaf's
        /// chain of dependent reads costs a trip to L3 or memory per link
        /// (`wide::default_leaf_copy`).
        const LEAF_COPY_LARGE: LeafCopy = Self::LEAF_COPY;

        /// The node of `children` (at most `WIDTH` boxes and child words, in slots `0..`),
        /// with its per-octant child orders.
        fn from_children(children: &[(Aabb, u32)]) -> Self;

        /// Tests the ray against every child's box and pushes the children it enters within
        /// `[tmin, tmax]` on `stack`, in the node's order for the ray's octant, nearest on top.
        fn push_hits(&self, ray: &WideRay, tmax: f32, stack: &mut Stack);

        /// Prefetches the node's cache lines.
        fn prefetch(&self);

        /// The child boxes' planes as rays of direction octant `octant` meet them, lane `k`
        /// for slot `k`: the stream engine picks them once per node for eight rays at a time.
        fn stream_planes(&self, octant: u32) -> StreamPlanes;

        /// Which child boxes `ray` enters within `[tmin, tmax]` (bit `k` for slot `k`): the
        /// stream engine's test for the rays it does not take eight at a time.
        fn ray_mask(&self, ray: &WideRay, tmax: f32) -> u32;

        /// The child word of slot `slot`.
        fn child(&self, slot: usize) -> u32;

        /// Every slot's child word, to rewrite leaf words (unused slots hold 0, no leaf word).
        fn children_mut(&mut self) -> &mut [u32];

        /// The box the node's tests use for slot `slot` (it holds the child's box).
        fn child_bounds(&self, slot: usize) -> Aabb;

        /// The number of slots in use (slots are filled from 0 up).
        fn used_slots(&self) -> usize;

        /// The order word of direction octant `octant` (see
        /// [`crate::wide::order::octant_orders`]).
        fn order_word(&self, octant: u32) -> u32;

        /// Every slot, nearest first for rays of octant mask `octant_mask` (`1 << octant`) or
        /// in slot order for mask 0 (mixed octants), `WIDTH.trailing_zeros()` bits each.
        #[inline(always)]
        fn stream_order(&self, octant_mask: u8) -> u32 {
            match octant_mask {
                0 => slot_order(Self::WIDTH),
                mask => self.order_word(mask.trailing_zeros()),
            }
        }
    }
}
