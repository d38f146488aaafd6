//! Audio occlusion: a segment through a shared edge or vertex crosses one surface, not two
//! (within a mesh and across instances), through a closed sphere exactly two; losses add up
//! per crossing with the largest loss of a crossing's triangles; "first N" limits; batched
//! equals per ray bit for bit; bad material tables are typed errors.

use crate::common::meshes::{edges, icosphere, tri_mesh};
use crate::common::rng::{in_cube, seeded};
use crate::common::scenes::build_scene;
use glam::{Quat, Vec3};
use raybatch::scene::{InstanceDesc, Rigid};
use raybatch::users::{AudioError, Materials, Occlusion, occlusion, occlusion_batch};
use raybatch::{AccelKind, Mesh, Ray, RayQueries};

fn sphere_scene(rotation: Quat) -> (Mesh, raybatch::Scene) {
    let mesh = icosphere(2);
    let at = Rigid::new(rotation, Vec3::new(0.25, -0.5, 1.0)).unwrap();
    let scene = build_scene(
        std::slice::from_ref(&mesh),
        &[AccelKind::Aabb],
        &[InstanceDesc::new(0, at)],
    );
    (mesh, scene)
}

#[test]
fn a_line_through_vertices_and_edges_crosses_a_closed_sphere_twice() {
    for rotation in [
        Quat::IDENTITY,
        Quat::from_rotation_y(0.3) * Quat::from_rotation_x(1.1),
    ] {
        let (mesh, scene) = sphere_scene(rotation);
        let materials = Materials::uniform(&scene, 10.0).unwrap();
        let at = scene.instances()[0].transform();
        let mut points: Vec<Vec3> = mesh.vertices().to_vec();
        points.extend(
            edges(&mesh)
                .iter()
                .map(|&(a, b)| (mesh.vertices()[a as usize] + mesh.vertices()[b as usize]) * 0.5),
        );
        let (mut shared, mut total) = (0, 0);
        for p in points {
            let ray = Ray::segment(at.point_to_world(p * 3.0), at.point_to_world(p * -3.0));
            let hits = scene.all_hits(&ray);
            total += 1;
            if hits.len() > 2 {
                shared += 1;
            }
            let o = occlusion(&scene, &materials, &ray, u32::MAX);
            assert_eq!(
                o,
                Occlusion {
                    loss_db: 20.0,
                    crossings: 2
                },
                "{p:?}: {} hits",
                hits.len()
            );
            let first = occlusion(&scene, &materials, &ray, 1);
            assert_eq!(
                first,
                Occlusion {
                    loss_db: 10.0,
                    crossings: 1
                }
            );
        }
        // Many of these lines pass through shared edges and vertices (several hits per side).
        assert!(shared * 4 > total, "{shared} of {total}");
    }
}

#[test]
fn a_seam_between_two_instances_is_one_crossing() {
    let half = tri_mesh(
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
        ],
        &[[0, 1, 2], [1, 3, 2]],
    );
    let tiles =
        [Vec3::ZERO, Vec3::X].map(|t| InstanceDesc::new(0, Rigid::from_translation(t).unwrap()));
    let scene = build_scene(std::slice::from_ref(&half), &[AccelKind::Bvh4], &tiles);
    let materials = Materials::new(&scene, vec![vec![3.0, 7.0]]).unwrap();
    // Straight down on the seam x = 1 (inside triangle 1 of the first tile and triangle 0 of
    // the second: shared edge across instances).
    let ray = Ray::segment(Vec3::new(1.0, 5.0, 0.5), Vec3::new(1.0, -5.0, 0.5));
    assert!(scene.all_hits(&ray).len() >= 2);
    assert_eq!(
        occlusion(&scene, &materials, &ray, u32::MAX),
        Occlusion {
            loss_db: 7.0,
            crossings: 1
        }
    );
    // The diagonal of one tile: two triangles of one instance.
    let diag = Ray::segment(Vec3::new(0.5, 5.0, 0.5), Vec3::new(0.5, -5.0, 0.5));
    assert_eq!(scene.all_hits(&diag).len(), 2);
    assert_eq!(
        occlusion(&scene, &materials, &diag, u32::MAX),
        Occlusion {
            loss_db: 7.0,
            crossings: 1
        }
    );
}

