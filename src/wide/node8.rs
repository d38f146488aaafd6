//! The 8-wide node and its box test: eight children's boxes in structure-of-arrays form,
//! tested against one ray in one AVX2 pass (two 4-lane passes without AVX2).
//!
//! ```text
//! bounds: [[f32; 8]; 6]  min x, min y, min z, max x, max y, max z, one lane per child
//! child:  [u32; 8]       child words, as in the 4-wide node
//! order:  [u32; 8]       per ray octant, the used slots nearest first, then the unused
//!                        (3 bits each, position k in bits 3k..3k + 3)
//! ```
//! 256 bytes, four cache lines, aligned to 64. Unused slots hold empty boxes, which no ray
//! enters. Each lane does the scalar slab test's arithmetic ([`crate::geom::aabb::box_entry`])
//! exactly as the 4-wide node's lanes do ([`super::slabs`] says how); the AVX2 version and its
//! portable twin (the 4-wide test on each half) are compared by this module's tests.

use glam::Vec3;

use super::kind::NodeKind;
use super::kind::layout::Layout;
use super::order::octant_orders;
use super::ray::{StreamPlanes, WideRay};
use super::rows::PlaneRows8;
use super::slabs::slabs_by_halves;
use super::stack::Stack;
use crate::bvh::LeafCopy;
use crate::geom::Aabb;
use crate::prefetch::prefetch;

/// Children per node.
pub const WIDTH: usize = 8;

/// One 8-wide node (see the module docs).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct WideNode8 {
    /// Child boxes by coordinate: min x, min y, min z, max x, max y, max z.
    pub(crate) bounds: PlaneRows8,
    /// Child words.
    pub(crate) child: [u32; WIDTH],
    /// Per octant, every slot, the used ones nearest first (3 bits each, see
    /// `order::octant_orders`).
    order: [u32; 8],
}

// 256 bytes, and each row of `bounds` 32-byte aligned (the AVX2 test's aligned loads).
const _: () =
    assert!(size_of::<WideNode8>() == 256 && std::mem::offset_of!(WideNode8, bounds) % 32 == 0);

impl WideNode8 {
    /// A node whose slots all hold empty boxes (which no ray enters).
    pub(crate) fn empty() -> Self {
        let (lo, hi) = ([f32::INFINITY; WIDTH], [f32::NEG_INFINITY; WIDTH]);
        Self {
            bounds: PlaneRows8([lo, lo, lo, hi, hi, hi]),
            child: [0; WIDTH],
            order: [0; 8],
        }
    }

    /// Puts `bounds` and `word` in slot `slot` (slots are filled from 0 up).
    pub(crate) fn set(&mut self, slot: usize, bounds: &Aabb, word: u32) {
        for axis in 0..3 {
            self.bounds[axis][slot] = bounds.min[axis];
            self.bounds[3 + axis][slot] = bounds.max[axis];
        }
        self.child[slot] = word;
    }

    /// The number of slots in use (slots are filled from 0 up; an unused slot's box is empty).
    #[inline(always)]
    fn used_slots(&self) -> usize {
        (0..WIDTH).take_while(|&slot| self.used(slot)).count()
    }

    /// True if slot `slot` holds a box (an unused slot's is empty).
    fn used(&self, slot: usize) -> bool {
        self.bounds[0][slot] <= self.bounds[3][slot]
    }

    /// The order word of direction octant `octant`.
    #[inline(always)]
    pub(crate) fn order(&self, octant: u32) -> u32 {
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

    /// Which child boxes the ray enters within `[tmin, tmax]` (bit `k` for slot `k`) and the
    /// entry distances (meaningful for those slots only), lane by lane the scalar slab test.
    #[inline(always)]
    pub(crate) fn hits(&self, ray: &WideRay, tmax: f32) -> (u32, [f32; WIDTH]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = ray.simd.avx2() {
            return super::simd::slabs8(avx2, ray, &self.bounds, tmax);
        }
        self.hits_by_halves(ray, tmax)
    }

    /// [`WideNode8::hits`] as two 4-wide box tests: the portable twin of the AVX2 version.
    #[inline(always)]
    pub(crate) fn hits_by_halves(&self, ray: &WideRay, tmax: f32) -> (u32, [f32; WIDTH]) {
        slabs_by_halves(&self.bounds, ray, tmax)
    }
}

#[allow(private_interfaces)]
impl Layout for WideNode8 {
    const WIDTH: usize = WIDTH;
    const NAME: &'static str = "bvh8";
    const FORMAT: &'static str = "8-wide nodes (256 B)";
    const LEAF_COPY: LeafCopy = LeafCopy::Indices;

