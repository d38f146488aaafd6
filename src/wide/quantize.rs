//! The per-node grid of the quantized wide nodes ([`super::node4q`], [`super::node8q`]): each
//! child box stored as 8-bit steps from the node's box minimum, a power-of-two step per axis.
//!
//! A plane decodes as `origin + steps * step` in f32: the product is exact (`steps` < 256, the
//! step a power of two), the sum is rounded. The build picks each minimum's steps as the
//! largest whose decoded plane is at or below the true one, each maximum's as the smallest at
//! or above, with that same arithmetic, so a decoded box always holds its child's box: a ray
//! that reaches a triangle enters every box on the way, no later than the exact box, and the
//! walk skips nothing the full-precision tree would visit (the answers are the same; the tie
//! rule decides among hits, never the boxes). A decoded box is up to a 255th of the node's
//! extent larger on each side, so a ray enters a few more of them.
//!
//! A SIMD decode must round as this one does: a multiply then an add (a fused multiply-add
//! rounds the same sum while the product is exact, but not where it overflows, at exponent 254).

use glam::Vec3;

use crate::geom::Aabb;

/// The grid step of biased exponent `exponent` (1..=254: a normal power of two).
#[inline(always)]
pub(crate) fn step(exponent: u8) -> f32 {
    f32::from_bits(u32::from(exponent) << 23)
}

/// Plane `steps` of the grid at `origin` with step `step`: the decode, the same arithmetic at
/// build and at test time.
#[inline(always)]
pub(crate) fn plane(origin: f32, steps: u8, step: f32) -> f32 {
    origin + f32::from(steps) * step
}

/// A node's grid: its corner and its step per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Grid {
    /// The corner: the minimum of the union of the children's boxes.
    pub(crate) origin: [f32; 3],
    /// Per axis, the biased exponent of the step (see [`step`]).
    pub(crate) exponent: [u8; 3],
}

impl Grid {
    /// The finest grid whose 255 steps from the children's common minimum reach their common
    /// maximum on each axis. No children: a grid at the origin with unit steps.
    pub(crate) fn around(children: &[(Aabb, u32)]) -> Self {
        if children.is_empty() {
            return Grid {
                origin: [0.0; 3],
                exponent: [127; 3],
            };
        }
        let union = children
            .iter()
            .fold(Aabb::EMPTY, |all, (bounds, _)| all.union(*bounds));
        let origin = union.min.to_array();
        Grid {
            origin,
            exponent: std::array::from_fn(|a| exponent_for(origin[a], union.max[a])),
        }
    }

    /// The grid step of each axis.
    #[inline(always)]
    pub(crate) fn steps(&self) -> [f32; 3] {
        self.exponent.map(step)
    }

    /// The box of per-axis steps `low` (its minimum) and `high` (its maximum), decoded.
    pub(crate) fn decode_box(&self, low: [u8; 3], high: [u8; 3]) -> Aabb {
        let steps = self.steps();
        let corner = |at: [u8; 3]| {
            Vec3::from_array(std::array::from_fn(|a| {
                plane(self.origin[a], at[a], steps[a])
            }))
        };
        Aabb::new(corner(low), corner(high))
    }

    /// The rows of a quantized node of `W` slots holding `children`: per axis and slot, the
    /// steps of each child's box minimum, rounded down (`low`), and maximum, rounded up
    /// (`high`); slots past the children hold 0.
    pub(crate) fn slot_steps<const W: usize>(
        &self,
        children: &[(Aabb, u32)],
    ) -> ([[u8; W]; 3], [[u8; W]; 3]) {
        let (mut low, mut high) = ([[0; W]; 3], [[0; W]; 3]);
        for (slot, (bounds, _)) in children.iter().enumerate() {
            for a in 0..3 {
                low[a][slot] = self.steps_below(a, bounds.min[a]);
                high[a][slot] = self.steps_above(a, bounds.max[a]);
            }
        }
        (low, high)
    }

    /// The decoded box of slot `slot` of a quantized node's rows `low` and `high` (it holds the
    /// child's exact box).
    pub(crate) fn decode_slot<const W: usize>(
        &self,
        (low, high): (&[[u8; W]; 3], &[[u8; W]; 3]),
        slot: usize,
    ) -> Aabb {
        let at = |rows: &[[u8; W]; 3]| rows.map(|row| row[slot]);
        self.decode_box(at(low), at(high))
    }

