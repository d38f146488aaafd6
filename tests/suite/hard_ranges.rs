//! Hard cases of ray ranges: rays starting on the surface (`t = 0` included, a positive `tmin`
//! excluded), segments ending or starting exactly on a triangle (both ends included, one ulp
//! short excluded), unbounded and huge `tmax`, extreme direction lengths. Every structure of
//! the zoo is compared with the brute-force reference and checked for the expected answer.

use crate::common::meshes::{icosphere, tri_mesh};
use crate::common::oracles::{assert_matches_brute_force, unanimous_hit};
use crate::common::rng::{RngExt, in_cube, seeded};
use crate::common::zoo::all_structures;
use glam::Vec3;
use raybatch::brute_force;
use raybatch::{Kernel, Mesh, Ray};

/// The triangles that use `vertex`.
fn incident_triangles(mesh: &Mesh, vertex: u32) -> Vec<u32> {
    (0..mesh.triangle_count() as u32)
        .filter(|&id| mesh.triangles()[id as usize].contains(&vertex))
        .collect()
}

#[test]
fn ray_starting_on_surface() {
    // A unit square at z = 0 (ids 0, 1, sharing the diagonal (0,0)-(1,1)) and a triangle above.
    let mesh = tri_mesh(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, -1.0, 1.0],
            [3.0, -1.0, 1.0],
            [-1.0, 3.0, 1.0],
        ],
        &[[0, 1, 2], [0, 2, 3], [4, 5, 6]],
    );
    let zoo = all_structures(&mesh);
    let dirs = [
        Vec3::Z,
        -Vec3::Z,
        Vec3::new(0.3, 0.2, 1.0),
        Vec3::new(-0.3, 0.1, -1.0),
    ];
    // (origin, id expected at t = 0): inside triangle 0, inside 1, on their shared edge.
    for (origin, id) in [
        (Vec3::new(0.75, 0.25, 0.0), 0),
        (Vec3::new(0.25, 0.75, 0.0), 1),
        (Vec3::new(0.5, 0.5, 0.0), 0),
        (Vec3::new(0.0, 0.0, 0.0), 0),
    ] {
        for dir in dirs {
            let ray = Ray::new(origin, dir);
            assert_matches_brute_force(&mesh, &zoo, &ray);
            // tmin = 0 includes the surface the ray starts on: hit at t = 0.
            let h = unanimous_hit(&zoo, &ray).expect("starts on the surface");
            assert_eq!((h.triangle, h.t), (id, 0.0), "{ray:?}");
            // A positive tmin skips it: the triangle above, or nothing below.
            let ray = Ray::with_range(origin, dir, 1e-3, f32::INFINITY);
            assert_matches_brute_force(&mesh, &zoo, &ray);
            let h = unanimous_hit(&zoo, &ray);
            if dir.z > 0.0 {
                let h = h.expect("the triangle above");
                assert_eq!(h.triangle, 2);
                assert!((h.t - 1.0 / dir.z).abs() < 1e-6);
            } else {
                assert!(h.is_none(), "{h:?}");
            }
        }
    }
    // Starting on a vertex of a closed mesh, any direction hits at t = 0, on the lowest id among
    // the triangles around the vertex.
    let sphere = icosphere(1);
    let zoo = all_structures(&sphere);
    let mut rng = seeded(7);
    for v in 0..sphere.vertices().len() as u32 {
        let origin = sphere.vertices()[v as usize];
        let lowest = *incident_triangles(&sphere, v).iter().min().unwrap();
        for _ in 0..4 {
            let dir = in_cube(&mut rng, 1.0);
            let ray = Ray::new(origin, dir);
            assert_matches_brute_force(&sphere, &zoo, &ray);
            let h = unanimous_hit(&zoo, &ray).expect("starts on the surface");
            assert_eq!(h.t, 0.0);
            assert_eq!(h.triangle, lowest, "vertex {v}, {ray:?}");
        }
    }
}

