//! The 4-wide node and its box test: the four children's boxes in structure-of-arrays form,
//! tested against one ray in one SIMD pass.
//!
//! ```text
//! bounds: [[f32; 4]; 6]  min x, min y, min z, max x, max y, max z, one lane per child
//! child:  [u32; 4]       internal child: its node index (bit 31 clear)
//!                        leaf child: the leaf word of `bvh::nodes` (bit 31 set, count, first slot)
//! order:  [u8; 8]        per ray octant, the used slots nearest first, then the unused
//!                        (2 bits each)
//! used:   u8             slots in use (0..used; the others are unused)
//! ```
//! 121 bytes, aligned to 128 (two cache lines). An unused slot has an empty box
//! (`min = +inf`, `max = -inf`), which no ray enters, so the box test needs no slot count.
//!
//! The order bytes are precomputed node sorting for four children: for each
//! direction octant, the children sorted by the projection of their centres on the octant's
//! diagonal. Both the stream engine and the one-ray loop read them to walk nearer children
//! first (`single` says why the loop does not sort by entry distance).
//!
//! The box test is [`super::slabs::hits_planes`] on the planes of the ray's octant
//! ([`WideNode::planes`]).

use glam::{Vec3, Vec4};

use super::kind::NodeKind;
use super::kind::layout::Layout;
use super::order::octant_orders;
use super::ray::{Planes, StreamPlanes, WideRay};
use super::slabs::hits_planes;
use super::stack::Stack;
use crate::bvh::LeafCopy;
use crate::geom::Aabb;
use crate::prefetch::prefetch;

/// Children per node.
pub const WIDTH: usize = 4;

/// One 4-wide node (see the module docs).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(128))]
pub struct WideNode {
    /// Child boxes by coordinate: min x, min y, min z, max x, max y, max z.
    pub(crate) bounds: [Vec4; 6],
    /// Child words.
    pub(crate) child: [u32; WIDTH],
    /// Per octant, the used slots nearest first, slot `k` of the order in bits `2k..2k + 2`.
    order: [u8; 8],
    /// Number of used slots (they are `0..used`).
    used: u8,
}

impl WideNode {
    /// A node whose slots all hold empty boxes.
    pub(crate) fn empty() -> Self {
        Self {
            bounds: [
                Vec4::INFINITY,
                Vec4::INFINITY,
                Vec4::INFINITY,
                Vec4::NEG_INFINITY,
                Vec4::NEG_INFINITY,
                Vec4::NEG_INFINITY,
            ],
            child: [0; WIDTH],
            order: [0; 8],
            used: 0,
        }
    }

    /// Puts `bounds` and `word` in slot `slot` (slots are filled from 0 up).
    pub(crate) fn set(&mut self, slot: usize, bounds: &Aabb, word: u32) {
        for axis in 0..3 {
            self.bounds[axis][slot] = bounds.min[axis];
            self.bounds[3 + axis][slot] = bounds.max[axis];
        }
        self.child[slot] = word;
        self.used = self.used.max(slot as u8 + 1);
    }

    /// The order byte of direction octant `octant`: a permutation of the four slots, the used
    /// ones nearest first, then the unused ones, whose empty boxes no ray enters
    /// ([`octant_orders`]).
    #[inline(always)]
    pub(crate) fn order(&self, octant: u32) -> u8 {
        self.order[octant as usize & 7]
    }

    /// The box of slot `slot`.
    pub(crate) fn slot_bounds(&self, slot: usize) -> Aabb {
        let b = &self.bounds;
        Aabb::new(
            Vec3::new(b[0][slot], b[1][slot], b[2][slot]),
            Vec3::new(b[3][slot], b[4][slot], b[5][slot]),
        )
    }

    /// The planes for rays whose direction has the sign bits of `octant` (bit `a` set: negative
    /// along axis `a`, as [`crate::geom::octant`] numbers them). A stream grouped by octant
    /// picks them once per node instead of once per ray.
    #[inline(always)]
    pub(crate) fn planes(&self, octant: u32) -> Planes {
        let negative = |axis: usize| (octant >> axis) & 1 != 0;
        let near = |axis: usize| self.bounds[axis + 3 * negative(axis) as usize];
        let far = |axis: usize| self.bounds[axis + 3 * !negative(axis) as usize];
        Planes {
            near: [near(0), near(1), near(2)],
            far: [far(0), far(1), far(2)],
        }
    }

    /// Which child boxes the ray enters within `[tmin, tmax]` (bit `k` for slot `k`) and the
    /// entry distances (meaningful for those slots only), lane by lane the scalar slab test.
    #[inline(always)]
    pub(crate) fn hits(&self, ray: &WideRay, tmax: f32) -> (u32, Vec4) {
        hits_planes(ray, &self.planes(ray.octant), tmax)
    }
}

