//! The quantized 8-wide node: the 8-wide node's children in two 64-byte cache lines instead
//! of four, their boxes stored as 8-bit steps on a per-node grid (`wide::quantize`, shared with
//! the quantized 4-wide node).
//!
//! ```text
//! origin:   [f32; 3]      the grid's corner: the node's box minimum (the union of its children)
//! exponent: [u8; 3]       per axis, the grid step 2^(exponent - 127) (an f32's exponent bits)
//! used:     u8            slots in use (0..used)
//! low:      [[u8; 8]; 3]  per axis and slot, the steps of the box's minimum
//! high:     [[u8; 8]; 3]  per axis and slot, the steps of its maximum
//! child:    [u32; 8]      child words, as in the 8-wide node
//! order:    [u32; 8]      per ray octant, the slots nearest first (3 bits each)
//! ```
//!
//! 128 bytes, aligned to 64. The box test decodes the six planes of all eight slots (with AVX2:
//! widen eight bytes, convert, multiply by the step, add the origin; the portable twin does
//! the same a lane at a time) and runs the 8-wide node's slab test on them, lane by lane the
//! scalar slab test on the decoded box. Unused slots decode to a point at the origin, so the
//! test masks them off by `used`. The stream engine decodes a node once for all its rays.
//!
//! Half the node bytes of [`super::node8`] for the same visits, plus a few more boxes entered
//! (each decoded box is up to a 255th of the node's extent larger than the exact one).

use super::kind::NodeKind;
use super::kind::layout::Layout;
use super::order::{child_words, octant_orders};
use super::quantize::{Grid, plane};
use super::ray::{StreamPlanes, WideRay};
use super::slabs::slabs_by_halves;
use super::stack::Stack;
use crate::bvh::LeafCopy;
use crate::geom::Aabb;
use crate::prefetch::prefetch;

/// Children per node.
pub const WIDTH: usize = 8;

/// One quantized 8-wide node (see the module docs).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct QuantizedWideNode8 {
    origin: [f32; 3],
    exponent: [u8; 3],
    used: u8,
    pub(crate) low: [[u8; WIDTH]; 3],
    pub(crate) high: [[u8; WIDTH]; 3],
    child: [u32; WIDTH],
    order: [u32; 8],
}

const _: () = assert!(size_of::<QuantizedWideNode8>() == 128);

impl QuantizedWideNode8 {
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

    /// The six decoded planes of all eight slots: minima then maxima, per axis (the layout
    /// of [`super::node8::WideNode8`]'s bounds).
    #[inline(always)]
    pub(crate) fn decoded(&self) -> [[f32; WIDTH]; 6] {
        let steps = self.grid().steps();
        let row = |rows: &[[u8; WIDTH]; 3], a: usize| {
            rows[a].map(|steps_of| plane(self.origin[a], steps_of, steps[a]))
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

    /// Which used slots' boxes the ray enters within `[tmin, tmax]` (bit `k` for slot `k`)
    /// and the entry distances (meaningful for those slots only).
    #[inline(always)]
    pub(crate) fn hits(&self, ray: &WideRay, tmax: f32) -> (u32, [f32; WIDTH]) {
        let used = (1u32 << self.used) - 1;
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = ray.simd.avx2() {
            let node = (self.grid(), &self.low, &self.high);
            let (mask, entries) = super::simd::slabs8q(avx2, ray, node, tmax);
            return (mask & used, entries);
        }
        let (mask, entries) = self.hits_portable(ray, tmax);
        (mask & used, entries)
    }

    /// The portable twin of the AVX2 decode and test: the planes decoded a lane at a time,
    /// then the 8-wide node's test by 4-wide halves (all slots, used or not).
    #[inline(always)]
    pub(crate) fn hits_portable(&self, ray: &WideRay, tmax: f32) -> (u32, [f32; WIDTH]) {
        slabs_by_halves(&self.decoded(), ray, tmax)
    }

    /// The order word of direction octant `octant`.
    #[inline(always)]
    fn order(&self, octant: u32) -> u32 {
        self.order[octant as usize & 7]
    }
}

#[allow(private_interfaces)]
impl Layout for QuantizedWideNode8 {
    const WIDTH: usize = WIDTH;
    const NAME: &'static str = "bvh8q";
    const FORMAT: &'static str = "quantized 8-wide nodes (128 B)";
    // As the quantized 4-wide tree: the index copy would add 8 B a triangle to about 12...
    const LEAF_COPY: LeafCopy = LeafCopy::Nothing;
    // ...except on large trees (over 8 MiB with the mesh), where leaf blocks make each leaf one
    // trip to memory instead of two or three, at about 36 B/tri (the index copy, 20-21 B/tri,
    // where blocks would take more than 38: `wide::leaves`'s budget).
    const LEAF_COPY_LARGE: LeafCopy = LeafCopy::Blocks;

    fn from_children(children: &[(Aabb, u32)]) -> Self {
        debug_assert!(children.len() <= WIDTH);
        let grid = Grid::around(children);
        let (low, high) = grid.slot_steps(children);
        QuantizedWideNode8 {
            origin: grid.origin,
            exponent: grid.exponent,
            used: children.len() as u8,
            low,
            high,
            child: child_words(children),
            order: octant_orders(children, WIDTH),
        }
    }

    #[inline(always)]
    fn push_hits(&self, ray: &WideRay, tmax: f32, stack: &mut Stack) {
        let (mask, entries) = self.hits(ray, tmax);
        stack.push_hits::<8>(mask, &entries, &self.child, self.order(ray.octant));
    }

    #[inline(always)]
    fn prefetch(&self) {
        prefetch(&self.origin);
        prefetch(&self.child);
    }

    fn stream_planes(&self, octant: u32) -> StreamPlanes {
        StreamPlanes::from_rows(&self.decoded(), octant)
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
        self.order(octant)
    }
}

impl NodeKind for QuantizedWideNode8 {}
