//! Hard cases of the build: meshes large enough for the parallel build (compared with the
//! sequential build of the same options) and geometrically shrinking triangles that make the
//! tree deep. Every structure is compared with the brute-force reference.

use std::sync::Arc;

use crate::common::meshes::icosphere;
use crate::common::oracles::assert_matches_brute_force;
use crate::common::rng::{RngExt, in_box, in_cube, seeded};
use crate::common::zoo::{all_structures, build, structures_with};
use glam::Vec3;
use raybatch::{AccelKind, BuildOptions, ChildOrdering, Mesh, Ray};

/// Meshes above the parallel build threshold (16k triangles) take the rayon path.
#[test]
fn parallel_and_sequential_builds_match_brute_force() {
    let mesh = icosphere(6);
    assert!(mesh.triangle_count() > 16 * 1024);
    let mesh_arc = Arc::new(mesh.clone());
    let mut zoo = structures_with(&mesh, &AccelKind::ALL, &[1, 4], &[ChildOrdering::Pns]);
    for kind in AccelKind::ALL {
        // Same options without rayon.
        let options = BuildOptions::default().with_parallel(false);
        let name = format!("{}/sequential", kind.name());
        zoo.push(build(&mesh_arc, kind, &options, name));
    }
    let mut rng = seeded(17);
    for _ in 0..100 {
        let origin = in_cube(&mut rng, 2.0);
        let ray = Ray::new(origin, in_cube(&mut rng, 1.0) - origin);
        assert_matches_brute_force(&mesh, &zoo, &ray);
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
    let zoo = all_structures(&mesh);
    let mut rng = seeded(19);
    for _ in 0..300 {
        let k = rng.random_range(0..120);
        let s = 0.8f32.powi(k);
        let target = Vec3::new(s * 1.03, s * 0.02, s * 0.02);
        let origin = in_box(
            &mut rng,
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(2.0, 1.0, 1.0),
        );
        let ray = Ray::new(origin, target - origin);
        assert_matches_brute_force(&mesh, &zoo, &ray);
    }
}