#[test]
fn batched_equals_per_ray() {
    let meshes = vec![icosphere(1), icosphere(2)];
    let descs: Vec<InstanceDesc> = (0..20)
        .map(|i| {
            let r = Quat::from_rotation_z(i as f32);
            let t = Vec3::new(
                (i % 5) as f32 * 2.0 - 4.0,
                (i / 5) as f32 * 2.0 - 4.0,
                (i % 3) as f32,
            );
            InstanceDesc::new(i % 2, Rigid::new(r, t).unwrap())
        })
        .collect();
    let scene = build_scene(&meshes, &[AccelKind::Aabb, AccelKind::Hybrid], &descs);
    let tables = meshes
        .iter()
        .enumerate()
        .map(|(m, mesh)| {
            (0..mesh.triangle_count())
                .map(|t| (t % 7 + m) as f32)
                .collect()
        })
        .collect();
    let materials = Materials::new(&scene, tables).unwrap();
    let mut rng = seeded(21);
    let mut rays: Vec<Ray> = (0..1500)
        .map(|_| Ray::segment(in_cube(&mut rng, 7.0), in_cube(&mut rng, 7.0)))
        .collect();
    // Invalid segments (a NaN source, length zero) are not heard, per ray and batched.
    rays[10] = Ray::segment(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ZERO);
    rays[700] = Ray::segment(Vec3::ONE, Vec3::ONE);
    for &k in &[10, 700] {
        assert_eq!(
            occlusion(&scene, &materials, &rays[k], 3),
            Occlusion::SILENT
        );
    }
    for limit in [1, 3, u32::MAX] {
        let mut out = vec![Occlusion::default(); rays.len()];
        occlusion_batch(&scene, &materials, &rays, limit, &mut out).unwrap();
        let mut crossed = 0;
        for (ray, o) in rays.iter().zip(&out) {
            let single = occlusion(&scene, &materials, ray, limit);
            assert_eq!(single.loss_db.to_bits(), o.loss_db.to_bits());
            assert_eq!(single.crossings, o.crossings);
            assert!(o.crossings <= limit);
            crossed += (o.crossings > 0) as usize;
        }
        assert!(crossed > 300, "{crossed}");
    }
    let mut short = vec![Occlusion::default(); 3];
    assert!(occlusion_batch(&scene, &materials, &rays, 1, &mut short).is_err());
}

#[test]
fn bad_tables_are_typed_errors() {
    let (mesh, scene) = sphere_scene(Quat::IDENTITY);
    let n = mesh.triangle_count();
    assert_eq!(
        Materials::new(&scene, vec![]).unwrap_err(),
        AudioError::WrongTableCount {
            meshes: 1,
            tables: 0
        }
    );
    assert_eq!(
        Materials::new(&scene, vec![vec![1.0; n - 1]]).unwrap_err(),
        AudioError::TableTooShort {
            mesh: 0,
            triangles: n,
            entries: n - 1
        }
    );
    let mut bad = vec![1.0; n];
    bad[5] = f32::NAN;
    assert_eq!(
        Materials::new(&scene, vec![bad]).unwrap_err(),
        AudioError::BadLoss {
            mesh: 0,
            triangle: 5
        }
    );
    assert_eq!(
        Materials::uniform(&scene, -1.0).unwrap_err(),
        AudioError::BadLoss {
            mesh: 0,
            triangle: 0
        }
    );
    assert!(Materials::new(&scene, vec![vec![1.0; n + 4]]).is_ok());
}
