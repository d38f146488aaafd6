//! The O(n) reference of the shape queries: every non-degenerate triangle tested, in id order,
//! with the same triangle tests and tie rule as the trees.

use glam::Vec3;

use super::{Contact, Earliest, Shape};
use crate::mesh::Mesh;

/// The ids of the triangles `shape` overlaps, ascending (the shape is not checked).
pub fn overlapping(mesh: &Mesh, shape: &Shape) -> Vec<u32> {
    triangles(mesh)
        .filter(|&(_, corners)| shape.overlaps_triangle(&corners))
        .map(|(id, _)| id)
        .collect()
}

/// The first contact of `shape` moved by `motion` (see [`super::ShapeQueries::sweep`]; the
/// inputs are not checked, and the ray engine's answer for a sphere of radius 0 is not used:
/// this is the `f64` test on every triangle).
pub fn sweep(mesh: &Mesh, shape: &Shape, motion: Vec3) -> Option<Contact> {
    let mut best = None;
    for (id, corners) in triangles(mesh) {
        if let Some(t) = shape.sweep_time(motion, &corners) {
            Earliest::keep(&mut best, t, id, &corners);
        }
    }
    best.map(|first| shape.contact(motion, &first))
}

/// Every triangle a tree holds: the non-degenerate ones.
fn triangles(mesh: &Mesh) -> impl Iterator<Item = (u32, [Vec3; 3])> + '_ {
    (0..mesh.triangle_count() as u32)
        .filter(|&id| !mesh.is_degenerate(id))
        .map(|id| (id, mesh.triangle(id)))
}
