//! Hard cases of degenerate input: zero-area triangles of every kind (never hit), rays in the
//! plane of a triangle (never hit), meshes with no triangles or only degenerate ones (empty
//! structures that miss everything). Every structure of the zoo is compared with the
//! brute-force reference and checked for the expected answer.

use crate::common::meshes::tri_mesh;
use crate::common::oracles::{assert_matches_brute_force, assert_misses_everywhere, unanimous_hit};
use crate::common::rng::{in_cube, seeded};
use crate::common::zoo::all_structures;
use glam::Vec3;
use raybatch::{Kernel, Mesh, Ray};

#[test]
fn degenerate_triangles_are_never_hit() {
    // Good triangles at ids 1, 4 and 7 (z = 1, 2, 3); every other triangle is degenerate:
    // repeated indices, collinear corners, three distinct indices on one point, a zero-area
    // segment lying across triangle 4.
    let mesh = tri_mesh(
        &[
            [0.0, 0.0, 1.0],   // 0
            [1.0, 0.0, 1.0],   // 1
            [0.0, 1.0, 1.0],   // 2
            [0.0, 0.0, 2.0],   // 3
            [1.0, 0.0, 2.0],   // 4
            [0.0, 1.0, 2.0],   // 5
            [0.0, 0.0, 3.0],   // 6
            [1.0, 0.0, 3.0],   // 7
            [0.0, 1.0, 3.0],   // 8
            [2.0, 2.0, 5.0],   // 9
            [2.0, 2.0, 5.0],   // 10
            [2.0, 2.0, 5.0],   // 11
            [0.0, 0.0, 2.0],   // 12 (= 3)
            [0.25, 0.25, 2.0], // 13
            [0.5, 0.5, 2.0],   // 14
            [0.0, 0.0, 4.0],   // 15
            [0.5, 0.0, 4.0],   // 16
            [1.0, 0.0, 4.0],   // 17
        ],
        &[
            [0, 0, 1],    // 0: repeated index
            [0, 1, 2],    // 1: good
            [9, 10, 11],  // 2: one point
            [12, 13, 14], // 3: segment across triangle 4
            [3, 4, 5],    // 4: good
            [15, 16, 17], // 5: collinear
            [2, 2, 2],    // 6: one index
            [6, 7, 8],    // 7: good
            [15, 17, 16], // 8: collinear, other order
            [13, 14, 13], // 9: repeated index
        ],
    );
    let good = [1u32, 4, 7];
    for id in 0..mesh.triangle_count() as u32 {
        assert_eq!(mesh.is_degenerate(id), !good.contains(&id), "triangle {id}");
    }
    let zoo = all_structures(&mesh);
    let mut rays = vec![];
    // Straight down through the good triangles' interiors and corners, and through the
    // degenerate ones.
    for p in [
        [0.25f32, 0.25],
        [0.2, 0.1],
        [0.0, 0.0],
        [0.5, 0.5],
        [0.5, 0.0],
        [0.75, 0.0],
        [1.0, 0.0],
    ] {
        rays.push(Ray::new(Vec3::new(p[0], p[1], 10.0), -Vec3::Z));
        rays.push(Ray::new(Vec3::new(p[0], p[1], -10.0), Vec3::Z));
    }
    // Along the degenerate segments and at the point.
    rays.push(Ray::new(Vec3::new(-1.0, 0.0, 4.0), Vec3::X));
    rays.push(Ray::new(
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(0.25, 0.25, 0.0),
    ));
    rays.push(Ray::new(Vec3::new(2.0, 2.0, 6.0), -Vec3::Z));
    rays.push(Ray::new(Vec3::new(2.0, -1.0, 5.0), Vec3::Y));
    for ray in &rays {
        assert_matches_brute_force(&mesh, &zoo, ray);
        for t in &zoo {
            for h in t.accel.all_hits(ray) {
                assert!(
                    good.contains(&h.triangle),
                    "{}: hit {h:?} on {ray:?}",
                    t.name
                );
            }
            for kernel in Kernel::ALL {
                if let Some(h) = t.accel.cast_ray_with(ray, kernel) {
                    assert!(good.contains(&h.triangle), "{} {kernel:?}: {h:?}", t.name);
                }
            }
        }
    }
    // Interior hits report the good triangles' own ids, in z order.
    let down = Ray::new(Vec3::new(0.25, 0.25, 10.0), -Vec3::Z);
    let ids: Vec<u32> = zoo[0]
        .accel
        .all_hits(&down)
        .iter()
        .map(|h| h.triangle)
        .collect();
    assert_eq!(ids, vec![7, 4, 1]);
    assert_eq!(unanimous_hit(&zoo, &down).unwrap().triangle, 7);
    let up = Ray::new(Vec3::new(0.25, 0.25, -10.0), Vec3::Z);
    assert_eq!(unanimous_hit(&zoo, &up).unwrap().triangle, 1);
    // Nothing but degenerate triangles along these.
    for ray in &rays[rays.len() - 4..] {
        assert!(unanimous_hit(&zoo, ray).is_none(), "{ray:?}");
    }
}

