//! Rays shared by several test files: the hard rays of a mesh (aimed at every vertex and edge
//! midpoint, axis-parallel with signed zeros, windows, segments, invalid rays mixed in), a
//! selection of invalid rays, and incoherent rays (random origins and directions).

use glam::Vec3;
use raybatch::{Mesh, Ray};

use super::meshes::edges;
use super::rng::{StdRng, in_box, in_cube, seeded};

/// A selection of invalid rays: they must miss everything, in every path.
pub fn invalid_rays() -> Vec<Ray> {
    let o = Vec3::new(0.1, 0.2, -3.0);
    let d = Vec3::new(0.01, -0.02, 1.0);
    let sub = f32::MIN_POSITIVE / 4.0;
    vec![
        Ray::new(Vec3::new(f32::NAN, 0.0, -3.0), d),
        Ray::new(Vec3::new(0.0, f32::INFINITY, -3.0), d),
        Ray::new(o, Vec3::new(0.0, f32::NAN, 1.0)),
        Ray::new(o, Vec3::new(f32::NEG_INFINITY, 0.0, 1.0)),
        Ray::new(o, Vec3::ZERO),
        Ray::new(o, Vec3::new(-0.0, 0.0, -0.0)),
        Ray::new(o, Vec3::new(sub, -sub, sub)),
        Ray::with_range(o, d, 2.0, 1.0),
        Ray::with_range(o, d, -0.5, 10.0),
        Ray::with_range(o, d, f32::NAN, 10.0),
        Ray::with_range(o, d, 0.0, f32::NAN),
        Ray::with_range(o, d, f32::INFINITY, f32::INFINITY),
        Ray::with_range(o, d, 0.0, f32::NEG_INFINITY),
        Ray::segment(o, o),
    ]
}

/// Ray `i` of the mixes: a valid ray's range variant.
pub fn with_range_variant(i: usize, origin: Vec3, target: Vec3) -> Ray {
    let d = target - origin;
    match i % 6 {
        0 => Ray::new(origin, d),
        // A segment ending exactly at the target.
        1 => Ray::segment(origin, target),
        // Starting exactly at the target.
        2 => Ray::with_range(origin, d, 1.0, f32::INFINITY),
        // tmin = 0.3 * tmax.
        3 => Ray::with_range(origin, d, 0.6, 2.0),
        // Through the target and beyond, as a segment.
        4 => Ray::segment(origin, origin + 2.0 * d),
        _ => Ray::with_range(origin, d, 0.3 * 1.5, 1.5),
    }
}

/// Rays at the hard places of a mesh around the origin: aimed exactly at every vertex and
/// every edge midpoint from inside and outside, axis-parallel rays through vertices and edge
/// midpoints with `+0` / `-0` components, random rays and segments (some with `tmin > 0`), and
/// invalid rays mixed in.
pub fn hard_rays(mesh: &Mesh, seed: u64) -> Vec<Ray> {
    let mut rng = seeded(seed);
    let verts = mesh.vertices();
    let mut targets: Vec<Vec3> = verts.to_vec();
    targets.extend(
        edges(mesh)
            .iter()
            .map(|&(a, b)| (verts[a as usize] + verts[b as usize]) * 0.5),
    );
    let origins = [
        Vec3::ZERO,
        Vec3::new(3.0, 0.5, -2.0),
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(-2.5, -2.5, 2.5),
        verts[0],
    ];
    let mut rays = Vec::new();
    for (k, &origin) in origins.iter().enumerate() {
        for (i, &target) in targets.iter().enumerate() {
            if target != origin {
                rays.push(with_range_variant(i + k, origin, target));
            }
        }
    }
    // Axis-parallel through the targets: the two other components exactly those of the target.
    for (i, &target) in targets.iter().enumerate() {
        let axis = i % 3;
        let negative = (i / 3) % 2 == 1;
        let zeros = (i / 6) % 4;
        let mut dir = [0.0f32; 3];
        let mut origin = target.to_array();
        for (k, o) in [(axis + 1) % 3, (axis + 2) % 3].into_iter().enumerate() {
            dir[o] = if zeros >> k & 1 == 1 { -0.0 } else { 0.0 };
        }
        dir[axis] = if negative { -1.0 } else { 1.0 };
        origin[axis] = if negative { 3.0 } else { -3.0 };
        let (origin, dir) = (Vec3::from_array(origin), Vec3::from_array(dir));
        rays.push(match i % 4 {
            0 | 1 => Ray::new(origin, dir),
            2 => Ray::with_range(origin, dir, 0.3 * 6.0, 6.0),
            _ => Ray::segment(origin, target),
        });
    }
    // Random rays, some axis-parallel-ish with zero components, and random segments.
    for i in 0..400 {
        let origin = in_cube(&mut rng, 3.0);
        let mut dir = in_cube(&mut rng, 1.0);
        if i % 5 == 0 {
            dir[i % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
        }
        let target = in_cube(&mut rng, 1.2);
        rays.push(match i % 4 {
            0 => Ray::new(origin, dir),
            1 => Ray::segment(origin, target),
            2 => Ray::with_range(origin, dir, 0.3 * 4.0, 4.0),
            _ => with_range_variant(i, origin, target),
        });
    }
    // Invalid rays at scattered positions.
    let invalid = invalid_rays();
    for (k, ray) in invalid.iter().cycle().take(invalid.len() * 3).enumerate() {
        let at = (k * 131) % (rays.len() + 1);
        rays.insert(at, *ray);
    }
    rays
}

/// Every `step`-th ray.
pub fn every_nth(rays: &[Ray], step: usize) -> Vec<Ray> {
    rays.iter().step_by(step).copied().collect()
}

/// `count` incoherent rays over `mesh`, the workload of the tools' `incoherent` ray set:
/// origins uniform in the mesh bounds grown by 5% of their extent on every side, directions
/// uniform in the cube `[-1, 1)^3` (a zero direction is drawn again), unbounded.
pub fn incoherent(mesh: &Mesh, count: usize, rng: &mut StdRng) -> Vec<Ray> {
    let bounds = mesh.bounds();
    let margin = bounds.extent() * 0.05;
    let (min, max) = (bounds.min - margin, bounds.max + margin);
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count {
        let origin = in_box(rng, min, max);
        let ray = Ray::new(origin, in_cube(rng, 1.0));
        if ray.is_valid() {
            rays.push(ray);
        }
    }
    rays
}
