//! Hard cases at shared vertices and edges: rays along the grid lines of a tessellated cube
//! (axis-parallel, signed zeros), rays aimed exactly at every vertex and edge midpoint of a
//! closed icosphere, and a regression at a corner shared by two triangles. Every structure of
//! the zoo is compared with the brute-force reference and checked for the expected answer.

use std::collections::HashMap;

use crate::common::meshes::{assert_closed_and_outward, edges, icosphere, tri_mesh};
use crate::common::oracles::{assert_matches_brute_force, closest_ids, unanimous_hit};
use crate::common::rng::{in_box, seeded};
use crate::common::zoo::all_structures;
use glam::Vec3;
use raybatch::{Kernel, Mesh, Ray};

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
    let zoo = all_structures(&mesh);
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
                                assert_matches_brute_force(&mesh, &zoo, &ray);
                                let hit = unanimous_hit(&zoo, &ray);
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
/// every structure must hit, on a triangle touching the target, at `t` close to 1,
/// bit-identical to brute force, and the reported triangle is the lowest id among those hit at
/// that `t`.
#[test]
fn rays_at_shared_vertices_and_edges() {
    let mesh = icosphere(2);
    let zoo = all_structures(&mesh);
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
            assert_matches_brute_force(&mesh, &zoo, &ray);
            let at_closest = closest_ids(&mesh, &ray);
            ties += (at_closest.len() > 1) as usize;
            for t in &zoo {
                let h = t
                    .accel
                    .cast_ray_with(&ray, Kernel::Watertight)
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

/// Two triangles sharing the corner (1, 0, 0): brute force finds triangle 1 at t = 0.9999999,
/// and no tree, whatever its child ordering, may prune it and report triangle 0 at
/// t = 0.99999994.
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
    let zoo = all_structures(&mesh);
    let mut rng = seeded(29);
    let mut hits = 0;
    let mut origins = vec![Vec3::new(-0.78, -0.18, 0.37)];
    for _ in 0..2000 {
        origins.push(in_box(&mut rng, Vec3::new(-1.0, -1.0, 0.01), Vec3::ONE));
    }
    for origin in origins {
        let ray = Ray::new(origin, Vec3::X - origin);
        assert_matches_brute_force(&mesh, &zoo, &ray);
        hits += unanimous_hit(&zoo, &ray).is_some() as usize;
    }
    assert!(hits > 1000, "{hits}");
}
