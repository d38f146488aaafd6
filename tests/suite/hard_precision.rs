//! Hard cases of floating-point precision: a mesh far from the origin (offset 1e5), tiny
//! triangles next to huge ones, and directions so short that `t` grows past 1e21. Every
//! structure of the zoo is compared with the brute-force reference and checked for the
//! expected answer.

use crate::common::meshes::{assert_closed_and_outward, edges, icosphere, transformed, tri_mesh};
use crate::common::oracles::{assert_matches_brute_force, unanimous_hit};
use crate::common::rng::{in_cube, seeded};
use crate::common::zoo::all_structures;
use glam::{DVec3, Vec3};
use raybatch::{Kernel, Ray};

#[test]
fn mesh_offset_by_1e5() {
    let offset = DVec3::splat(1e5);
    let mesh = transformed(&icosphere(3), 1.0, offset);
    let center = offset.as_vec3();
    assert_eq!(center, Vec3::splat(100_000.0));
    assert_closed_and_outward(&mesh, center);
    let zoo = all_structures(&mesh);
    let mut targets: Vec<Vec3> = mesh.vertices().to_vec();
    for (a, b) in edges(&mesh) {
        targets.push((mesh.vertices()[a as usize] + mesh.vertices()[b as usize]) * 0.5);
    }
    let mut rng = seeded(11);
    for _ in 0..500 {
        let d = in_cube(&mut rng, 1.0);
        targets.push(center + d);
    }
    let origins = [center, center + Vec3::new(-0.5, 0.25, 0.125)];
    for origin in origins {
        for &target in &targets {
            let ray = Ray::new(origin, target - origin);
            assert_matches_brute_force(&mesh, &zoo, &ray);
            for t in &zoo {
                let h = t
                    .accel
                    .cast_ray_with(&ray, Kernel::Watertight)
                    .unwrap_or_else(|| panic!("{}: leak from {origin} towards {target}", t.name));
                let r = (ray.at(h.t) - center).length();
                assert!((r - 1.0).abs() < 0.05, "{}: hit at radius {r}", t.name);
            }
        }
    }
}

#[test]
fn tiny_and_huge_triangles_together() {
    let big = 1e4f32;
    let mut vertices = vec![
        // A floor at z = 0 and a wall at x = 1e4, both 2e4 wide.
        [-big, -big, 0.0],
        [big, -big, 0.0],
        [big, big, 0.0],
        [-big, big, 0.0],
        [big, -big, -big],
        [big, big, -big],
        [big, 0.0, big],
    ];
    let mut triangles = vec![[0u32, 1, 2], [0, 2, 3], [4, 5, 6]];
    let s = 1e-4f32;
    let spots = [
        [0.0f32, 0.0, 1.0],
        [0.37, -0.21, 1.0],
        [-50.0, 25.5, 2.0],
        [99.9, -80.25, 0.5],
        [3.0, 3.0, 1e-3],
    ];
    for p in spots {
        let base = vertices.len() as u32;
        vertices.extend([
            [p[0], p[1], p[2]],
            [p[0] + s, p[1], p[2]],
            [p[0], p[1] + s, p[2]],
        ]);
        triangles.push([base, base + 1, base + 2]);
    }
    let mesh = tri_mesh(&vertices, &triangles);
    for id in 0..mesh.triangle_count() as u32 {
        assert!(!mesh.is_degenerate(id));
    }
    let zoo = all_structures(&mesh);
    for (k, p) in spots.iter().enumerate() {
        let tiny = 3 + k as u32;
        let centroid = Vec3::new(p[0] + s / 3.0, p[1] + s / 3.0, p[2]);
        for from in [
            Vec3::new(0.0, 0.0, 10.0),
            Vec3::new(3.0, -4.0, 10.0),
            Vec3::new(-2.0, 1.0, 3.0),
        ] {
            let origin = centroid + from;
            let ray = Ray::new(origin, centroid - origin);
            assert_matches_brute_force(&mesh, &zoo, &ray);
            let h = unanimous_hit(&zoo, &ray).unwrap_or_else(|| panic!("{ray:?} missed"));
            assert_eq!(h.triangle, tiny, "{ray:?}");
            assert!((h.t - 1.0).abs() < 1e-4, "{h:?}");
            // All hits: the tiny triangle, then the floor behind it.
            let all: Vec<u32> = zoo[0]
                .accel
                .all_hits(&ray)
                .iter()
                .map(|h| h.triangle)
                .collect();
            assert_eq!(all[0], tiny);
            assert!(all[1..].iter().all(|&id| id < 3), "{all:?}");
            // Beside the tiny triangle by twice its size: the floor.
            let beside = Ray::new(origin + Vec3::new(2.0 * s, 0.0, 0.0), centroid - origin);
            assert_matches_brute_force(&mesh, &zoo, &beside);
            let h = unanimous_hit(&zoo, &beside).expect("the floor");
            assert!(h.triangle < 2, "{h:?}");
        }
    }
    // Long rays across the whole scene hit the wall.
    for y in [-4000.0f32, 0.0, 1234.5] {
        let ray = Ray::new(Vec3::new(-big, y, 1.0), Vec3::X);
        assert_matches_brute_force(&mesh, &zoo, &ray);
        let h = unanimous_hit(&zoo, &ray).expect("the wall");
        assert_eq!((h.triangle, h.t), (2, 2.0 * big));
    }
}

/// Short directions: `t` grows to 1e21 and more, still finite. The watertight kernel computes
/// `t * det` before dividing, which overflows.
#[test]
fn small_direction_far_triangle_is_hit() {
    let far = 1e11f32;
    let mesh = tri_mesh(
        &[[-far, -far, far], [far, -far, far], [0.0, far, far]],
        &[[0, 1, 2]],
    );
    let zoo = all_structures(&mesh);
    for scale in [1e-10f32, 1e-20] {
        let ray = Ray::new(Vec3::new(0.5, 0.5, 0.0), Vec3::Z * scale);
        for t in &zoo {
            let h = t.accel.cast_ray_with(&ray, Kernel::Watertight);
            let h = h.unwrap_or_else(|| panic!("{}: missed with |dir| = {scale}", t.name));
            assert!((h.t * scale / far - 1.0).abs() < 1e-6, "{h:?}");
        }
    }
}
