//! Watertightness: no ray from inside a closed mesh may escape under the watertight kernel,
//! whatever structure answers it, even aimed exactly at shared vertices and edges.

use crate::common::meshes::{assert_closed_and_outward, edges, icosphere};
use crate::common::rng::{RngExt, StdRng, in_cube, seeded};
use crate::common::zoo::structures_with;
use glam::Vec3;
use raybatch::brute_force;
use raybatch::{AccelKind, ChildOrdering, Kernel, Mesh, Ray};

const RAYS: usize = 100_000;

/// A point uniformly distributed in the ball of radius `r`.
fn in_ball(rng: &mut StdRng, r: f32) -> Vec3 {
    loop {
        let p = in_cube(rng, 1.0);
        if p.length_squared() <= 1.0 {
            return p * r;
        }
    }
}

/// What a ray is aimed at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Aim {
    Vertex,
    EdgeMidpoint,
    Random,
}

/// The rays: every vertex and edge midpoint seen from the centre, then interior origins
/// (random, or on a grid of eighths) aimed at random vertices (30%), random edge midpoints
/// (30%) or in random directions.
fn rays(mesh: &Mesh, rng: &mut StdRng) -> Vec<(Ray, Aim)> {
    let verts = mesh.vertices();
    let midpoints: Vec<Vec3> = edges(mesh)
        .iter()
        .map(|&(a, b)| (verts[a as usize] + verts[b as usize]) * 0.5)
        .collect();
    let mut rays: Vec<(Ray, Aim)> = verts
        .iter()
        .map(|&v| (Ray::new(Vec3::ZERO, v), Aim::Vertex))
        .chain(
            midpoints
                .iter()
                .map(|&m| (Ray::new(Vec3::ZERO, m), Aim::EdgeMidpoint)),
        )
        .collect();
    while rays.len() < RAYS {
        let origin = match rng.random_range(0..4) {
            0 => Vec3::new(
                rng.random_range(-4i32..=4) as f32 * 0.125,
                rng.random_range(-4i32..=4) as f32 * 0.125,
                rng.random_range(-4i32..=4) as f32 * 0.125,
            ),
            _ => in_ball(rng, 0.9),
        };
        let (target, aim) = match rng.random_range(0..10) {
            0..3 => (verts[rng.random_range(0..verts.len())], Aim::Vertex),
            3..6 => (
                midpoints[rng.random_range(0..midpoints.len())],
                Aim::EdgeMidpoint,
            ),
            _ => (origin + in_ball(rng, 1.0), Aim::Random),
        };
        let ray = Ray::new(origin, target - origin);
        if ray.is_valid() {
            rays.push((ray, aim));
        }
    }
    rays
}

#[test]
fn no_leaks_from_inside_closed_icosphere() {
    let mesh = icosphere(4);
    assert_closed_and_outward(&mesh, Vec3::ZERO);
    let zoo = structures_with(&mesh, &AccelKind::ALL, &[1, 4], &[ChildOrdering::Pns]);
    let mut rng = seeded(0x5eed);
    let rays = rays(&mesh, &mut rng);
    let count = |aim: Aim| rays.iter().filter(|(_, a)| *a == aim).count();
    let aimed = count(Aim::Vertex) + count(Aim::EdgeMidpoint);
    assert!(aimed > RAYS / 2, "{aimed}");

    // Möller-Trumbore leaks per aim (same order as the enum).
    let mut mt_leaks = [0usize; 3];
    for (i, (ray, aim)) in rays.iter().enumerate() {
        for t in &zoo {
            let h = t
                .accel
                .cast_ray_with(ray, Kernel::Watertight)
                .unwrap_or_else(|| panic!("{}: leak, ray {i} ({aim:?}): {ray:?}", t.name));
            // The hit is on the sphere (radius 1, the facets are at most ~0.2% inside).
            let r = ray.at(h.t).length();
            assert!(
                (0.99..=1.0001).contains(&r),
                "{}: hit at radius {r}, {ray:?}",
                t.name
            );
            assert!(
                t.accel.occluded_with(ray, Kernel::Watertight),
                "{}: {ray:?}",
                t.name
            );
        }
        if zoo[0]
            .accel
            .cast_ray_with(ray, Kernel::MollerTrumbore)
            .is_none()
        {
            mt_leaks[*aim as usize] += 1;
        }
    }
    // The kernel itself, without any structure, on a tenth of the rays.
    for (ray, _) in rays.iter().step_by(10) {
        assert!(
            brute_force::cast_ray(&mesh, ray, Kernel::Watertight).is_some(),
            "brute force leak: {ray:?}"
        );
    }
    let total: usize = mt_leaks.iter().sum();
    eprintln!(
        "watertight: 0 leaks in {} rays x {} structures (icosphere, {} triangles). \
         Moller-Trumbore ({}): {total} leaks ({:.3}%): {} of {} rays aimed at vertices, \
         {} of {} aimed at edge midpoints, {} of {} random",
        rays.len(),
        zoo.len(),
        mesh.triangle_count(),
        zoo[0].name,
        100.0 * total as f64 / rays.len() as f64,
        mt_leaks[0],
        count(Aim::Vertex),
        mt_leaks[1],
        count(Aim::EdgeMidpoint),
        mt_leaks[2],
        count(Aim::Random),
    );
}

/// At every scale a mesh may have: an icosphere of radius 1e-10 to 1e-40 (subnormal corners)
/// near the origin, rays from its centre aimed at every vertex and edge midpoint, per ray and
/// batched, every structure: no leak, and every hit on the sphere.
#[test]
fn no_leaks_at_tiny_scales() {
    let unit = icosphere(2);
    for exponent in [-10, -15, -22, -28, -35, -38, -40] {
        let r = 10f64.powi(exponent) as f32;
        let mesh = Mesh::new(
            unit.vertices().iter().map(|&v| v * r).collect(),
            unit.triangles().to_vec(),
        )
        .unwrap();
        let verts = mesh.vertices();
        let targets: Vec<Vec3> = verts
            .iter()
            .copied()
            .chain(
                edges(&mesh)
                    .iter()
                    .map(|&(a, b)| (verts[a as usize] + verts[b as usize]) * 0.5),
            )
            .collect();
        // Aimed with a direction scaled up by a power of two (exact): a subnormal direction
        // counts as zero (`Ray::validate`).
        let unit_scale = 2f32.powi((-r.log2().floor() as i32).min(100));
        let rays: Vec<Ray> = targets
            .iter()
            .map(|&t| Ray::new(Vec3::ZERO, t * unit_scale))
            .collect();
        let zoo = structures_with(&mesh, &AccelKind::ALL, &[4], &[ChildOrdering::Pns]);
        for t in &zoo {
            let mut batched = vec![None; rays.len()];
            t.accel.cast_ray_batch(&rays, &mut batched).unwrap();
            for (ray, b) in rays.iter().zip(&batched) {
                let hit = t.accel.cast_ray(ray);
                let h = hit.unwrap_or_else(|| panic!("{}, radius {r}: leak {ray:?}", t.name));
                assert_eq!(hit, *b, "{}, radius {r}: batched differs", t.name);
                // The facets are within 2% of the sphere (measured in f64: squares of
                // coordinates this small underflow in f32).
                let at = ray.at(h.t).as_dvec3().length() / f64::from(r);
                assert!(
                    (0.97..=1.0001).contains(&at),
                    "{}, radius {r}: hit at radius {at} r, {ray:?}, {h:?}",
                    t.name
                );
            }
        }
    }
}