#[test]
fn ray_parallel_to_triangle_plane() {
    // Triangles in the planes z = 0 (id 0), x = 2 (id 1) and y = -1 (id 2), far enough apart
    // that an in-plane ray of one cannot reach the others.
    let mesh = tri_mesh(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 3.0, 3.0],
            [2.0, 4.0, 3.0],
            [2.0, 3.0, 4.0],
            [-5.0, -1.0, -5.0],
            [-4.0, -1.0, -5.0],
            [-5.0, -1.0, -4.0],
        ],
        &[[0, 1, 2], [3, 4, 5], [6, 7, 8]],
    );
    let zoo = all_structures(&mesh);
    // In-plane rays crossing the triangles' interiors, edges and vertices: all miss.
    let in_plane = [
        Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::X),
        Ray::new(Vec3::new(-1.0, 0.25, -0.0), Vec3::new(1.0, 0.3, 0.0)),
        Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::new(1.0, -0.0, -0.0)),
        Ray::new(Vec3::new(0.25, -3.0, 0.0), Vec3::Y),
        Ray::new(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)),
        Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::new(2.0, 3.25, -1.0), Vec3::Z),
        Ray::new(Vec3::new(2.0, 0.0, 3.25), Vec3::new(0.0, 1.0, 0.01)),
        Ray::new(Vec3::new(2.0, 3.0, 0.0), Vec3::new(-0.0, 0.0, 1.0)),
        Ray::new(Vec3::new(-4.75, -1.0, -10.0), Vec3::Z),
        Ray::new(Vec3::new(-10.0, -1.0, -4.75), Vec3::new(1.0, 0.0, -0.0)),
    ];
    for ray in in_plane {
        assert_matches_brute_force(&mesh, &zoo, &ray);
        assert!(unanimous_hit(&zoo, &ray).is_none(), "{ray:?} hit");
        for t in &zoo {
            for kernel in Kernel::ALL {
                assert!(
                    !t.accel.occluded_with(&ray, kernel),
                    "{} {kernel:?} {ray:?}",
                    t.name
                );
            }
        }
    }
    // Slightly off the plane, aimed at (0.25, 0.25, 0): hit at t = 1.
    for eps in [1e-3f32, 1e-6, -1e-6, 1e-20] {
        let origin = Vec3::new(-1.0, 0.25, eps);
        let ray = Ray::new(origin, Vec3::new(0.25, 0.25, 0.0) - origin);
        assert_matches_brute_force(&mesh, &zoo, &ray);
        let h = unanimous_hit(&zoo, &ray).unwrap_or_else(|| panic!("{ray:?} missed"));
        assert_eq!(h.triangle, 0);
        assert!((h.t - 1.0).abs() < 1e-5, "{h:?}");
    }
    // Almost parallel: crosses the plane far outside the triangle.
    let ray = Ray::new(Vec3::new(-1.0, 0.25, 1e-3), Vec3::new(1.0, 0.0, -1e-30));
    assert_matches_brute_force(&mesh, &zoo, &ray);
    assert!(unanimous_hit(&zoo, &ray).is_none());
}

#[test]
fn empty_mesh_misses_everything() {
    let empty = Mesh::new(vec![], vec![]).unwrap();
    let no_triangles = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![]).unwrap();
    for mesh in [empty, no_triangles] {
        assert!(mesh.is_empty());
        let zoo = all_structures(&mesh);
        for t in &zoo {
            assert_eq!(t.accel.node_count(), 0, "{}", t.name);
        }
        let mut rng = seeded(3);
        let mut rays = vec![
            Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z),
            Ray::new(Vec3::ZERO, Vec3::X),
            Ray::segment(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.2, 0.2, 1.0)),
        ];
        for _ in 0..100 {
            rays.push(Ray::new(in_cube(&mut rng, 2.0), in_cube(&mut rng, 2.0)));
        }
        for ray in &rays {
            assert_misses_everywhere(&mesh, &zoo, ray);
        }
    }
}

#[test]
fn only_degenerate_triangles() {
    let mesh = tri_mesh(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        &[
            [0, 1, 2],
            [0, 0, 3],
            [3, 4, 3],
            [2, 1, 0],
            [1, 1, 1],
            [3, 4, 4],
        ],
    );
    for id in 0..mesh.triangle_count() as u32 {
        assert!(mesh.is_degenerate(id));
    }
    let zoo = all_structures(&mesh);
    for t in &zoo {
        assert_eq!(t.accel.node_count(), 0, "{}", t.name);
    }
    for ray in [
        Ray::new(Vec3::new(0.5, 0.0, -1.0), Vec3::Z),
        Ray::new(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z),
        Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::new(0.5, 0.0, 0.0), Vec3::Y),
        Ray::new(Vec3::new(0.0, 1.0, -1.0), Vec3::Z),
        Ray::new(Vec3::new(0.0, 0.5, -1.0), Vec3::new(0.0, 0.5, 1.0)),
    ] {
        assert_misses_everywhere(&mesh, &zoo, &ray);
    }
}
