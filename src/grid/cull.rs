//! Cull boxes: every stored cell keeps the box of what its triangles put inside it, and a ray
//! whose path misses that box skips the cell's triangle tests.
//!
//! A cell is a box the ray crosses, but its triangles may fill only a sliver of it: a height
//! field's patch crosses a cube cell as a thin layer, and most rays through the cell pass above
//! or below it. One slab test (about 20 instructions) then stands in for a dozen triangle tests
//! (about 110 instructions each, with the mailbox).
//!
//! **The box.** For each triangle of the cell, the intersection of the triangle's box with the
//! cell's box (plane coordinates taken with `max` and `min`, so no rounding); the cull box is
//! the union of those (again `min` and `max`). The hash stores it as six exact `f32`s in front
//! of the cell's references.
//!
//! **The dense grid's coarse box.** The dense grid stores the box rounded outwards to whole
//! steps of a thirty-first of a cell from the cell's own planes, five bits a face, 30 bits a
//! cell, in an array of its own by rank ([`coarse_cull`]). A ray reads 4 bytes per stored cell
//! it crosses, from an array of nothing else, and reaches for the references only when the
//! box lets it through. The exact box in front of the references takes a miss for every
//! stored cell a ray crosses (about half the walk's samples on the 1M-triangle terrain); with
//! the coarse box the grid's short rays there run at 0.80-0.95x the AABB tree's speed instead
//! of 0.73x (docs/benchmarks.md).
//!
//! **Why no hit is lost.** The kernels report a hit on a triangle at `t >= t*`, where `t*` is
//! the triangle box's entry distance and every axis of that box is active at `t*`; the walk
//! (`super::walk`) visits a cell of the triangle's block with every axis active at `t*` too.
//! The box test's distances are monotone in the plane coordinate, so along each axis the
//! active interval of the intersection box is exactly the intersection of the two intervals
//! (the `max` of two planes enters at the later distance, the `min` leaves at the earlier),
//! and the union's interval contains each of its parts' intervals. So at `t*` every axis of
//! that cell's cull box is active, its slab test passes within `[tmin, t]`, and the triangle
//! is tested there. In a cell whose cull box the ray misses, no triangle is marked in the
//! mailbox, so each is still tested in the cell where the test passes. None of this needs the
//! intersections to be non-empty: the formulas hold plane by plane. A coarse box holds the
//! exact one (its faces are rounded outwards with the very arithmetic the walk decodes them
//! with), so its intervals hold the exact box's, and its test passes wherever that one does.

use glam::{Vec3, Vec3A};

use crate::geom::aabb::SlabRay;

use super::walk::GridPlanes;

/// Words a cull box takes in front of a stored cell's references in the hash.
pub(crate) const CULL_WORDS: usize = 6;

/// The cull box of cell `cell` (slab indices) of `planes` holding triangles whose boxes are
/// `boxes` (`(min, max)` each), as `(min, max)`.
pub(crate) fn cull_box(
    planes: &GridPlanes,
    cell: [u32; 3],
    boxes: impl Iterator<Item = (Vec3, Vec3)>,
) -> (Vec3, Vec3) {
    let at = |axis: usize, plane: u32| planes[axis].planes()[plane as usize];
    let cell_min = Vec3::from_array([0, 1, 2].map(|a| at(a, cell[a])));
    let cell_max = Vec3::from_array([0, 1, 2].map(|a| at(a, cell[a] + 1)));
    let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for (lo, hi) in boxes {
        min = min.min(lo.max(cell_min));
        max = max.max(hi.min(cell_max));
    }
    (min, max)
}

/// [`cull_box`] as the words the hash stores in front of the cell's references.
pub(crate) fn cull_words(
    planes: &GridPlanes,
    cell: [u32; 3],
    boxes: impl Iterator<Item = (Vec3, Vec3)>,
) -> [u32; CULL_WORDS] {
    let (min, max) = cull_box(planes, cell, boxes);
    let [a, b, c] = min.to_array().map(f32::to_bits);
    let [d, e, f] = max.to_array().map(f32::to_bits);
    [a, b, c, d, e, f]
}

/// The references of a stored cell (its `words`: the cull box, then the references) that
/// the ray (`slab`, its slab-test constants, made once per walk) must test: all of them if it
/// may meet the cull box within `[tmin, tmax]`, else `None` (nor if the words hold no cull
/// box).
#[inline(always)]
pub(crate) fn refs_to_test<'a>(words: &'a [u32], slab: &SlabRay, tmax: f32) -> Option<&'a [u32]> {
    let (cull, refs) = words.split_first_chunk::<CULL_WORDS>()?;
    let f = |i: usize| f32::from_bits(cull[i]);
    let min = Vec3A::new(f(0), f(1), f(2));
    let max = Vec3A::new(f(3), f(4), f(5));
    (slab.entry(min, max, tmax) < f32::INFINITY).then_some(refs)
}

/// Bits per face of a [`coarse_cull`] box, and the steps a face can move in from its cell's
/// plane (`2^5 - 1`: a thirty-first of the cell's width each).
const COARSE_BITS: u32 = 5;
const COARSE_STEPS: u32 = (1 << COARSE_BITS) - 1;

