//! Named hard cases. Each compares every tree combination ({full, quantized} x leaf {1, 4, 16}
//! x {fixed, split-axis, PNS}) with the brute-force reference and checks the expected answer.

mod common;

use std::collections::HashMap;

use common::{
    HitBits, TreeKind, all_trees, assert_closed_and_outward, assert_matches_brute_force, bits,
    closest_ids, closest_is_first_of_all_hits, edges, icosphere, opt_bits, transformed, trees_with,
};
use glam::{DVec3, Vec3};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use raybatch::query::brute_force;
use raybatch::{ChildOrdering, Hit, Kernel, Mesh, Ray, RayError};

/// An axis-aligned box `[-h, h]^3` whose faces are split into `n x n` squares of two
/// triangles each, vertices shared between faces, wound outward.
fn tessellated_cube(n: i32, h: f32) -> Mesh {
    let mut index: HashMap<[i32; 3], u32> = HashMap::new();
    let mut vertices = Vec::new();
    let mut id = |p: [i32; 3], vertices: &mut Vec<Vec3>| -> u32 {
        *index.entry(p).or_insert_with(|| {
            let s = 2.0 * h / n as f32;
            vertices.push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) * s - Vec3::splat(h));
            (vertices.len() - 1) as u32
        })
    };
    let mut triangles = Vec::new();
    for axis in 0..3 {
        for side in [0, n] {
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: i32, dj: i32| {
                        let mut p = [0; 3];
                        p[axis] = side;
                        p[a1] = i + di;
                        p[a2] = j + dj;
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)]
                        .map(|p| id(p, &mut vertices));
                    // (a1, a2, axis) is right-handed: counter-clockwise in (a1, a2) faces +axis.
                    let (t0, t1) = if side == n {
                        ([q[0], q[1], q[2]], [q[0], q[2], q[3]])
                    } else {
                        ([q[0], q[2], q[1]], [q[0], q[3], q[2]])
                    };
                    triangles.extend([t0, t1]);
                }
            }
        }
    }
    Mesh::new(vertices, triangles).unwrap()
}

