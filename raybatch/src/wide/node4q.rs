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
//! A plane decodes as `origin + steps * step` in f32: the product is exact (`steps` < 256, the
//! step a power of two), the sum is rounded, and the build picks each minimum's steps as the
//! largest whose decoded plane is at or below the true one, each maximum's as the smallest at or
//! above, with that same arithmetic. So a decoded box always holds its child's box: a ray that
//! reaches a triangle enters every box on the way, and enters it no later than the exact box,
//! so the walk skips nothing the full-precision tree would visit and the answers are the same
//! (the tie rule decides among hits, never the boxes). The boxes are up to a 255th of the
//! node's extent larger, so a ray enters a few more of them.
//!
//! The box test decodes the six planes and runs the 4-wide node's slab test on them
//! (`WideRay::hits_planes`), lane by lane the scalar slab test on the decoded box; the
//! stream engine decodes a node once for all the rays that reach it.

use glam::{Vec3, Vec4};

use super::kind::layout::Layout;
use super::kind::octant_orders;
use super::node::{Planes, WideRay};
use super::stack::Stack;
use super::stream::StreamPlanes;
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

/// The grid step of biased exponent `exponent` (1..=254: a normal power of two).
#[inline(always)]
fn step(exponent: u8) -> f32 {
    f32::from_bits(u32::from(exponent) << 23)
}

/// Plane `steps` of the grid at `origin` with step `step`: the decode, the same arithmetic at
/// build and at test time.
#[inline(always)]
fn plane(origin: f32, steps: u8, step: f32) -> f32 {
    origin + f32::from(steps) * step
}

/// The smallest biased exponent whose 255 steps from `origin` reach `max` (decoded as the walk
/// decodes), at most 254.
fn exponent_for(origin: f32, max: f32) -> u8 {
    let extent = max - origin;
    // A power of two about extent / 255 (exponent bits of the quotient), then upwards until
    // the top plane holds `max`: the guess is at most a step or two below.
    let guess = ((extent / 255.0).to_bits() >> 23) as u8;
    let mut exponent = guess.saturating_sub(1).max(1);
    while exponent < 254 && plane(origin, 255, step(exponent)) < max {
        exponent += 1;
    }
    exponent
}

/// The largest steps whose plane lies at or below `value` (0 decodes to `origin` <= `value`).
fn steps_below(origin: f32, step: f32, value: f32) -> u8 {
    let guess = ((value - origin) / step).floor().clamp(0.0, 255.0) as u8;
    let mut steps = guess.saturating_add(1);
    while steps > 0 && plane(origin, steps, step) > value {
        steps -= 1;
    }
    steps
}

/// The smallest steps whose plane lies at or above `value` (255 does, by the exponent's choice;
/// where even it does not, the exponent hit its cap and 255 is the nearest).
fn steps_above(origin: f32, step: f32, value: f32) -> u8 {
    let guess = ((value - origin) / step).ceil().clamp(0.0, 255.0) as u8;
    let mut steps = guess.saturating_sub(1);
    while steps < 255 && plane(origin, steps, step) < value {
        steps += 1;
    }
    steps
}

impl QuantizedWideNode {
    /// The grid step of each axis.
    #[inline(always)]
    fn step_sizes(&self) -> [f32; 3] {
        self.exponent.map(step)
    }

    /// The decoded box of slot `slot` (it holds the child's exact box).
    pub(crate) fn slot_bounds(&self, slot: usize) -> Aabb {
        let steps = self.step_sizes();
        let corner = |rows: &[[u8; WIDTH]; 3]| {
            Vec3::from_array(std::array::from_fn(|a| {
                plane(self.origin[a], rows[a][slot], steps[a])
            }))
        };
        Aabb::new(corner(&self.low), corner(&self.high))
    }