    /// The largest steps on axis `axis` whose plane lies at or below `value` (0 decodes to
    /// the origin, at or below every child's minimum).
    pub(crate) fn steps_below(&self, axis: usize, value: f32) -> u8 {
        let (origin, step) = (self.origin[axis], step(self.exponent[axis]));
        let guess = ((value - origin) / step).floor().clamp(0.0, 255.0) as u8;
        let mut steps = guess.saturating_add(1);
        while steps > 0 && plane(origin, steps, step) > value {
            steps -= 1;
        }
        steps
    }

    /// The smallest steps on axis `axis` whose plane lies at or above `value` (255 does, by
    /// the exponent's choice; where even it does not, the exponent hit its cap and 255 is the
    /// nearest).
    pub(crate) fn steps_above(&self, axis: usize, value: f32) -> u8 {
        let (origin, step) = (self.origin[axis], step(self.exponent[axis]));
        let guess = ((value - origin) / step).ceil().clamp(0.0, 255.0) as u8;
        let mut steps = guess.saturating_sub(1);
        while steps < 255 && plane(origin, steps, step) < value {
            steps += 1;
        }
        steps
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::PreparedRay;
    use crate::test_support::TestRng;
    use crate::wide::kind::layout::Layout;
    use crate::wide::node4::tests::box_test_case;
    use crate::wide::node4q::QuantizedWideNode;
    use crate::wide::node8q::QuantizedWideNode8;
    use crate::wide::ray::{BoxSimd, WideRay};

    /// What these tests need of a quantized node beside its layout.
    trait Quantized: Layout {
        fn grid_of(&self) -> Grid;
        /// The box test's mask and entries, lane `k` for slot `k`.
        fn test(&self, ray: &WideRay, tmax: f32) -> (u32, Vec<f32>);
    }

    impl Quantized for QuantizedWideNode {
        fn grid_of(&self) -> Grid {
            self.grid()
        }
        fn test(&self, ray: &WideRay, tmax: f32) -> (u32, Vec<f32>) {
            let (mask, entries) = self.hits(ray, tmax);
            (mask, entries.to_array().to_vec())
        }
    }

    impl Quantized for QuantizedWideNode8 {
        fn grid_of(&self) -> Grid {
            self.grid()
        }
        fn test(&self, ray: &WideRay, tmax: f32) -> (u32, Vec<f32>) {
            let (mask, entries) = self.hits(ray, tmax);
            (mask, entries.to_vec())
        }
    }

    /// Every decoded box holds its child's box and is at most one step larger on each side,
    /// over random boxes, flat ones, large offsets and tiny extents, for both node widths.
    #[test]
    fn decoded_boxes_hold_the_exact_ones() {
        decoded_boxes_hold_the_exact_ones_for::<QuantizedWideNode>();
        decoded_boxes_hold_the_exact_ones_for::<QuantizedWideNode8>();
    }

    /// Round `round`'s children (1 to `width` of them, slot 1 flat in y): far from the origin
    /// or not, tiny, unit or large, by the round; and their size.
    fn spread_children(rng: &mut TestRng, round: usize, width: usize) -> (Vec<(Aabb, u32)>, f32) {
        let offset = [0.0, 1e3, -3e5, 7e6][round % 4];
        let size = [1e-6, 1.0, 50.0, 1e4][(round / 4) % 4];
        let children = (0..1 + round % width)
            .map(|slot| {
                let a = rng.vec3(size) + offset;
                let mut b = a + rng.vec3(size).abs();
                if slot == 1 {
                    b.y = a.y;
                }
                (Aabb::new(a.min(b), a.max(b)), slot as u32)
            })
            .collect();
        (children, size)
    }

    fn decoded_boxes_hold_the_exact_ones_for<N: Quantized>() {
        let mut rng = TestRng::new(21);
        for round in 0..5_000 {
            let (children, _) = spread_children(&mut rng, round, N::WIDTH);
            let used = children.len();
            let node = N::from_children(&children);
            let steps = node.grid_of().steps();
            assert_eq!(node.used_slots(), used);
            for (slot, (exact, word)) in children.iter().enumerate() {
                let decoded = node.child_bounds(slot);
                assert_eq!(node.child(slot), *word);
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

    /// The node's box test is, lane by lane, the scalar slab test on the decoded boxes, with
    /// the portable test and with SIMD (the 8-wide node's AVX2 decode and test where the CPU
    /// has AVX2); unused slots are never hit; a ray that enters an exact box enters its decoded
    /// box, no later.
    #[test]
    fn lanes_match_the_scalar_box_test_on_the_decoded_boxes() {
        for simd in [BoxSimd::PORTABLE, BoxSimd::detect(true)] {
            lanes_match_for::<QuantizedWideNode>(simd);
            lanes_match_for::<QuantizedWideNode8>(simd);
        }
    }

    fn lanes_match_for<N: Quantized>(simd: BoxSimd) {
        let mut rng = TestRng::new(22);
        for round in 0..20_000 {
            let slots = 1 + round % N::WIDTH;
            let Some((boxes, ray, tmax)) = box_test_case(&mut rng, round, slots) else {
                continue;
            };
            let children: Vec<(Aabb, u32)> = boxes.iter().map(|&b| (b, 0)).collect();
            let node = N::from_children(&children);
            let (mask, entries) = node.test(&WideRay::new(&ray, simd), tmax);
            for slot in 0..N::WIDTH {
                check_lane(&node, (slot, slots), (mask, &entries), &boxes, (&ray, tmax));
            }
        }
    }

    /// One lane of [`lanes_match_for`].
    fn check_lane<N: Quantized>(
        node: &N,
        (slot, slots): (usize, usize),
        (mask, entries): (u32, &[f32]),
        boxes: &[Aabb],
        (ray, tmax): (&PreparedRay, f32),
    ) {
        let scalar = if slot < slots {
            node.child_bounds(slot).entry(ray, tmax)
        } else {
            f32::INFINITY
        };
        let hit = mask & (1 << slot) != 0;
        assert_eq!(hit, scalar < f32::INFINITY, "slot {slot}, {ray:?}");
        if hit {
            assert_eq!(entries[slot], scalar, "slot {slot} of {boxes:?}, {ray:?}");
        }
        if slot < slots && boxes[slot].entry(ray, tmax) < f32::INFINITY {
            let exact = boxes[slot].entry(ray, tmax);
            assert!(hit && entries[slot] <= exact, "slot {slot}, {ray:?}");
        }
    }

    /// The 8-wide node's AVX2 decode and test give, on every lane (unused slots included),
    /// the mask and the entries of its portable twin, over nodes far from the origin, tiny and
    /// large ones, and rays from inside and outside them.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_decode_and_test_equal_the_portable_twin() {
        use crate::geom::Ray;
        use crate::wide::simd::{Avx2, slabs8q};
        let Some(avx2) = Avx2::detect_or_note("only the portable box test runs") else {
            return;
        };
        let mut rng = TestRng::new(23);
        let mut hit_lanes = 0;
        for round in 0..20_000 {
            let (children, size) = spread_children(&mut rng, round, 8);
            let node = QuantizedWideNode8::from_children(&children);
            let origin = rng.vec3(size * 3.0) + children[0].0.min;
            let tmax = if round % 3 == 0 {
                f32::INFINITY
            } else {
                rng.range(0.0, size * 5.0)
            };
            let ray = Ray::with_range(origin, rng.vec3(1.0), 0.0, tmax);
            let Some(ray) = PreparedRay::new(&ray) else {
                continue;
            };
            let wide_ray = WideRay::new(&ray, BoxSimd::detect(true));
            let quantized = (node.grid(), &node.low, &node.high);
            let (mask, entries) = slabs8q(avx2, &wide_ray, quantized, tmax);
            let (twin_mask, twin_entries) = node.hits_portable(&wide_ray, tmax);
            assert_eq!(mask, twin_mask, "{children:?}, {ray:?}");
            hit_lanes += mask.count_ones();
            for slot in (0..8).filter(|slot| mask & (1 << slot) != 0) {
                assert_eq!(entries[slot], twin_entries[slot], "slot {slot}, {ray:?}");
            }
        }
        assert!(hit_lanes > 5_000, "{hit_lanes} lanes hit");
    }
}