fn tri_mesh(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> Mesh {
    Mesh::new(
        vertices.iter().map(|&v| Vec3::from_array(v)).collect(),
        triangles.to_vec(),
    )
    .unwrap()
}

/// Every tree's watertight closest hit, checked to be the same bits for all trees.
#[track_caller]
fn unanimous_hit(trees: &[common::TreeUnderTest], ray: &Ray) -> Option<Hit> {
    let first = trees[0].tree.cast(ray, Kernel::Watertight);
    for t in trees {
        let h = t.tree.cast(ray, Kernel::Watertight);
        assert_eq!(
            opt_bits(h),
            opt_bits(first),
            "{} disagrees on {ray:?}",
            t.name
        );
    }
    first
}

fn incident_triangles(mesh: &Mesh, vertex: u32) -> Vec<u32> {
    (0..mesh.triangle_count() as u32)
        .filter(|&id| mesh.triangles()[id as usize].contains(&vertex))
        .collect()
}

#[test]
fn helper_meshes_are_closed_and_outward() {
    for sub in 0..4 {
        let m = icosphere(sub);
        assert_eq!(m.triangle_count(), 20 * 4usize.pow(sub));
        assert_closed_and_outward(&m, Vec3::ZERO);
    }
    assert_closed_and_outward(&tessellated_cube(3, 1.0), Vec3::ZERO);
}

#[test]
fn axis_parallel_rays_with_signed_zeros() {
    let mesh = tessellated_cube(4, 1.0);
    let trees = all_trees(&mesh);
    let zeros = [0.0f32, -0.0];
    let mut checked = 0;
    // Origins on grid lines (rays through shared vertices and edges) and off them.
    let coords = [-0.5f32, 0.0, 0.25, 0.3, 1.0];
    for axis in 0..3 {
        for negative in [false, true] {
            for (za, zb) in zeros.iter().flat_map(|&a| zeros.map(|b| (a, b))) {
                for magnitude in [1.0f32, 0.5] {
                    let mut dir = [0.0f32; 3];
                    dir[axis] = if negative { -magnitude } else { magnitude };
                    dir[(axis + 1) % 3] = za;
                    dir[(axis + 2) % 3] = zb;
                    let dir = Vec3::from_array(dir);
                    for &c1 in &coords {
                        for &c2 in &coords {
                            for start in [0.0f32, -3.0] {
                                let mut o = [0.0f32; 3];
                                o[axis] = if negative { -start } else { start };
                                o[(axis + 1) % 3] = c1;
                                o[(axis + 2) % 3] = c2;
                                let origin = Vec3::from_array(o);
                                let ray = Ray::new(origin, dir);
                                assert_matches_brute_force(&mesh, &trees, &ray);
                                let hit = unanimous_hit(&trees, &ray);
                                // The face the ray must reach first (the +-1 face along the
                                // axis; from outside, the near face).
                                let inside = c1.abs() <= 1.0 && c2.abs() <= 1.0;
                                let expect_t = if start == 0.0 { 1.0 } else { 2.0 } / magnitude;
                                if inside && (start == 0.0 || (c1.abs() < 1.0 && c2.abs() < 1.0)) {
                                    let h = hit.unwrap_or_else(|| panic!("{ray:?} missed"));
                                    assert_eq!(h.t, expect_t, "{ray:?}");
                                    assert_eq!(
                                        Some(h.triangle),
                                        closest_ids(&mesh, &ray).first().copied(),
                                        "not the lowest id at that t: {ray:?}"
                                    );
                                    checked += 1;
                                } else if c1.abs() > 1.0 || c2.abs() > 1.0 {
                                    assert!(hit.is_none(), "{ray:?} hit {hit:?} outside the box");
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 500, "{checked}");
}

/// Rays from inside a closed icosphere aimed exactly at each vertex and each edge midpoint:
/// every tree must hit, on a triangle touching the target, at `t` close to 1, bit-identical to
/// brute force, and the reported triangle is the lowest id among those hit at that `t`.
#[test]
fn rays_at_shared_vertices_and_edges() {
    let mesh = icosphere(2);
    let trees = all_trees(&mesh);
    let origins = [
        Vec3::ZERO,
        Vec3::new(0.1, 0.2, -0.3),
        Vec3::new(-0.4, 0.05, 0.3),
    ];
    let mut ties = 0;
    for origin in origins {
        let mut targets: Vec<(Vec3, Vec<u32>)> = (0..mesh.vertices().len() as u32)
            .map(|v| (mesh.vertices()[v as usize], vec![v]))
            .collect();
        for (a, b) in edges(&mesh) {
            let m = (mesh.vertices()[a as usize] + mesh.vertices()[b as usize]) * 0.5;
            targets.push((m, vec![a, b]));
        }
        for (target, touching) in targets {
            let ray = Ray::new(origin, target - origin);
            assert_matches_brute_force(&mesh, &trees, &ray);
            let at_closest = closest_ids(&mesh, &ray);
            ties += (at_closest.len() > 1) as usize;
            for t in &trees {
                let h = t
                    .tree
                    .cast(&ray, Kernel::Watertight)
                    .unwrap_or_else(|| panic!("{}: leak through {target} from {origin}", t.name));
                assert_eq!(Some(&h.triangle), at_closest.first(), "{}: {ray:?}", t.name);
                let tri = mesh.triangles()[h.triangle as usize];
                assert!(
                    touching.iter().all(|v| tri.contains(v)),
                    "{}: hit triangle {} {tri:?} does not touch {touching:?}",
                    t.name,
                    h.triangle
                );
                assert!((h.t - 1.0).abs() < 1e-5, "{}: t = {}", t.name, h.t);
            }
        }
    }
    // The targets really produce equal-t hits on several triangles.
    assert!(ties > 100, "{ties}");
}

/// Regression: two copies of one triangle, a ray aimed at a corner. The kernel's `t` used to
/// round below the copy's box entry distance, so with leaf size 1 and fixed ordering the box
/// of triangle 0 was culled and id 1 reported.
#[test]
fn ties_at_box_boundaries_pick_lowest_id() {
    let mesh = tri_mesh(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[[0, 1, 2], [0, 1, 2]],
    );
    let trees = all_trees(&mesh);
    let mut rng = StdRng::seed_from_u64(23);
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
            assert_matches_brute_force(&mesh, &trees, &ray);
            // An isolated corner may be missed by rounding; a hit is on both copies.
            if let Some(h) = unanimous_hit(&trees, &ray) {
                assert_eq!(h.triangle, 0, "{ray:?}");
                hits += 1;
            }
        }
    }
    assert!(hits > 3000, "{hits}");
}

/// Regression: two triangles sharing the corner (1, 0, 0). The split-axis and PNS trees used
/// to report triangle 0 at t = 0.99999994 where brute force finds triangle 1 at t = 0.9999999.
#[test]
fn closest_hit_at_shared_corner_is_not_pruned() {
    let mesh = tri_mesh(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [2.0, 0.0, 1.0],
        ],
        &[[0, 1, 2], [1, 3, 4]],
    );
    let trees = all_trees(&mesh);
    let mut rng = StdRng::seed_from_u64(29);
    let mut hits = 0;
    let mut origins = vec![Vec3::new(-0.78, -0.18, 0.37)];
    for _ in 0..2000 {
        origins.push(Vec3::new(
            rng.random_range(-1.0f32..1.0),
            rng.random_range(-1.0f32..1.0),
            rng.random_range(0.01f32..1.0),
        ));
    }
    for origin in origins {
        let ray = Ray::new(origin, Vec3::X - origin);
        assert_matches_brute_force(&mesh, &trees, &ray);
        hits += unanimous_hit(&trees, &ray).is_some() as usize;
    }
    assert!(hits > 1000, "{hits}");
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
    let trees = all_trees(&mesh);
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
            assert_matches_brute_force(&mesh, &trees, &ray);
            // tmin = 0 includes the surface the ray starts on: hit at t = 0.
            let h = unanimous_hit(&trees, &ray).expect("starts on the surface");
            assert_eq!((h.triangle, h.t), (id, 0.0), "{ray:?}");
            // A positive tmin skips it: the triangle above, or nothing below.
            let ray = Ray::with_range(origin, dir, 1e-3, f32::INFINITY);
            assert_matches_brute_force(&mesh, &trees, &ray);
            let h = unanimous_hit(&trees, &ray);
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
    let trees = all_trees(&sphere);
    let mut rng = StdRng::seed_from_u64(7);
    for v in 0..sphere.vertices().len() as u32 {
        let origin = sphere.vertices()[v as usize];
        let lowest = *incident_triangles(&sphere, v).iter().min().unwrap();
        for _ in 0..4 {
            let dir = Vec3::new(
                rng.random_range(-1.0f32..1.0),
                rng.random_range(-1.0f32..1.0),
                rng.random_range(-1.0f32..1.0),
            );
            let ray = Ray::new(origin, dir);
            assert_matches_brute_force(&sphere, &trees, &ray);
            let h = unanimous_hit(&trees, &ray).expect("starts on the surface");
            assert_eq!(h.t, 0.0);
            assert_eq!(h.triangle, lowest, "vertex {v}, {ray:?}");
        }
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
    let trees = all_trees(&mesh);
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
        assert_matches_brute_force(&mesh, &trees, &ray);
        assert!(unanimous_hit(&trees, &ray).is_none(), "{ray:?} hit");
        for t in &trees {
            for kernel in Kernel::ALL {
                assert!(
                    !t.tree.occluded(&ray, kernel),
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
        assert_matches_brute_force(&mesh, &trees, &ray);
        let h = unanimous_hit(&trees, &ray).unwrap_or_else(|| panic!("{ray:?} missed"));
        assert_eq!(h.triangle, 0);
        assert!((h.t - 1.0).abs() < 1e-5, "{h:?}");
    }
    // Almost parallel: crosses the plane far outside the triangle.
    let ray = Ray::new(Vec3::new(-1.0, 0.25, 1e-3), Vec3::new(1.0, 0.0, -1e-30));
    assert_matches_brute_force(&mesh, &trees, &ray);
    assert!(unanimous_hit(&trees, &ray).is_none());
}

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
    let trees = all_trees(&mesh);
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
        assert_matches_brute_force(&mesh, &trees, ray);
        for t in &trees {
            for h in t.tree.all_hits(ray) {
                assert!(
                    good.contains(&h.triangle),
                    "{}: hit {h:?} on {ray:?}",
                    t.name
                );
            }
            for kernel in Kernel::ALL {
                if let Some(h) = t.tree.cast(ray, kernel) {
                    assert!(good.contains(&h.triangle), "{} {kernel:?}: {h:?}", t.name);
                }
            }
        }
    }
    // Interior hits report the good triangles' own ids, in z order.
    let down = Ray::new(Vec3::new(0.25, 0.25, 10.0), -Vec3::Z);
    let ids: Vec<u32> = trees[0]
        .tree
        .all_hits(&down)
        .iter()
        .map(|h| h.triangle)
        .collect();
    assert_eq!(ids, vec![7, 4, 1]);
    assert_eq!(unanimous_hit(&trees, &down).unwrap().triangle, 7);
    let up = Ray::new(Vec3::new(0.25, 0.25, -10.0), Vec3::Z);
    assert_eq!(unanimous_hit(&trees, &up).unwrap().triangle, 1);
    // Nothing but degenerate triangles along these.
    for ray in &rays[rays.len() - 4..] {
        assert!(unanimous_hit(&trees, ray).is_none(), "{ray:?}");
    }
}

#[test]
fn mesh_offset_by_1e5() {
    let offset = DVec3::splat(1e5);
    let mesh = transformed(&icosphere(3), 1.0, offset);
    let center = offset.as_vec3();
    assert_eq!(center, Vec3::splat(100_000.0));
    assert_closed_and_outward(&mesh, center);
    let trees = all_trees(&mesh);
    let mut targets: Vec<Vec3> = mesh.vertices().to_vec();
    for (a, b) in edges(&mesh) {
        targets.push((mesh.vertices()[a as usize] + mesh.vertices()[b as usize]) * 0.5);
    }
    let mut rng = StdRng::seed_from_u64(11);
    for _ in 0..500 {
        let d = Vec3::new(
            rng.random_range(-1.0f32..1.0),
            rng.random_range(-1.0f32..1.0),
            rng.random_range(-1.0f32..1.0),
        );
        targets.push(center + d);
    }
    let origins = [center, center + Vec3::new(-0.5, 0.25, 0.125)];
    for origin in origins {
        for &target in &targets {
            let ray = Ray::new(origin, target - origin);
            assert_matches_brute_force(&mesh, &trees, &ray);
            for t in &trees {
                let h = t
                    .tree
                    .cast(&ray, Kernel::Watertight)
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
    let trees = all_trees(&mesh);
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
            assert_matches_brute_force(&mesh, &trees, &ray);
            let h = unanimous_hit(&trees, &ray).unwrap_or_else(|| panic!("{ray:?} missed"));
            assert_eq!(h.triangle, tiny, "{ray:?}");
            assert!((h.t - 1.0).abs() < 1e-4, "{h:?}");
            // All hits: the tiny triangle, then the floor behind it.
            let all: Vec<u32> = trees[0]
                .tree
                .all_hits(&ray)
                .iter()
                .map(|h| h.triangle)
                .collect();
            assert_eq!(all[0], tiny);
            assert!(all[1..].iter().all(|&id| id < 3), "{all:?}");
            // Beside the tiny triangle by twice its size: the floor.
            let beside = Ray::new(origin + Vec3::new(2.0 * s, 0.0, 0.0), centroid - origin);
            assert_matches_brute_force(&mesh, &trees, &beside);
            let h = unanimous_hit(&trees, &beside).expect("the floor");
            assert!(h.triangle < 2, "{h:?}");
        }
    }
    // Long rays across the whole scene hit the wall.
    for y in [-4000.0f32, 0.0, 1234.5] {
        let ray = Ray::new(Vec3::new(-big, y, 1.0), Vec3::X);
        assert_matches_brute_force(&mesh, &trees, &ray);
        let h = unanimous_hit(&trees, &ray).expect("the wall");
        assert_eq!((h.triangle, h.t), (2, 2.0 * big));
    }
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
    let trees = all_trees(&mesh);
    let origin = Vec3::new(0.5, 0.5, 0.0);
    // Past the near triangle (it is at (0, 0) +- 1): only the far one.
    for tmax in [f32::INFINITY, f32::MAX] {
        let ray = Ray::with_range(origin, Vec3::Z, 0.0, tmax);
        assert_matches_brute_force(&mesh, &trees, &ray);
        let h = unanimous_hit(&trees, &ray).expect("the far triangle");
        assert_eq!((h.triangle, h.t), (0, far));
        let ray = Ray::with_range(origin, Vec3::Z, 0.0, far.next_down());
        assert!(unanimous_hit(&trees, &ray).is_none());
        assert_matches_brute_force(&mesh, &trees, &ray);
    }
    // Direction lengths from 1e-3 to 1e20: t scales inversely (smaller lengths: see
    // `small_direction_far_triangle_is_hit`).
    for scale in [1e-3f32, 1.0, 1e10, 1e20] {
        let ray = Ray::new(origin, Vec3::Z * scale);
        assert_matches_brute_force(&mesh, &trees, &ray);
        let h = unanimous_hit(&trees, &ray).expect("the far triangle");
        assert_eq!(h.triangle, 0);
        assert!(h.t.is_finite());
        assert!((h.t * scale / far - 1.0).abs() < 1e-6, "{h:?}");
        // Through the near triangle: both, near first.
        let ray = Ray::new(Vec3::ZERO, Vec3::Z * scale);
        assert_matches_brute_force(&mesh, &trees, &ray);
        let ids: Vec<u32> = trees[0]
            .tree
            .all_hits(&ray)
            .iter()
            .map(|h| h.triangle)
            .collect();
        assert_eq!(ids, vec![1, 0]);
        assert_eq!(unanimous_hit(&trees, &ray).unwrap().triangle, 1);
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
            assert_matches_brute_force(&mesh, &trees, &ray);
            for t in &trees {
                for kernel in Kernel::ALL {
                    if let Some(h) = t.tree.cast(&ray, kernel) {
                        assert!(h.t.is_finite(), "{} {kernel:?}: {h:?}", t.name);
                    }
                }
                for h in t.tree.all_hits(&ray) {
                    assert!(h.t.is_finite(), "{}: {h:?}", t.name);
                }
            }
        }
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
    let trees = all_trees(&mesh);
    for scale in [1e-10f32, 1e-20] {
        let ray = Ray::new(Vec3::new(0.5, 0.5, 0.0), Vec3::Z * scale);
        for t in &trees {
            let h = t.tree.cast(&ray, Kernel::Watertight);
            let h = h.unwrap_or_else(|| panic!("{}: missed with |dir| = {scale}", t.name));
            assert!((h.t * scale / far - 1.0).abs() < 1e-6, "{h:?}");
        }
    }
}

/// A mesh with something to hit from the origin in every direction.
fn enclosing_mesh() -> Mesh {
    icosphere(1)
}

fn assert_misses_everywhere(mesh: &Mesh, trees: &[common::TreeUnderTest], ray: &Ray) {
    for kernel in Kernel::ALL {
        assert_eq!(brute_force::cast_ray(mesh, ray, kernel), None, "{ray:?}");
        assert!(!brute_force::occluded(mesh, ray, kernel));
    }
    assert!(brute_force::all_hits(mesh, ray, Kernel::Watertight).is_empty());
    for t in trees {
        for kernel in Kernel::ALL {
            assert_eq!(
                t.tree.cast(ray, kernel),
                None,
                "{} {kernel:?} {ray:?}",
                t.name
            );
            assert!(
                !t.tree.occluded(ray, kernel),
                "{} {kernel:?} {ray:?}",
                t.name
            );
        }
        assert_eq!(t.tree.cast_default(ray), None);
        assert!(!t.tree.occluded_default(ray));
        assert!(t.tree.all_hits(ray).is_empty(), "{} {ray:?}", t.name);
        assert!(t.tree.each_hit(ray).is_empty(), "{} {ray:?}", t.name);
    }
}

#[test]
fn nan_and_infinite_rays_miss_without_panic() {
    let mesh = enclosing_mesh();
    let trees = all_trees(&mesh);
    let o = Vec3::new(0.1, -0.2, 0.05);
    let d = Vec3::new(0.3, 0.4, -0.5);
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let bad = [
        (
            Ray::new(Vec3::new(nan, 0.0, 0.0), d),
            RayError::NonFiniteOrigin,
        ),
        (
            Ray::new(Vec3::new(0.0, 0.0, -nan), d),
            RayError::NonFiniteOrigin,
        ),
        (
            Ray::new(Vec3::new(0.0, inf, 0.0), d),
            RayError::NonFiniteOrigin,
        ),
        (Ray::new(Vec3::splat(-inf), d), RayError::NonFiniteOrigin),
        // The origin is checked first.
        (Ray::new(Vec3::NAN, Vec3::NAN), RayError::NonFiniteOrigin),
        (
            Ray::new(o, Vec3::new(nan, 1.0, 0.0)),
            RayError::NonFiniteDirection,
        ),
        (
            Ray::new(o, Vec3::new(0.0, 0.0, inf)),
            RayError::NonFiniteDirection,
        ),
        (
            Ray::new(o, Vec3::new(1.0, -inf, 0.0)),
            RayError::NonFiniteDirection,
        ),
        (Ray::new(o, Vec3::NAN), RayError::NonFiniteDirection),
        (Ray::with_range(o, d, nan, 1.0), RayError::InvalidRange),
        (Ray::with_range(o, d, 0.0, nan), RayError::InvalidRange),
        (Ray::with_range(o, d, nan, nan), RayError::InvalidRange),
        (Ray::with_range(o, d, -1.0, 1.0), RayError::InvalidRange),
        (
            Ray::with_range(o, d, -f32::MIN_POSITIVE, 1.0),
            RayError::InvalidRange,
        ),
        (Ray::with_range(o, d, -inf, inf), RayError::InvalidRange),
        (Ray::with_range(o, d, inf, inf), RayError::InvalidRange),
        (Ray::with_range(o, d, 2.0, 1.0), RayError::InvalidRange),
        (Ray::with_range(o, d, 0.0, -inf), RayError::InvalidRange),
        (Ray::with_range(o, d, 0.0, -1.0), RayError::InvalidRange),
    ];
    for (ray, err) in bad {
        assert_eq!(ray.validate(), Err(err), "{ray:?}");
        assert!(!ray.is_valid());
        assert!(!err.to_string().is_empty());
        assert_misses_everywhere(&mesh, &trees, &ray);
    }
    // The same rays with their problem removed do hit: the misses above are not accidents.
    for ray in [
        Ray::new(o, d),
        Ray::with_range(o, d, 0.0, inf),
        Ray::with_range(o, d, -0.0, inf),
    ] {
        assert_eq!(ray.validate(), Ok(()));
        assert_matches_brute_force(&mesh, &trees, &ray);
        assert!(unanimous_hit(&trees, &ray).is_some());
    }
    // Valid but extreme rays: no panic, same answer as brute force.
    let extreme = [
        Ray::new(Vec3::splat(1e38), Vec3::splat(-3e38)),
        Ray::new(Vec3::splat(-3.4e38), Vec3::new(f32::MAX, 1.0, 1.0)),
        Ray::new(Vec3::new(1e30, 0.0, 0.0), -Vec3::X),
        Ray::new(o, Vec3::new(f32::MAX, f32::MAX, -f32::MAX)),
        Ray::new(o, Vec3::new(f32::MIN_POSITIVE, 0.0, 0.0)),
        Ray::with_range(o, d, f32::MAX, f32::MAX),
        Ray::with_range(o, d, 0.0, 0.0),
    ];
    for ray in extreme {
        assert_eq!(ray.validate(), Ok(()), "{ray:?}");
        assert_matches_brute_force(&mesh, &trees, &ray);
    }
}

#[test]
fn zero_direction_misses() {
    let mesh = enclosing_mesh();
    let trees = all_trees(&mesh);
    let sub = f32::MIN_POSITIVE / 2.0; // subnormal
    let zero_dirs = [
        Vec3::ZERO,
        Vec3::new(-0.0, 0.0, -0.0),
        Vec3::splat(-0.0),
        Vec3::new(sub, 0.0, 0.0),
        Vec3::new(-sub, sub, -1e-45),
        Vec3::splat(1e-40),
    ];
    // From inside, and from a vertex (on the surface, where t = 0 would otherwise hit).
    for origin in [Vec3::new(0.1, 0.0, 0.0), mesh.vertices()[0]] {
        for dir in zero_dirs {
            let ray = Ray::new(origin, dir);
            assert_eq!(ray.validate(), Err(RayError::ZeroDirection), "{dir:?}");
            assert_misses_everywhere(&mesh, &trees, &ray);
            let seg = Ray::segment(origin, origin + dir);
            assert_misses_everywhere(&mesh, &trees, &seg);
        }
        assert_misses_everywhere(&mesh, &trees, &Ray::segment(origin, origin));
    }
    // Subnormal components next to a normal one count as zero: same answers, bit for bit,
    // as the direction with exact zeros.
    let origin = Vec3::new(0.1, 0.2, 0.0);
    for (with_sub, flushed) in [
        (Vec3::new(1.0, sub, -sub), Vec3::new(1.0, 0.0, -0.0)),
        (Vec3::new(1e-40, -2.0, 0.0), Vec3::new(0.0, -2.0, 0.0)),
        (Vec3::new(-1e-45, 1e-45, 0.5), Vec3::new(-0.0, 0.0, 0.5)),
    ] {
        let a = Ray::new(origin, with_sub);
        let b = Ray::new(origin, flushed);
        assert_eq!(a.validate(), Ok(()));
        assert_matches_brute_force(&mesh, &trees, &a);
        for t in &trees {
            for kernel in Kernel::ALL {
                let (ha, hb) = (t.tree.cast(&a, kernel), t.tree.cast(&b, kernel));
                assert!(ha.is_some());
                assert_eq!(opt_bits(ha), opt_bits(hb), "{} {kernel:?}", t.name);
            }
        }
    }
}

#[test]
fn empty_mesh_misses_everything() {
    let empty = Mesh::new(vec![], vec![]).unwrap();
    let no_triangles = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![]).unwrap();
    for mesh in [empty, no_triangles] {
        assert!(mesh.is_empty());
        let trees = all_trees(&mesh);
        for t in &trees {
            assert_eq!(t.tree.node_count(), 0, "{}", t.name);
        }
        let mut rng = StdRng::seed_from_u64(3);
        let mut rays = vec![
            Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z),
            Ray::new(Vec3::ZERO, Vec3::X),
            Ray::segment(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.2, 0.2, 1.0)),
        ];
        for _ in 0..100 {
            let v = |rng: &mut StdRng| {
                Vec3::new(
                    rng.random_range(-2.0f32..2.0),
                    rng.random_range(-2.0f32..2.0),
                    rng.random_range(-2.0f32..2.0),
                )
            };
            rays.push(Ray::new(v(&mut rng), v(&mut rng)));
        }
        for ray in &rays {
            assert_misses_everywhere(&mesh, &trees, ray);
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
    let trees = all_trees(&mesh);
    for t in &trees {
        assert_eq!(t.tree.node_count(), 0, "{}", t.name);
    }
    for ray in [
        Ray::new(Vec3::new(0.5, 0.0, -1.0), Vec3::Z),
        Ray::new(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z),
        Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::new(0.5, 0.0, 0.0), Vec3::Y),
        Ray::new(Vec3::new(0.0, 1.0, -1.0), Vec3::Z),
        Ray::new(Vec3::new(0.0, 0.5, -1.0), Vec3::new(0.0, 0.5, 1.0)),
    ] {
        assert_misses_everywhere(&mesh, &trees, &ray);
    }
}

#[test]
fn segment_occlusion_respects_endpoints() {
    let z = 1.0f32;
    let mesh = tri_mesh(
        &[[-1.0, -1.0, z], [3.0, -1.0, z], [-1.0, 3.0, z]],
        &[[0, 1, 2]],
    );
    let trees = all_trees(&mesh);
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
        assert_matches_brute_force(&mesh, &trees, &ray);
        for t in &trees {
            assert_eq!(
                t.tree.occluded(&ray, Kernel::Watertight),
                occluded,
                "{} {ray:?}",
                t.name
            );
            assert_eq!(t.tree.occluded_default(&ray), occluded);
        }
        if occluded && ray.dir.x == 0.0 {
            // Axis-aligned: t is exact, the hit point is on the plane.
            let h = unanimous_hit(&trees, &ray).unwrap();
            assert_eq!(ray.at(h.t).z, z, "{ray:?} {h:?}");
        }
    }
    // Segments from random points to random points of the triangle, its edges and corners: the
    // trees agree with brute force, and a watertight hit at t <= 1 is occlusion.
    let sphere = icosphere(1);
    let trees = all_trees(&sphere);
    let mut rng = StdRng::seed_from_u64(5);
    let mut occluded_count = 0;
    for _ in 0..3000 {
        let from = Vec3::new(
            rng.random_range(-3.0f32..3.0),
            rng.random_range(-3.0f32..3.0),
            rng.random_range(-3.0f32..3.0),
        );
        let v = sphere.vertices();
        let a = v[rng.random_range(0..v.len())];
        let b = v[rng.random_range(0..v.len())];
        let to = match rng.random_range(0..3) {
            0 => a,
            1 => (a + b) * 0.5,
            _ => a.lerp(b, rng.random_range(0.0f32..1.0)),
        };
        let ray = Ray::segment(from, to);
        assert_matches_brute_force(&sphere, &trees, &ray);
        let expected = brute_force::occluded(&sphere, &ray, Kernel::Watertight);
        occluded_count += expected as usize;
        for t in &trees {
            assert_eq!(
                t.tree.occluded(&ray, Kernel::Watertight),
                expected,
                "{}",
                t.name
            );
        }
    }
    assert!(occluded_count > 1000, "{occluded_count}");
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
    let trees = all_trees(&mesh);
    let mut rng = StdRng::seed_from_u64(9);
    let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
    for k in 0..400 {
        // Origins all around (every octant of direction), aimed at interior points.
        let origin = centroid
            + Vec3::new(
                rng.random_range(-3.0f32..3.0),
                rng.random_range(-3.0f32..3.0),
                rng.random_range(-3.0f32..3.0),
            );
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
        assert_matches_brute_force(&mesh, &trees, &ray);
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
            for t in &trees {
                for kernel in Kernel::ALL {
                    let h = t.tree.cast(&ray, kernel).unwrap();
                    assert_eq!(h.triangle, lowest, "{} {kernel:?} {ray:?}", t.name);
                }
            }
        }
    }
    // Rotated corners (same plane, t may differ in the last bits) and opposite winding: the
    // trees still follow brute force exactly.
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
    let trees = all_trees(&mesh);
    for _ in 0..400 {
        let origin = Vec3::new(
            rng.random_range(-1.0f32..6.0),
            rng.random_range(-3.0f32..3.0),
            rng.random_range(-3.0f32..3.0),
        );
        let (u, v) = (
            rng.random_range(0.05f32..0.45),
            rng.random_range(0.05f32..0.45),
        );
        let target = tri[0] * (1.0 - u - v) + tri[1] * u + tri[2] * v;
        let ray = Ray::new(origin, target - origin);
        assert_matches_brute_force(&mesh, &trees, &ray);
        let h = unanimous_hit(&trees, &ray).expect("aimed at the triangle");
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
    let trees = all_trees(&mesh);
    let mut rng = StdRng::seed_from_u64(13);
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
        assert_matches_brute_force(&mesh, &trees, &ray);
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
        for t in &trees {
            let hits = t.tree.all_hits(&ray);
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
            assert_eq!(Some(hits[0]), t.tree.cast(&ray, Kernel::Watertight));
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
    let trees = all_trees(&mesh);
    let ray = Ray::new(Vec3::new(0.5, 0.0, 0.0), Vec3::new(-1.0, 0.0, 1.0));
    for t in &trees {
        let all = t.tree.all_hits(&ray);
        let closest = t.tree.cast(&ray, Kernel::Watertight).unwrap();
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

/// Meshes above the parallel build threshold (16k triangles) take the rayon path.
#[test]
fn parallel_and_sequential_builds_match_brute_force() {
    let mesh = icosphere(6);
    assert!(mesh.triangle_count() > 16 * 1024);
    let mesh_arc = std::sync::Arc::new(mesh.clone());
    let mut trees = trees_with(&mesh, &TreeKind::ALL, &[1, 4], &[ChildOrdering::Pns]);
    for kind in TreeKind::ALL {
        // Same options without rayon.
        let options = raybatch::BuildOptions::default().with_parallel(false);
        let tree: Box<dyn common::Queries> = match kind {
            TreeKind::Full => {
                Box::new(<raybatch::AabbTree>::build(mesh_arc.clone(), &options).unwrap())
            }
            TreeKind::Quantized => {
                Box::new(raybatch::QuantizedAabbTree::build(mesh_arc.clone(), &options).unwrap())
            }
        };
        trees.push(common::TreeUnderTest {
            name: format!("{kind:?}/sequential"),
            tree,
        });
    }
    let mut rng = StdRng::seed_from_u64(17);
    for _ in 0..100 {
        let v = |rng: &mut StdRng, r: f32| {
            Vec3::new(
                rng.random_range(-r..r),
                rng.random_range(-r..r),
                rng.random_range(-r..r),
            )
        };
        let origin = v(&mut rng, 2.0);
        let ray = Ray::new(origin, v(&mut rng, 1.0) - origin);
        assert_matches_brute_force(&mesh, &trees, &ray);
    }
}

/// Geometrically shrinking triangles make the SAH build deep; traversal's fixed stack must
/// cope and answers must not change.
#[test]
fn deep_trees_match_brute_force() {
    let mut vertices = vec![];
    let mut triangles = vec![];
    for k in 0..120 {
        let s = 0.8f32.powi(k);
        let b = vertices.len() as u32;
        vertices.extend([
            Vec3::new(s, 0.0, 0.0),
            Vec3::new(s * 1.1, s * 0.1, 0.0),
            Vec3::new(s, 0.0, s * 0.1),
        ]);
        triangles.push([b, b + 1, b + 2]);
    }
    let mesh = Mesh::new(vertices, triangles).unwrap();
    let trees = all_trees(&mesh);
    let mut rng = StdRng::seed_from_u64(19);
    for _ in 0..300 {
        let k = rng.random_range(0..120);
        let s = 0.8f32.powi(k);
        let target = Vec3::new(s * 1.03, s * 0.02, s * 0.02);
        let origin = Vec3::new(
            rng.random_range(-1.0f32..2.0),
            rng.random_range(-1.0f32..1.0),
            rng.random_range(-1.0f32..1.0),
        );
        let ray = Ray::new(origin, target - origin);
        assert_matches_brute_force(&mesh, &trees, &ray);
    }
}
