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
//! the union of those (again `min` and `max`). It is stored as six exact `f32`s.
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
//! intersections to be non-empty: the formulas hold plane by plane.

use glam::{Vec3, Vec3A};

use crate::geom::aabb::SlabRay;

use super::walk::GridPlanes;

/// Words a cull box takes in front of a stored cell's references (grid and hash alike).
pub(crate) const CULL_WORDS: usize = 6;

/// The cull box of cell `cell` (slab indices) of `planes` holding triangles whose boxes are
/// `boxes` (`(min, max)` each), as the words stored in front of the cell's references.
pub(crate) fn cull_words(
    planes: &GridPlanes,
    cell: [u32; 3],
    boxes: impl Iterator<Item = (Vec3, Vec3)>,
) -> [u32; CULL_WORDS] {
    let at = |axis: usize, plane: u32| planes[axis].planes()[plane as usize];
    let cell_min = Vec3::from_array([0, 1, 2].map(|a| at(a, cell[a])));
    let cell_max = Vec3::from_array([0, 1, 2].map(|a| at(a, cell[a] + 1)));
    let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for (lo, hi) in boxes {
        min = min.min(lo.max(cell_min));
        max = max.max(hi.min(cell_max));
    }
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