/// The size of one coarse step on each axis of `planes` (the first slab's width over
/// [`COARSE_STEPS`]; any positive size keeps the boxes conservative, see [`coarse_cull`]).
pub(crate) fn coarse_steps(planes: &GridPlanes) -> Vec3A {
    Vec3A::from_array([0, 1, 2].map(|a| {
        let at = planes[a].planes();
        (at[1] - at[0]) / COARSE_STEPS as f32
    }))
}

/// The cull box `(min, max)` (from [`cull_box`]) of cell `cell`, rounded outwards to whole
/// coarse steps from the cell's planes and packed in 30 bits: the low face `k` steps above
/// the cell's low plane, the high face `k` steps below its high plane. The rounding is done
/// with the very arithmetic of [`coarse_box`], so its box holds the exact one.
pub(crate) fn coarse_cull(
    planes: &GridPlanes,
    steps: Vec3A,
    cell: [u32; 3],
    (min, max): (Vec3, Vec3),
) -> u32 {
    let mut packed = 0;
    for a in 0..3 {
        let at = planes[a].planes();
        let (lo, hi) = (at[cell[a] as usize], at[cell[a] as usize + 1]);
        let (min, max) = (min[a], max[a]);
        let up = (0..=COARSE_STEPS)
            .rev()
            .find(|&k| lo + k as f32 * steps[a] <= min)
            .unwrap_or(0);
        let down = (0..=COARSE_STEPS)
            .rev()
            .find(|&k| hi - k as f32 * steps[a] >= max)
            .unwrap_or(0);
        packed |= (up | down << COARSE_BITS) << (2 * COARSE_BITS * a as u32);
    }
    packed
}

/// The box [`coarse_cull`] packed in `packed` for cell `cell` of `planes`, as `(min, max)`.
#[inline(always)]
pub(crate) fn coarse_box(
    planes: &GridPlanes,
    steps: Vec3A,
    cell: [u32; 3],
    packed: u32,
) -> (Vec3A, Vec3A) {
    let field = |a: usize, which: u32| {
        (packed >> (2 * COARSE_BITS * a as u32 + COARSE_BITS * which) & COARSE_STEPS) as f32
    };
    let plane = |a: usize, up: usize| planes[a].planes()[cell[a] as usize + up];
    let lo = Vec3A::new(plane(0, 0), plane(1, 0), plane(2, 0));
    let hi = Vec3A::new(plane(0, 1), plane(1, 1), plane(2, 1));
    let up = Vec3A::new(field(0, 0), field(1, 0), field(2, 0));
    let down = Vec3A::new(field(0, 1), field(1, 1), field(2, 1));
    (lo + up * steps, hi - down * steps)
}

/// True if the ray (`slab`) may meet, within `[tmin, tmax]`, the box [`coarse_cull`] packed
/// in `packed` for cell `cell` of `planes`.
#[inline(always)]
pub(crate) fn coarse_hit(
    planes: &GridPlanes,
    steps: Vec3A,
    cell: [u32; 3],
    packed: u32,
    slab: &SlabRay,
    tmax: f32,
) -> bool {
    let (min, max) = coarse_box(planes, steps, cell, packed);
    slab.entry(min, max, tmax) < f32::INFINITY
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::planes::Planes;

    #[test]
    fn coarse_boxes_hold_the_exact_ones_within_a_step() {
        let mut rng = crate::test_support::TestRng::new(17);
        // Uneven planes (widths that do not divide evenly in f32), a flat axis, large offsets.
        let planes: GridPlanes = [
            Planes::new(-3.3, 1e4, 707),
            Planes::new(5.0, 5.0, 1),
            Planes::new(0.1, 0.7, 3),
        ];
        let steps = coarse_steps(&planes);
        for _ in 0..2000 {
            let cell = [0, 1, 2].map(|a| {
                (rng.range(0.0, planes[a].slabs() as f32) as u32).min(planes[a].slabs() - 1)
            });
            let at = |a: usize, up: u32| planes[a].planes()[(cell[a] + up) as usize];
            // A triangle box that may stick out of the cell, or lie on one of its planes.
            let mut corner = || {
                Vec3::from_array([0, 1, 2].map(|a| {
                    let (lo, hi) = (at(a, 0), at(a, 1));
                    match rng.range(0.0, 4.0) as u32 {
                        0 => lo,
                        1 => hi,
                        _ => lo + (hi - lo) * rng.range(-0.2, 1.2),
                    }
                }))
            };
            let (p, q) = (corner(), corner());
            let exact = cull_box(&planes, cell, std::iter::once((p.min(q), p.max(q))));
            let packed = coarse_cull(&planes, steps, cell, exact);
            let (min, max) = coarse_box(&planes, steps, cell, packed);
            for a in 0..3 {
                let (emin, emax) = (exact.0[a], exact.1[a]);
                assert!(min[a] <= emin && max[a] >= emax, "{cell:?} axis {a}");
                // Within a step, give or take the rounding of the planes' arithmetic.
                let slack = steps[a] * 1.01 + at(a, 1).abs() * 4.0 * f32::EPSILON;
                assert!(
                    emin - min[a] <= slack || emin > at(a, 1),
                    "{cell:?} axis {a}"
                );
                assert!(
                    max[a] - emax <= slack || emax < at(a, 0),
                    "{cell:?} axis {a}"
                );
            }
        }
    }
}