    /// The six decoded planes of all four slots: minima then maxima, per axis.
    #[inline(always)]
    fn decoded(&self) -> [Vec4; 6] {
        let steps = self.step_sizes();
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

    /// The planes as rays of octant `octant` meet them (see [`super::node::WideNode::planes`]).
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
    fn hits(&self, ray: &WideRay, tmax: f32) -> (u32, Vec4) {
        let (mask, entries) = ray.hits_planes(&self.planes(ray.octant), tmax);
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
        let union = children
            .iter()
            .fold(Aabb::EMPTY, |all, (bounds, _)| all.union(*bounds));
        let mut node = QuantizedWideNode {
            origin: [0.0; 3],
            exponent: [127; 3],
            used: children.len() as u8,
            low: [[0; WIDTH]; 3],
            high: [[0; WIDTH]; 3],
            child: [0; WIDTH],
            order: [0b11_10_01_00; 8],
        };
        if children.is_empty() {
            return node;
        }
        for a in 0..3 {
            let origin = union.min[a];
            let exponent = exponent_for(origin, union.max[a]);
            node.origin[a] = origin;
            node.exponent[a] = exponent;
            for (slot, (bounds, _)) in children.iter().enumerate() {
                node.low[a][slot] = steps_below(origin, step(exponent), bounds.min[a]);
                node.high[a][slot] = steps_above(origin, step(exponent), bounds.max[a]);
            }
        }
        for (slot, (_, word)) in children.iter().enumerate() {
            node.child[slot] = *word;
        }
        node.order = octant_orders(children, WIDTH).map(|word| word as u8);
        node
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;
    use crate::wide::node::BoxSimd;
    use crate::wide::node::tests::box_test_case;

    /// Every decoded box holds its child's box and is at most one step larger on each side,
    /// over random boxes, flat ones, large offsets and tiny extents.
    #[test]
    fn decoded_boxes_hold_the_exact_ones() {
        let mut rng = TestRng::new(21);
        for round in 0..5_000 {
            let offset = [0.0, 1e3, -3e5, 7e6][round % 4];
            let size = [1e-6, 1.0, 50.0, 1e4][(round / 4) % 4];
            let used = 1 + round % WIDTH;
            let children: Vec<(Aabb, u32)> = (0..used)
                .map(|slot| {
                    let a = rng.vec3(size) + offset;
                    let mut b = a + rng.vec3(size).abs();
                    if slot == 1 {
                        b.y = a.y;
                    }
                    (Aabb::new(a.min(b), a.max(b)), slot as u32)
                })
                .collect();
            let node = QuantizedWideNode::from_children(&children);
            let steps = node.step_sizes();
            for (slot, (exact, word)) in children.iter().enumerate() {
                let decoded = node.slot_bounds(slot);
                assert_eq!(node.child[slot], *word);
                for (a, step) in steps.iter().enumerate() {
                    assert!(decoded.min[a] <= exact.min[a], "{decoded:?} {exact:?}");
                    assert!(decoded.max[a] >= exact.max[a], "{decoded:?} {exact:?}");
                    // Within a step (and the rounding of the sum) of the exact planes.
                    let slack = step * 1.01 + exact.max[a].abs() * 2.0 * f32::EPSILON;
                    assert!(
                        exact.min[a] - decoded.min[a] <= slack,
                        "{decoded:?} {exact:?}"
                    );
                    assert!(
                        decoded.max[a] - exact.max[a] <= slack,
                        "{decoded:?} {exact:?}"
                    );
                }
            }
        }
    }

    /// The node's box test is, lane by lane, the scalar slab test on the decoded boxes; unused
    /// slots are never hit.
    #[test]
    fn lanes_match_the_scalar_box_test_on_the_decoded_boxes() {
        let mut rng = TestRng::new(22);
        for round in 0..20_000 {
            let slots = 1 + round % WIDTH;
            let Some((boxes, ray, tmax)) = box_test_case(&mut rng, round, slots) else {
                continue;
            };
            let children: Vec<(Aabb, u32)> = boxes.iter().map(|&b| (b, 0)).collect();
            let node = QuantizedWideNode::from_children(&children);
            let wide_ray = WideRay::new(&ray, BoxSimd::PORTABLE);
            let (mask, entries) = node.hits(&wide_ray, tmax);
            for slot in 0..WIDTH {
                let scalar = if slot < slots {
                    node.slot_bounds(slot).entry(&ray, tmax)
                } else {
                    f32::INFINITY
                };
                let hit = mask & (1 << slot) != 0;
                assert_eq!(hit, scalar < f32::INFINITY, "slot {slot}, {ray:?}");
                if hit {
                    assert_eq!(entries[slot], scalar, "slot {slot} of {boxes:?}, {ray:?}");
                }
                // A ray that enters the exact box enters the decoded one, no later.
                if slot < slots {
                    let exact = boxes[slot].entry(&ray, tmax);
                    if exact < f32::INFINITY {
                        assert!(hit && entries[slot] <= exact, "slot {slot}, {ray:?}");
                    }
                }
            }
        }
    }
}
