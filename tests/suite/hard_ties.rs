//! Hard cases where several triangles are hit at the same `t`: exact duplicates (in one leaf
//! or spread over many), rotated and flipped copies, stacked planes. The closest hit must be
//! the lowest id among the triangles hit at the smallest `t`, and `all_hits` must be sorted by
//! `(t, id)`, in every structure of the zoo, bit for bit like the brute-force reference.

use crate::common::meshes::{icosphere, tri_mesh};
use crate::common::oracles::{
    HitBits, assert_matches_brute_force, bits, closest_ids, closest_is_first_of_all_hits,
    unanimous_hit,
};
use crate::common::rng::{RngExt, in_box, in_cube, seeded};
use crate::common::zoo::all_structures;
use glam::Vec3;
use raybatch::brute_force;
use raybatch::{Hit, Kernel, Mesh, Ray};

/// Two copies of one triangle, a ray aimed at a corner. The kernel's `t` may round below the
/// copy's box entry distance; unless the hit is raised to it (`agree_with_bounds`), with leaf
/// size 1 and fixed ordering the box of triangle 0 would be culled and id 1 reported.
#[test]
fn ties_at_box_boundaries_pick_lowest_id() {
    let mesh = tri_mesh(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[[0, 1, 2], [0, 1, 2]],
    );
    let zoo = all_structures(&mesh);
    let mut rng = seeded(23);
    let mut hits = 0;
    let mut origins = vec![Vec3::new(-0.78, 0.04, 0.16)];
    for _ in 0..2000 {
        origins.push(Vec3::new(
            rng.random_range(-100i32..100) as f32 * 0.01,
            rng.random_range(-100i32..100) as f32 * 0.01,
            rng.random_range(1i32..100) as f32 * 0.01,
        ));
    }
    for origin in origins {
        for corner in mesh.vertices() {
            let ray = Ray::new(origin, *corner - origin);
            assert_matches_brute_force(&mesh, &zoo, &ray);
            // An isolated corner may be missed by rounding; a hit is on both copies.
            if let Some(h) = unanimous_hit(&zoo, &ray) {
                assert_eq!(h.triangle, 0, "{ray:?}");
                hits += 1;
            }
        }
    }
    assert!(hits > 3000, "{hits}");
}

#[test]
fn ties_pick_lowest_id() {
    // A tilted triangle (no axis-aligned box face through its interior) duplicated under
    // several ids, mixed with an icosphere so the copies land in different leaves.
    let sphere = icosphere(1);
    let (mut vertices, mut triangles) = sphere.into_parts();
    let tri = [
        Vec3::new(3.0, 0.1, -0.2),
        Vec3::new(3.5, 1.2, 0.3),
        Vec3::new(2.8, 0.4, 1.1),
    ];
    let shared = vertices.len() as u32;
    vertices.extend(tri);
    let shared_tri = [shared, shared + 1, shared + 2];
    // Exact duplicates (same indices) at ids 7, 23, 40, 61; copies through fresh vertices at
    // ids 15 and 70.
    let mut dup_ids = vec![];
    for (id, fresh) in [
        (7usize, false),
        (15, true),
        (23, false),
        (40, false),
        (61, false),
    ] {
        let t = if fresh {
            let b = vertices.len() as u32;
            vertices.extend(tri);
            [b, b + 1, b + 2]
        } else {
            shared_tri
        };
        triangles.insert(id, t);
        dup_ids.push(id as u32);
    }
    let b = vertices.len() as u32;
    vertices.extend(tri);
    triangles.push([b, b + 1, b + 2]);
    dup_ids.push(triangles.len() as u32 - 1);
    let mesh = Mesh::new(vertices, triangles).unwrap();
    let lowest = dup_ids[0];
    let zoo = all_structures(&mesh);
    let mut rng = seeded(9);
    let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
    for k in 0..400 {
        // Origins all around (every octant of direction), aimed at interior points.
        let origin = centroid + in_cube(&mut rng, 3.0);
        let (u, v) = (
            rng.random_range(0.05f32..0.45),
            rng.random_range(0.05f32..0.45),
        );
        let target = tri[0] * (1.0 - u - v) + tri[1] * u + tri[2] * v;
        let ray = if k % 2 == 0 {
            Ray::new(origin, target - origin)
        } else {
            Ray::segment(origin, target + (target - origin))
        };
        assert_matches_brute_force(&mesh, &zoo, &ray);
        // All copies are hit at the same t (same corners in the same order).
        let all = brute_force::all_hits(&mesh, &ray, Kernel::Watertight);
        let at_target: Vec<&Hit> = all
            .iter()
            .filter(|h| dup_ids.contains(&h.triangle))
            .collect();
        assert_eq!(at_target.len(), dup_ids.len(), "{ray:?}");
        assert!(at_target.iter().all(|h| h.t == at_target[0].t));
        // Unless the icosphere is in front, the closest hit is the lowest duplicate id.
        if all[0].triangle == lowest || dup_ids.contains(&all[0].triangle) {
            for t in &zoo {
                for kernel in Kernel::ALL {
                    let h = t.accel.cast_ray_with(&ray, kernel).unwrap();
                    assert_eq!(h.triangle, lowest, "{} {kernel:?} {ray:?}", t.name);
                }
            }
        }
    }
    // Rotated corners (same plane, t may differ in the last bits) and opposite winding: the
    // structures still follow brute force exactly.
    let mesh = tri_mesh(
        &[
            [3.0, 0.1, -0.2],
            [3.5, 1.2, 0.3],
            [2.8, 0.4, 1.1],
            [-1.0, -1.0, -1.0],
            [-2.0, -1.0, -1.0],
            [-1.0, -2.0, -1.0],
        ],
        &[
            [3, 4, 5],
            [1, 2, 0],
            [0, 2, 1],
            [2, 0, 1],
            [0, 1, 2],
            [3, 5, 4],
        ],
    );
    let zoo = all_structures(&mesh);
    for _ in 0..400 {
        let origin = in_box(
            &mut rng,
            Vec3::new(-1.0, -3.0, -3.0),
            Vec3::new(6.0, 3.0, 3.0),
        );
        let (u, v) = (
            rng.random_range(0.05f32..0.45),
            rng.random_range(0.05f32..0.45),
        );
        let target = tri[0] * (1.0 - u - v) + tri[1] * u + tri[2] * v;
        let ray = Ray::new(origin, target - origin);
        assert_matches_brute_force(&mesh, &zoo, &ray);
        let h = unanimous_hit(&zoo, &ray).expect("aimed at the triangle");
        assert_eq!(Some(h.triangle), closest_ids(&mesh, &ray).first().copied());
    }
}

