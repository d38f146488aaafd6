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
//! The order bytes are precomputed node sorting (seed 000) for four children: for each
//! direction octant, the children sorted by the projection of their centres on the octant's
//! diagonal. Both the stream engine and the one-ray loop read them to walk nearer children
//! first (`single` says why the loop does not sort by entry distance).
//!
//! The lanes use glam's `Vec4` (SSE2 on x86-64, NEON on aarch64, scalar elsewhere) and do the
//! scalar slab test's arithmetic lane by lane ([`crate::geom::aabb::box_entry`]): the same
//! near/far plane choice by the direction's sign, the same products in the same order without
//! FMA, the same exit scaling, and the same NaN-safe compare-and-select fold. A lane misses
//! exactly when the scalar test misses and enters at the same distance (a test checks it).

use glam::{Vec3, Vec4};

use super::kind::layout::Layout;
use super::kind::octant_orders;
use super::stack::Stack;
use super::stream::StreamPlanes;
use crate::bvh::LeafCopy;
use crate::geom::aabb::EXIT_SCALE;
use crate::geom::{Aabb, PreparedRay};
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
}

/// A node's six planes as one ray (or a stream of rays of one direction octant) meets them:
/// per axis the near plane (the max plane when the direction is negative) and the far plane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Planes {
    pub(crate) near: [Vec4; 3],
    pub(crate) far: [Vec4; 3],
}

impl WideNode {
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
}

/// What the 8-lane box test may use: the AVX2 token where the CPU has AVX2 and the loop's
/// copy may use it (x86-64), nothing elsewhere. Found once per loop, not per ray.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BoxSimd {
    #[cfg(target_arch = "x86_64")]
    avx2: Option<crate::x86::Avx2>,
}

impl BoxSimd {
    /// The portable box test: the loops' baseline copies, and the 4-wide tree's loops (whose
    /// box test needs no token).
    pub(crate) const PORTABLE: BoxSimd = BoxSimd {
        #[cfg(target_arch = "x86_64")]
        avx2: None,
    };

    /// AVX2 if `wanted` and the CPU has it, else [`BoxSimd::PORTABLE`].
    pub(crate) fn detect(wanted: bool) -> Self {
        #[cfg(target_arch = "x86_64")]
        if wanted {
            return BoxSimd {
                avx2: crate::x86::Avx2::detect(),
            };
        }
        let _ = wanted;
        Self::PORTABLE
    }

    /// The AVX2 token, if the 8-lane test may use it.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn avx2(self) -> Option<crate::x86::Avx2> {
        self.avx2
    }
}

/// Per-ray constants of the box tests (4 and 8 lanes), computed once per ray.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WideRay {
    pub(crate) origin: [Vec4; 3],
    pub(crate) inv_dir: [Vec4; 3],
    /// The ray's direction octant ([`crate::geom::octant`] of the sign bits of `inv_dir`,
    /// which are the direction's): which planes of a node are near.
    pub(crate) octant: u32,
    pub(crate) tmin: Vec4,
    /// What the 8-wide node's box test may use (read on x86-64 only: elsewhere there is
    /// nothing to choose).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) simd: BoxSimd,
}

impl WideRay {
    /// The constants of `ray`, for box tests that may use `simd`.
    #[inline(always)]
    pub(crate) fn new(ray: &PreparedRay, simd: BoxSimd) -> Self {
        let (origin, inv_dir, tmin) = (ray.origin, ray.inv_dir, ray.tmin);
        let splat = |v: Vec3| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        Self {
            origin: splat(origin),
            inv_dir: splat(inv_dir),
            octant: (inv_dir.x < 0.0) as u32
                | ((inv_dir.y < 0.0) as u32) << 1
                | ((inv_dir.z < 0.0) as u32) << 2,
            tmin: Vec4::splat(tmin),
            simd,
        }
    }

    /// Which child boxes the ray enters within `[tmin, tmax]` (bit `k` for slot `k`) and the
    /// entry distances (meaningful for those slots only), lane by lane the scalar slab test.
    #[inline(always)]
    pub(crate) fn hits(&self, node: &WideNode, tmax: f32) -> (u32, Vec4) {
        self.hits_planes(&node.planes(self.octant), tmax)
    }

    /// [`WideRay::hits`] against planes picked beforehand (for this ray's octant).
    #[inline(always)]
    pub(crate) fn hits_planes(&self, planes: &Planes, tmax: f32) -> (u32, Vec4) {
        #[cfg(target_arch = "x86_64")]
        {
            super::simd::slabs(self, planes, tmax)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.slabs_portable(planes, tmax)
        }
    }

    /// [`WideRay::hits_planes`] with glam's `Vec4` only: the portable twin of the SSE version
    /// (used where SSE is not the baseline, and by the tests everywhere).
    #[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
    #[inline(always)]
    pub(crate) fn slabs_portable(&self, planes: &Planes, tmax: f32) -> (u32, Vec4) {
        // Hits have finite `t`, so an infinite entry (a parallel ray below a slab) is a miss.
        let mut near = self.tmin;
        let mut far = Vec4::splat(tmax.min(f32::MAX));
        for axis in 0..3 {
            let (o, inv) = (self.origin[axis], self.inv_dir[axis]);
            let enter = (planes.near[axis] - o) * inv;
            let exit = (planes.far[axis] - o) * inv * EXIT_SCALE;
            // Compare-and-select, so a NaN lane (the ray grazes this slab) leaves the range
            // alone. Folding the axes one by one gives the scalar test's max (min) of the
            // selected values, which never depends on the order.
            near = Vec4::select(enter.cmpgt(near), enter, near);
            far = Vec4::select(exit.cmplt(far), exit, far);
        }
        (near.cmple(far).bitmask(), near)
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
        let (mask, entries) = ray.hits(self, tmax);
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
        ray.hits(self, tmax).0
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geom::Ray;
    use crate::test_support::TestRng;

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
            let (mask, entries) = wide_ray.hits(&node, tmax);
            let planes = node.planes(wide_ray.octant);
            let (portable_mask, portable_entries) = wide_ray.slabs_portable(&planes, tmax);
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
