//! What the wide walks need of a node, so that one tree type, one collapse, one one-ray loop,
//! one stream engine and one side-by-side engine serve nodes of four children ([`WideNode`]),
//! of eight ([`WideNode8`], the default tree), of four in a quantized 64-byte node
//! ([`QuantizedWideNode`]) and of eight in a quantized 128-byte node ([`QuantizedWideNode8`]).
//!
//! Eight children take about a third fewer node visits per walk (12.8 -> 8.8 per incoherent
//! fandisk ray; each a dependent load: the one-ray loop is bound by their latency, not by its
//! instruction count), for a wider box test and push. Each layout implements the trait beside
//! its node, in `node.rs`, `node8.rs`, `node4q.rs` and `node8q.rs`; all of them order their children per
//! octant with [`octant_orders`].

use std::fmt::Debug;

use glam::Vec3;

use super::node::{WideNode, WideRay};
use super::node4q::QuantizedWideNode;
use super::node8::WideNode8;
use super::node8q::QuantizedWideNode8;
use super::stack::Stack;
use super::stream::StreamPlanes;
use crate::bvh::LeafCopy;
use crate::bvh::ordering::octant_diagonal;
use crate::geom::Aabb;

/// A wide node layout: [`WideNode`], [`WideNode8`], [`QuantizedWideNode`] or
/// [`QuantizedWideNode8`] (sealed: what the walks need of a node is the crate's own, in the
/// private `layout::Layout`).
pub trait NodeKind: layout::Layout + Clone + Copy + Debug + Send + Sync + 'static {}

impl NodeKind for WideNode {}
impl NodeKind for WideNode8 {}
impl NodeKind for QuantizedWideNode {}
impl NodeKind for QuantizedWideNode8 {}

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

        /// The order word of direction octant `octant` (see [`octant_orders`]).
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

/// The child words of `children` in slots `0..`, the others 0 (which no leaf word is).
pub(crate) fn child_words<const W: usize>(children: &[(Aabb, u32)]) -> [u32; W] {
    std::array::from_fn(|slot| children.get(slot).map_or(0, |&(_, word)| word))
}

/// The slots of order word `order` of a node of `width` slots, nearest first (see
/// [`octant_orders`]); every slot once.
#[inline(always)]
pub(crate) fn order_slots(order: u32, width: usize) -> impl DoubleEndedIterator<Item = usize> {
    let bits = slot_bits(width);
    (0..width as u32).map(move |k| (order >> (bits * k)) as usize & (width - 1))
}

/// Bits of a slot number in an order word of a node of `width` slots.
const fn slot_bits(width: usize) -> u32 {
    width.trailing_zeros()
}

/// The order word listing a node's `width` slots in slot order.
const fn slot_order(width: usize) -> u32 {
    let mut word = 0;
    let mut slot = 0;
    while slot < width {
        word |= (slot as u32) << (slot_bits(width) * slot as u32);
        slot += 1;
    }
    word
}

/// Per direction octant, the order word of a node of `width` slots whose used slots
/// `0..children.len()` hold `children`: the used slots sorted by the projection of their boxes'
/// centres on the octant's diagonal (ties by slot), then the unused ones, position `k` in bits
/// `k * b..(k + 1) * b` for `b = log2(width)` (read back by [`order_slots`]). A walk pushes the
/// slots in this order (precomputed node sorting, seed 000), so every position names each slot
/// once.
pub(crate) fn octant_orders(children: &[(Aabb, u32)], width: usize) -> [u32; 8] {
    debug_assert!(width.is_power_of_two() && children.len() <= width);
    let centres: Vec<Vec3> = children.iter().map(|(bounds, _)| bounds.center()).collect();
    std::array::from_fn(|octant| {
        let diagonal = octant_diagonal(octant as u32);
        let along = |slot: usize| centres[slot].dot(diagonal);
        let mut slots: Vec<usize> = (0..centres.len()).collect();
        slots.sort_by(|&a, &b| along(a).total_cmp(&along(b)).then(a.cmp(&b)));
        slots.extend(centres.len()..width);
        slots
            .iter()
            .rev()
            .fold(0, |word, &slot| (word << slot_bits(width)) | slot as u32)
    })
}