#[test]
fn all_hits_sorted() {
    // Eleven squares at z = 0..=10 with ids out of z order, one square duplicated, and an
    // icosphere around z = 5.
    let (mut vertices, mut triangles) = icosphere(2).into_parts();
    for v in &mut vertices {
        *v = *v * 0.5 + Vec3::new(0.5, 0.5, 5.5);
    }
    let order = [7, 2, 10, 0, 5, 9, 1, 3, 8, 6, 4];
    for z in order {
        let b = vertices.len() as u32;
        let z = z as f32;
        vertices.extend([
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(2.0, -1.0, z),
            Vec3::new(2.0, 2.0, z),
            Vec3::new(-1.0, 2.0, z),
        ]);
        triangles.insert(0, [b, b + 1, b + 2]);
        triangles.push([b, b + 2, b + 3]);
    }
    let dup = triangles[5];
    triangles.insert(2, dup);
    let mesh = Mesh::new(vertices, triangles).unwrap();
    let zoo = all_structures(&mesh);
    let mut rng = seeded(13);
    for k in 0..300 {
        // Through the sphere (centre (0.5, 0.5, 5.5), radius 0.5) and every square.
        let (x, y) = (
            rng.random_range(0.35f32..0.65),
            rng.random_range(0.35f32..0.65),
        );
        let dir = Vec3::new(
            rng.random_range(-0.02f32..0.02),
            rng.random_range(-0.02f32..0.02),
            1.0,
        );
        let ray = if k % 3 == 0 {
            Ray::new(Vec3::new(x, y, 11.0), -dir)
        } else {
            Ray::new(Vec3::new(x, y, -1.0), dir)
        };
        assert_matches_brute_force(&mesh, &zoo, &ray);
        if let Err(e) = closest_is_first_of_all_hits(&mesh, &ray) {
            panic!("{e}");
        }
        let expected: Vec<HitBits> = brute_force::all_hits(&mesh, &ray, Kernel::Watertight)
            .iter()
            .map(bits)
            .collect();
        // 11 planes (+ the duplicate where the ray crosses its half of the square) + at least
        // 2 sphere crossings.
        assert!(expected.len() >= 13, "{} hits for {ray:?}", expected.len());
        let mut plane_zs: Vec<f32> = brute_force::all_hits(&mesh, &ray, Kernel::Watertight)
            .iter()
            .map(|h| ray.at(h.t).z.round())
            .collect();
        plane_zs.dedup();
        assert!(plane_zs.len() >= 11, "{plane_zs:?}");
        for t in &zoo {
            let hits = t.accel.all_hits(&ray);
            for w in hits.windows(2) {
                assert!(
                    w[0].t < w[1].t || (w[0].t == w[1].t && w[0].triangle < w[1].triangle),
                    "{}: not sorted by (t, id): {w:?}",
                    t.name
                );
            }
            assert_eq!(
                hits.iter().map(bits).collect::<Vec<_>>(),
                expected,
                "{}",
                t.name
            );
            // Plane hits come in z order along the ray.
            let zs: Vec<f32> = hits.iter().map(|h| ray.at(h.t).z).collect();
            let ascending = ray.dir.z > 0.0;
            assert!(
                zs.windows(2)
                    .all(|w| (w[0] <= w[1]) == ascending || w[0] == w[1])
            );
            assert_eq!(
                Some(hits[0]),
                t.accel.cast_ray_with(&ray, Kernel::Watertight)
            );
        }
    }
}

/// The tie rule seen through `all_hits`: at a t = 0 tie the closest hit must come first.
#[test]
fn all_hits_orders_signed_zero_t_by_id() {
    // One triangle in both windings; the ray starts on their shared edge.
    let mesh = tri_mesh(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[[0, 1, 2], [0, 2, 1]],
    );
    let zoo = all_structures(&mesh);
    let ray = Ray::new(Vec3::new(0.5, 0.0, 0.0), Vec3::new(-1.0, 0.0, 1.0));
    for t in &zoo {
        let all = t.accel.all_hits(&ray);
        let closest = t.accel.cast_ray_with(&ray, Kernel::Watertight).unwrap();
        assert_eq!(closest.triangle, 0);
        assert_eq!(
            all.iter().map(|h| h.triangle).collect::<Vec<_>>(),
            vec![0, 1],
            "{}: {all:?}",
            t.name
        );
        assert_eq!(bits(&all[0]), bits(&closest), "{}", t.name);
    }
}
