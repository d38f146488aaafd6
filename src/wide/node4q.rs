//! The quantized 4-wide node: the 4-wide node's children in one 64-byte cache line instead of
//! two, their boxes stored as 8-bit steps on a per-node grid.
//!
//! ```text
//! origin:   [f32; 3]      the grid's corner: the node's box minimum (the union of its children)
//! exponent: [u8; 3]       per axis, the grid step 2^(exponent - 127) (an f32's exponent bits)
//! used:     u8            slots in use (0..used)
//! low:      [[u8; 4]; 3]  per axis and slot, the steps of the box's minimum
//! high:     [[u8; 4]; 3]  per axis and slot, the steps of its maximum
//! child:    [u32; 4]      child words, as in the 4-wide node
//! order:    [u8; 8]       per ray octant, the slots nearest first (2 bits each)
//! ```
//!
//! The grid and why a decoded box always holds its child's box (so the answers are those of
//! the full-precision tree) are in `wide::quantize`.
//!
//! The box test decodes the six planes and runs the 4-wide node's slab test on them
//! (`slabs::hits_planes`), lane by lane the scalar slab test on the decoded box; the
//! stream engine decodes a node once for all the rays that reach it.

use glam::Vec4;

use super::kind::NodeKind;
use super::kind::layout::Layout;
use super::order::{child_words, octant_orders};
use super::quantize::Grid;
use super::ray::{Planes, StreamPlanes, WideRay};
use super::slabs::hits_planes;
use super::stack::Stack;
use crate::bvh::LeafCopy;
use crate::geom::Aabb;
use crate::prefetch::prefetch;

/// Children per node.
pub const WIDTH: usize = 4;

/// One quantized 4-wide node (see the module docs).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct QuantizedWideNode {
    origin: [f32; 3],
    exponent: [u8; 3],
    used: u8,
    low: [[u8; WIDTH]; 3],
    high: [[u8; WIDTH]; 3],
    child: [u32; WIDTH],
    order: [u8; 8],
}

const _: () = assert!(size_of::<QuantizedWideNode>() == 64);

impl QuantizedWideNode {
    /// The node's grid.
    #[inline(always)]
    pub(crate) fn grid(&self) -> Grid {
        Grid {
            origin: self.origin,
            exponent: self.exponent,
        }
    }

    /// The decoded box of slot `slot` (it holds the child's exact box).
    pub(crate) fn slot_bounds(&self, slot: usize) -> Aabb {
        self.grid().decode_slot((&self.low, &self.high), slot)
    }

    /// The six decoded planes of all four slots: minima then maxima, per axis.
    #[inline(always)]
    fn decoded(&self) -> [Vec4; 6] {
        let steps = self.grid().steps();
        let row = |rows: &[[u8; WIDTH]; 3], a: usize| {
            let steps_of = Vec4::from_array(rows[a].map(f32::from));
            Vec4::splat(self.origin[a]) + steps_of * Vec4::splat(steps[a])
        };
        [
            row(&self.low, 0),
            row(&self.low, 1),
            row(&self.low, 2),
            row(&self.high, 0),
            row(&self.high, 1),
            row(&self.high, 2),
        ]
    }

    /// The planes as rays of octant `octant` meet them (see [`super::node4::WideNode::planes`]).
    #[inline(always)]
    fn planes(&self, octant: u32) -> Planes {
        let rows = self.decoded();
        let negative = |axis: usize| ((octant >> axis) & 1) as usize;
        Planes {
            near: std::array::from_fn(|a| rows[a + 3 * negative(a)]),
            far: std::array::from_fn(|a| rows[a + 3 * (1 - negative(a))]),
        }
    }

    /// Which used slots' boxes the ray enters within `[tmin, tmax]`, and the entry distances.
    #[inline(always)]
    pub(crate) fn hits(&self, ray: &WideRay, tmax: f32) -> (u32, Vec4) {
        let (mask, entries) = hits_planes(ray, &self.planes(ray.octant), tmax);
        (mask & ((1 << self.used) - 1), entries)
    }

    /// The order byte of direction octant `octant`.
    #[inline(always)]
    fn order(&self, octant: u32) -> u8 {
        self.order[octant as usize & 7]
    }
}

#[allow(private_interfaces)]
impl Layout for QuantizedWideNode {
    const WIDTH: usize = WIDTH;
    const NAME: &'static str = "bvh4q";
    const FORMAT: &'static str = "quantized 4-wide nodes (64 B)";
    // The index copy (8 B a triangle more than the ids alone) would add about two thirds to
    // the tree's 11.3-11.9 B a triangle.
    const LEAF_COPY: LeafCopy = LeafCopy::Nothing;

    fn from_children(children: &[(Aabb, u32)]) -> Self {
        debug_assert!(children.len() <= WIDTH);
        let grid = Grid::around(children);
        let (low, high) = grid.slot_steps(children);
        QuantizedWideNode {
            origin: grid.origin,
            exponent: grid.exponent,
            used: children.len() as u8,
            low,
            high,
            child: child_words(children),
            order: octant_orders(children, WIDTH).map(|word| word as u8),
        }
    }

    #[inline(always)]
    fn push_hits(&self, ray: &WideRay, tmax: f32, stack: &mut Stack) {
        let (mask, entries) = self.hits(ray, tmax);
        let order = u32::from(self.order(ray.octant));
        stack.push_hits::<4>(mask, &entries.to_array(), &self.child, order);
    }

    #[inline(always)]
    fn prefetch(&self) {
        prefetch(self);
    }

    fn stream_planes(&self, octant: u32) -> StreamPlanes {
        StreamPlanes::from_four(&self.planes(octant))
    }

    #[inline(always)]
    fn ray_mask(&self, ray: &WideRay, tmax: f32) -> u32 {
        self.hits(ray, tmax).0
    }

    #[inline(always)]
    fn child(&self, slot: usize) -> u32 {
        self.child[slot]
    }

    fn children_mut(&mut self) -> &mut [u32] {
        &mut self.child
    }

    fn child_bounds(&self, slot: usize) -> Aabb {
        self.slot_bounds(slot)
    }

    #[inline(always)]
    fn used_slots(&self) -> usize {
        self.used as usize
    }

    #[inline(always)]
    fn order_word(&self, octant: u32) -> u32 {
        u32::from(self.order(octant))
    }
}

impl NodeKind for QuantizedWideNode {}