#[test]
fn segment_occlusion_respects_endpoints() {
    let z = 1.0f32;
    let mesh = tri_mesh(
        &[[-1.0, -1.0, z], [3.0, -1.0, z], [-1.0, 3.0, z]],
        &[[0, 1, 2]],
    );
    let zoo = all_structures(&mesh);
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // (segment, occluded?)
    let cases = [
        // Ends exactly on the triangle: occluded (t = 1 is included).
        (Ray::segment(p(0.25, 0.25, 0.0), p(0.25, 0.25, z)), true),
        (Ray::segment(p(0.25, 0.25, 3.0), p(0.25, 0.25, z)), true),
        (Ray::segment(p(-0.5, 0.7, 0.0), p(0.5, 0.2, z)), true),
        // Starts exactly on it: occluded (t = 0 is included).
        (Ray::segment(p(0.25, 0.25, z), p(0.25, 0.25, 2.0)), true),
        (Ray::segment(p(0.25, 0.25, z), p(0.25, 0.25, 0.0)), true),
        // Stops one ulp short, or starts one ulp past: not occluded.
        (
            Ray::segment(p(0.25, 0.25, 0.0), p(0.25, 0.25, z.next_down())),
            false,
        ),
        (
            Ray::segment(p(0.25, 0.25, 3.0), p(0.25, 0.25, z.next_up())),
            false,
        ),
        (
            Ray::segment(p(0.25, 0.25, z.next_up()), p(0.25, 0.25, 2.0)),
            false,
        ),
        // Crosses it: occluded; beside it: not.
        (Ray::segment(p(0.25, 0.25, 0.0), p(0.25, 0.25, 2.0)), true),
        (Ray::segment(p(2.0, 2.0, 0.0), p(2.0, 2.0, 2.0)), false),
        // A point range on the surface.
        (Ray::with_range(p(0.25, 0.25, 0.0), Vec3::Z, z, z), true),
        (
            Ray::with_range(p(0.25, 0.25, 0.0), Vec3::Z, 0.5, 0.5),
            false,
        ),
    ];
    for (ray, occluded) in cases {
        assert_matches_brute_force(&mesh, &zoo, &ray);
        for t in &zoo {
            assert_eq!(
                t.accel.occluded_with(&ray, Kernel::Watertight),
                occluded,
                "{} {ray:?}",
                t.name
            );
            assert_eq!(t.accel.occluded(&ray), occluded);
        }
        if occluded && ray.dir.x == 0.0 {
            // Axis-aligned: t is exact, the hit point is on the plane.
            let h = unanimous_hit(&zoo, &ray).unwrap();
            assert_eq!(ray.at(h.t).z, z, "{ray:?} {h:?}");
        }
    }
    // Segments from random points to random points of the triangle, its edges and corners: the
    // structures agree with brute force, and a watertight hit at t <= 1 is occlusion.
    let sphere = icosphere(1);
    let zoo = all_structures(&sphere);
    let mut rng = seeded(5);
    let mut occluded_count = 0;
    for _ in 0..3000 {
        let from = in_cube(&mut rng, 3.0);
        let v = sphere.vertices();
        let a = v[rng.random_range(0..v.len())];
        let b = v[rng.random_range(0..v.len())];
        let to = match rng.random_range(0..3) {
            0 => a,
            1 => (a + b) * 0.5,
            _ => a.lerp(b, rng.random_range(0.0f32..1.0)),
        };
        let ray = Ray::segment(from, to);
        assert_matches_brute_force(&sphere, &zoo, &ray);
        let expected = brute_force::occluded(&sphere, &ray, Kernel::Watertight);
        occluded_count += expected as usize;
        for t in &zoo {
            assert_eq!(
                t.accel.occluded_with(&ray, Kernel::Watertight),
                expected,
                "{}",
                t.name
            );
        }
    }
    assert!(occluded_count > 1000, "{occluded_count}");
}

#[test]
fn unbounded_tmax() {
    let far = 1e11f32;
    let mesh = tri_mesh(
        &[
            [-1.0, -1.0, 5.0],
            [1.0, -1.0, 5.0],
            [0.0, 1.0, 5.0],
            [-far, -far, far],
            [far, -far, far],
            [0.0, far, far],
        ],
        &[[3, 4, 5], [0, 1, 2]],
    );
    let zoo = all_structures(&mesh);
    let origin = Vec3::new(0.5, 0.5, 0.0);
    // Past the near triangle (it is at (0, 0) +- 1): only the far one.
    for tmax in [f32::INFINITY, f32::MAX] {
        let ray = Ray::with_range(origin, Vec3::Z, 0.0, tmax);
        assert_matches_brute_force(&mesh, &zoo, &ray);
        let h = unanimous_hit(&zoo, &ray).expect("the far triangle");
        assert_eq!((h.triangle, h.t), (0, far));
        let ray = Ray::with_range(origin, Vec3::Z, 0.0, far.next_down());
        assert!(unanimous_hit(&zoo, &ray).is_none());
        assert_matches_brute_force(&mesh, &zoo, &ray);
    }
    // Direction lengths from 1e-3 to 1e20: t scales inversely (smaller lengths: see
    // `small_direction_far_triangle_is_hit` in hard_precision.rs).
    for scale in [1e-3f32, 1.0, 1e10, 1e20] {
        let ray = Ray::new(origin, Vec3::Z * scale);
        assert_matches_brute_force(&mesh, &zoo, &ray);
        let h = unanimous_hit(&zoo, &ray).expect("the far triangle");
        assert_eq!(h.triangle, 0);
        assert!(h.t.is_finite());
        assert!((h.t * scale / far - 1.0).abs() < 1e-6, "{h:?}");
        // Through the near triangle: both, near first.
        let ray = Ray::new(Vec3::ZERO, Vec3::Z * scale);
        assert_matches_brute_force(&mesh, &zoo, &ray);
        let ids: Vec<u32> = zoo[0]
            .accel
            .all_hits(&ray)
            .iter()
            .map(|h| h.triangle)
            .collect();
        assert_eq!(ids, vec![1, 0]);
        assert_eq!(unanimous_hit(&zoo, &ray).unwrap().triangle, 1);
    }
    // No query ever reports a non-finite t, however extreme the direction.
    for scale in [
        1e-30f32,
        1e-35,
        1e-36,
        1e-37,
        f32::MIN_POSITIVE,
        1e30,
        f32::MAX,
    ] {
        for origin in [Vec3::ZERO, origin] {
            let ray = Ray::new(origin, Vec3::Z * scale);
            assert_matches_brute_force(&mesh, &zoo, &ray);
            for t in &zoo {
                for kernel in Kernel::ALL {
                    if let Some(h) = t.accel.cast_ray_with(&ray, kernel) {
                        assert!(h.t.is_finite(), "{} {kernel:?}: {h:?}", t.name);
                    }
                }
                for h in t.accel.all_hits(&ray) {
                    assert!(h.t.is_finite(), "{}: {h:?}", t.name);
                }
            }
        }
    }
}