#[allow(private_interfaces)]
impl Layout for WideNode {
    const WIDTH: usize = WIDTH;
    const NAME: &'static str = "bvh4";
    const FORMAT: &'static str = "4-wide nodes (128 B)";
    const LEAF_COPY: LeafCopy = LeafCopy::Indices;

    fn from_children(children: &[(Aabb, u32)]) -> Self {
        let mut node = WideNode::empty();
        for (slot, (bounds, word)) in children.iter().enumerate() {
            node.set(slot, bounds, *word);
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
        prefetch(&self.bounds[4]);
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

impl NodeKind for WideNode {}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geom::{PreparedRay, Ray};
    use crate::test_support::TestRng;
    use crate::wide::ray::BoxSimd;
    use crate::wide::slabs::slabs_portable;

    /// The order bytes list the used slots nearest first along each octant's diagonal, and
    /// slot order for mixed octants.
    #[test]
    fn children_are_ordered_per_octant() {
        // Three children along x at x = 2, 0, 1 (slots 0, 1, 2); slot 3 unused.
        let children: Vec<(Aabb, u32)> = [2.0f32, 0.0, 1.0]
            .into_iter()
            .enumerate()
            .map(|(slot, x)| {
                let min = glam::Vec3::new(x, 0.0, 0.0);
                (Aabb::new(min, min + 0.5), slot as u32 + 10)
            })
            .collect();
        let node = WideNode::from_children(&children);
        let order = |mask: u8| -> Vec<u32> {
            let word = node.stream_order(mask);
            (0..WIDTH as u32).map(|k| (word >> (2 * k)) & 3).collect()
        };
        // Octant 0: +x, +y, +z; octant 1 (bit 0): -x. The unused slot comes last.
        assert_eq!(order(1 << 0), [1, 2, 0, 3]);
        assert_eq!(order(1 << 1), [0, 2, 1, 3]);
        assert_eq!(order(0), [0, 1, 2, 3]);
        assert_eq!(node.used_slots(), 3);
    }

    /// Round `round` of a box-test comparison: `slots` random boxes (flat and degenerate ones
    /// among them) and a ray against them (some starting on a box's plane, some with a zero
    /// direction component of either sign, finite and infinite ranges), with its range end;
    /// `None` when the ray is invalid. Shared with the 8-wide node's tests.
    pub(crate) fn box_test_case(
        rng: &mut TestRng,
        round: usize,
        slots: usize,
    ) -> Option<(Vec<Aabb>, PreparedRay, f32)> {
        let boxes: Vec<Aabb> = (0..slots)
            .map(|slot| {
                let a = rng.vec3(2.0);
                let mut b = a + rng.vec3(1.0).abs() * if slot == 1 { 0.0 } else { 1.0 };
                if slot == 2 {
                    b.y = a.y;
                }
                Aabb::new(a.min(b), a.max(b))
            })
            .collect();
        let mut origin = rng.vec3(3.0);
        if round.is_multiple_of(7) {
            origin.x = boxes[0].min.x;
        }
        let mut dir = rng.vec3(1.0);
        if round.is_multiple_of(5) {
            dir.y = if round.is_multiple_of(10) { 0.0 } else { -0.0 };
        }
        let tmax = if round.is_multiple_of(3) {
            f32::INFINITY
        } else {
            rng.range(0.0, 5.0)
        };
        let ray = PreparedRay::new(&Ray::with_range(origin, dir, 0.0, tmax))?;
        Some((boxes, ray, tmax))
    }

    /// Every lane of both versions (SSE where built for x86-64, and the portable one) agrees
    /// with the scalar slab test: same hit or miss, same entry distance.
    #[test]
    fn lanes_match_the_scalar_box_test() {
        let mut rng = TestRng::new(11);
        for round in 0..20_000 {
            let slots = 1 + round % WIDTH;
            let Some((boxes, ray, tmax)) = box_test_case(&mut rng, round, slots) else {
                continue;
            };
            let mut node = WideNode::empty();
            for (slot, bounds) in boxes.iter().enumerate() {
                node.set(slot, bounds, slot as u32);
            }
            let wide_ray = WideRay::new(&ray, BoxSimd::detect(true));
            let (mask, entries) = node.hits(&wide_ray, tmax);
            let planes = node.planes(wide_ray.octant);
            let (portable_mask, portable_entries) = slabs_portable(&wide_ray, &planes, tmax);
            assert_eq!(mask, portable_mask, "{boxes:?}, {ray:?}");
            for slot in 0..WIDTH {
                let scalar = if slot < slots {
                    boxes[slot].entry(&ray, tmax)
                } else {
                    f32::INFINITY
                };
                let hit = mask & (1 << slot) != 0;
                assert_eq!(
                    hit,
                    scalar < f32::INFINITY,
                    "slot {slot} of {boxes:?}, {ray:?}"
                );
                if hit {
                    assert_eq!(entries[slot], scalar, "slot {slot} of {boxes:?}, {ray:?}");
                    assert_eq!(portable_entries[slot], scalar, "slot {slot}, {ray:?}");
                }
            }
        }
    }
}
