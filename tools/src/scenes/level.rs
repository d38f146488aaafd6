//! The game level scene: a square of flat ground made of large triangles in a grid, box
//! buildings standing on it, and clutter (crates, containers) turned every which way.
//!
//! It is what a game's AI line of sight runs against: big ground triangles whose boxes overlap
//! many buildings, thousands of small boxes, and sightlines between agents standing in the open
//! (see [`super::rays`]), short and mostly blocked.

use raybatch::glam::{Vec2, Vec3};
use raybatch::{Aabb, Mesh};

use super::push_box;
use super::rng::SplitMix64;
use super::terrain;

/// Side of the square level along `x` and `z`, in metres.
pub(crate) const SIDE: f32 = 640.0;
/// Height of the ground.
pub(crate) const GROUND: f32 = 0.0;
/// Ground cells per side: 10 m cells, `2 * 64^2 = 8,192` ground triangles.
const CELLS: u32 = 64;
/// Buildings start this far below the ground and clutter half as far, so no face coincides with
/// the ground (coplanar overlaps would make hits depend on tie-breaking rather than geometry).
const FOUNDATION: f32 = -1.0;
/// Buildings stand on a lattice of square lots this wide, one per lot, leaving alleys and
/// small squares between them.
const LOT: f32 = 20.0;
/// Chance that a lot is left empty (a square).
const EMPTY_LOT: f32 = 0.1;
/// A building's share of its lot, per axis, and its height.
const BUILDING_SHARE: (f32, f32) = (0.55, 0.9);
const BUILDING_HEIGHT: (f32, f32) = (4.0, 20.0);
/// Clutter sides (each axis) and heights.
const CLUTTER_SIDE: (f32, f32) = (0.6, 6.0);
const CLUTTER_HEIGHT: (f32, f32) = (0.5, 3.0);

/// Pieces of clutter in the built-in level: with the ground and the buildings, about 45k
/// triangles.
pub(crate) const BUILTIN_CLUTTER: u32 = 2200;

/// The level: the ground grid first (`2 * CELLS^2` triangles), then 12 triangles per building,
/// then 12 per piece of clutter.
pub(crate) fn mesh(clutter: u32, seed: u64) -> Mesh {
    let mut rng = SplitMix64::new(seed);
    let (mut vertices, mut triangles) = ground();
    let lots = (SIDE / LOT) as u32;
    for lz in 0..lots {
        for lx in 0..lots {
            if rng.chance(EMPTY_LOT) {
                continue;
            }
            let lot_min = Vec2::new(lx as f32, lz as f32) * LOT;
            let bounds = building(&mut rng, lot_min);
            push_box(&mut vertices, &mut triangles, bounds);
        }
    }
    for _ in 0..clutter {
        push_turned_box(&mut vertices, &mut triangles, &mut rng);
    }
    Mesh::new(vertices, triangles).expect("a generated level is always a valid mesh")
}

/// A building on the lot at `lot_min`: a random footprint placed anywhere inside the lot, and a
/// random height.
fn building(rng: &mut SplitMix64, lot_min: Vec2) -> Aabb {
    let size = Vec2::new(
        rng.range_f32(BUILDING_SHARE.0, BUILDING_SHARE.1),
        rng.range_f32(BUILDING_SHARE.0, BUILDING_SHARE.1),
    ) * LOT;
    let lo = lot_min
        + Vec2::new(
            rng.range_f32(0.0, LOT - size.x),
            rng.range_f32(0.0, LOT - size.y),
        );
    let hi = lo + size;
    let height = rng.range_f32(BUILDING_HEIGHT.0, BUILDING_HEIGHT.1);
    Aabb::new(
        Vec3::new(lo.x, FOUNDATION, lo.y),
        Vec3::new(hi.x, GROUND + height, hi.y),
    )
}

/// The ground `[0, SIDE]^2` at [`GROUND`]: `CELLS^2` square cells of two triangles facing up,
/// triangulated as the terrain's grid.
fn ground() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let cell = SIDE / CELLS as f32;
    let row = CELLS + 1;
    let vertices = (0..row)
        .flat_map(|z| (0..row).map(move |x| Vec3::new(x as f32 * cell, GROUND, z as f32 * cell)))
        .collect();
    (vertices, terrain::triangles(CELLS))
}

/// A piece of clutter: a box turned about `+y` by a random angle, standing on the ground
/// anywhere in the level. The turn comes from [`SplitMix64::unit_vector_2d`] (no `sin`/`cos`,
/// whose last bit differs between platforms; see [`super::rng`]).
fn push_turned_box(vertices: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>, rng: &mut SplitMix64) {
    let half = Vec3::new(
        rng.range_f32(CLUTTER_SIDE.0, CLUTTER_SIDE.1),
        rng.range_f32(CLUTTER_HEIGHT.0, CLUTTER_HEIGHT.1) - 0.5 * FOUNDATION,
        rng.range_f32(CLUTTER_SIDE.0, CLUTTER_SIDE.1),
    ) * 0.5;
    let margin = half.x.max(half.z) * std::f32::consts::SQRT_2;
    let centre = Vec3::new(
        rng.range_f32(margin, SIDE - margin),
        0.5 * FOUNDATION + half.y,
        rng.range_f32(margin, SIDE - margin),
    );
    let axis = rng.unit_vector_2d();
    let first = vertices.len();
    push_box(vertices, triangles, Aabb::new(-half, half));
    for v in &mut vertices[first..] {
        let (x, z) = (v.x * axis.x - v.z * axis.y, v.x * axis.y + v.z * axis.x);
        *v = centre + Vec3::new(x, v.y, z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_bounds() {
        let m = mesh(20, 1);
        let ground = 2 * (CELLS * CELLS) as usize;
        let buildings = (m.triangle_count() - ground) / 12 - 20;
        assert_eq!(m.triangle_count(), ground + 12 * (buildings + 20));
        let lots = (SIDE / LOT) as usize;
        assert!(
            (lots * lots * 8 / 10..lots * lots).contains(&buildings),
            "{buildings}"
        );
        let b = m.bounds();
        assert_eq!((b.min.x, b.min.z, b.min.y), (0.0, 0.0, FOUNDATION));
        assert_eq!((b.max.x, b.max.z), (SIDE, SIDE));
        assert!(b.max.y <= GROUND + BUILDING_HEIGHT.1);
        assert_eq!(mesh(20, 1), m);
        assert_ne!(mesh(20, 2), m);
    }

    #[test]
    fn turned_clutter_keeps_its_shape_and_stands_on_the_ground() {
        let m = mesh(50, 3);
        let ground_vertices = ((CELLS + 1) * (CELLS + 1)) as usize;
        let clutter = &m.vertices()[m.vertices().len() - 8 * 50..];
        assert!(clutter.len() + ground_vertices <= m.vertices().len());
        for corners in clutter.chunks(8) {
            // A turn about +y keeps the four bottom corners at one height and their
            // distances to each other (a rectangle).
            let bottom: Vec<Vec3> = corners.iter().copied().filter(|v| v.y < 0.0).collect();
            assert_eq!(bottom.len(), 4);
            assert!(bottom.iter().all(|v| (v.y - 0.5 * FOUNDATION).abs() < 1e-5));
            let centre = bottom.iter().sum::<Vec3>() / 4.0;
            let r: Vec<f32> = bottom.iter().map(|v| (*v - centre).length()).collect();
            assert!(r.iter().all(|d| (d - r[0]).abs() < 1e-3), "{r:?}");
            assert!(corners.iter().all(|v| (0.0..=SIDE).contains(&v.x)));
        }
    }
}