    fn from_children(children: &[(Aabb, u32)]) -> Self {
        let mut node = WideNode8::empty();
        for (slot, (bounds, word)) in children.iter().enumerate() {
            node.set(slot, bounds, *word);
        }
        node.order = octant_orders(children, WIDTH);
        node
    }

    #[inline(always)]
    fn push_hits(&self, ray: &WideRay, tmax: f32, stack: &mut Stack) {
        let (mask, entries) = self.hits(ray, tmax);
        stack.push_hits::<8>(mask, &entries, &self.child, self.order(ray.octant));
    }

    #[inline(always)]
    fn prefetch(&self) {
        prefetch(&self.bounds[0]);
        prefetch(&self.bounds[2]);
        prefetch(&self.bounds[4]);
        prefetch(&self.child);
    }

    fn stream_planes(&self, octant: u32) -> StreamPlanes {
        StreamPlanes::from_rows(&self.bounds, octant)
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
        WideNode8::used_slots(self)
    }

    #[inline(always)]
    fn order_word(&self, octant: u32) -> u32 {
        self.order(octant)
    }
}

impl NodeKind for WideNode8 {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;
    use crate::wide::node4::tests::box_test_case;
    use crate::wide::ray::BoxSimd;

    /// The order words list the used slots nearest first along each octant's diagonal, then
    /// the unused ones, each slot once.
    #[test]
    fn children_are_ordered_per_octant() {
        // Five children along x at x = 4, 0, 3, 1, 2 (slots 0-4); slots 5-7 unused.
        let children: Vec<(Aabb, u32)> = [4.0f32, 0.0, 3.0, 1.0, 2.0]
            .into_iter()
            .enumerate()
            .map(|(slot, x)| {
                let min = Vec3::new(x, 0.0, 0.0);
                (Aabb::new(min, min + 0.5), slot as u32)
            })
            .collect();
        let node = WideNode8::from_children(&children);
        let order = |octant: u32| -> Vec<u32> {
            (0..WIDTH as u32)
                .map(|k| (node.order(octant) >> (3 * k)) & 7)
                .collect()
        };
        assert_eq!(order(0), [1, 3, 4, 2, 0, 5, 6, 7]);
        assert_eq!(order(1), [0, 2, 4, 3, 1, 5, 6, 7]);
        // A stream of one octant visits the slots in that octant's order; mixed octants in
        // slot order.
        assert_eq!(node.stream_order(1 << 1), node.order(1));
        let slot_order: Vec<u32> = (0..8)
            .map(|k| (node.stream_order(0) >> (3 * k)) & 7)
            .collect();
        assert_eq!(slot_order, [0, 1, 2, 3, 4, 5, 6, 7]);
        assert_eq!(node.used_slots(), 5);
    }

    /// Every lane of both versions (AVX2 where the CPU has it, and two 4-wide halves) agrees
    /// with the scalar slab test: same hit or miss, same entry distance.
    #[test]
    fn lanes_match_the_scalar_box_test() {
        let mut rng = TestRng::new(12);
        for round in 0..20_000 {
            let slots = 1 + round % WIDTH;
            let Some((boxes, ray, tmax)) = box_test_case(&mut rng, round, slots) else {
                continue;
            };
            let mut node = WideNode8::empty();
            for (slot, bounds) in boxes.iter().enumerate() {
                node.set(slot, bounds, slot as u32);
            }
            let wide_ray = WideRay::new(&ray, BoxSimd::detect(true));
            let (mask, entries) = node.hits(&wide_ray, tmax);
            let (halves_mask, halves_entries) = node.hits_by_halves(&wide_ray, tmax);
            assert_eq!(mask, halves_mask, "{boxes:?}, {ray:?}");
            for slot in 0..WIDTH {
                let scalar = boxes
                    .get(slot)
                    .map_or(f32::INFINITY, |b| b.entry(&ray, tmax));
                let hit = mask & (1 << slot) != 0;
                assert_eq!(hit, scalar < f32::INFINITY, "slot {slot}, {ray:?}");
                if hit {
                    assert_eq!(entries[slot], scalar, "slot {slot} of {boxes:?}, {ray:?}");
                    assert_eq!(halves_entries[slot], scalar, "slot {slot}, {ray:?}");
                }
            }
        }
    }
}
