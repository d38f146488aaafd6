//! What the wide walks need of a node, so that one tree type, one collapse, one one-ray loop,
//! one stream engine and one side-by-side engine serve nodes of four children ([`WideNode`],
//! the default tree) and of eight ([`WideNode8`], for single rays).
//!
//! Eight children take about a third fewer node visits per walk (12.8 -> 8.8 per incoherent
//! fandisk ray; each a dependent load: the one-ray loop is bound by their latency, not by its
//! instruction count), for a wider box test and push. Each layout implements the trait beside
//! its node, in `node.rs` and `node8.rs`.

use std::fmt::Debug;

use super::node::{WideNode, WideRay};
use super::node4q::QuantizedWideNode;
use super::node8::WideNode8;
use super::stack::Stack;
use super::stream::StreamPlanes;
use super::{WideBvh, WideScratch};
use crate::accel::RayStream;
use crate::geom::{Aabb, TriangleTest};
use crate::hit::Visitor;

/// A wide node layout: [`WideNode`] or [`WideNode8`] (sealed: what the walks need of a node
/// is the crate's own, in the private `layout::Layout`).
pub trait NodeKind: layout::Layout + Clone + Copy + Debug + Send + Sync + 'static {}

impl NodeKind for WideNode {}
impl NodeKind for WideNode8 {}
impl NodeKind for QuantizedWideNode {}

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

        /// The box the node's tests use for slot `slot` (it holds the child's box).
        fn child_bounds(&self, slot: usize) -> Aabb;

        /// The number of slots in use (slots are filled from 0 up).
        fn used_slots(&self) -> usize;

        /// Every slot, nearest first for rays of octant mask `octant_mask` (`1 << octant`) or
        /// in slot order for mask 0 (mixed octants), `WIDTH.trailing_zeros()` bits each.
        fn stream_order(&self, octant_mask: u8) -> u32;

        /// Runs a batch's stream of rays through `tree` with the layout's own batched engine,
        /// for the streams its tree does not walk side by side (`WideBvh::walks_side_by_side`).
        fn trace_own_stream<K: TriangleTest, V: Visitor>(
            tree: &WideBvh<Self>,
            stream: &mut RayStream<'_>,
            scratch: &mut WideScratch,
            visitor: &mut V,
        ) where
            Self: NodeKind;
    }
}
