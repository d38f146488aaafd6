//! Resolved scene hits: instance and mesh triangle as brute force names them, the world
//! position `ray.at(t)` and the triangle's world normal, the same per ray and batched, for
//! every kind of mesh tree (the zero-byte kinds reorder their triangles and must map back).

use crate::common::meshes::{icosphere, transformed};
use crate::common::rng::{in_cube, seeded};
use crate::common::scenes::{build_scene, scene_brute_force};
use glam::{DVec3, Quat, Vec3};
use raybatch::scene::{InstanceDesc, RayFilter, Rigid, SceneHit};
use raybatch::{AccelKind, BatchError, Kernel, Mesh, Ray};

#[test]
fn resolved_hits_name_the_triangle_and_its_world_normal() {
    // One mesh per kind, so that every kind's ids are mapped back to corners.
    let meshes: Vec<Mesh> = AccelKind::ALL
        .iter()
        .enumerate()
        .map(|(i, _)| transformed(&icosphere(2), 0.5 + 0.1 * i as f64, DVec3::ZERO))
        .collect();
    let descs: Vec<InstanceDesc> = (0..2 * meshes.len())
        .map(|i| {
            let angle = 0.37 * i as f32;
            let at = Vec3::new((i % 6) as f32 * 2.5 - 6.0, (i / 6) as f32 * 2.5 - 2.5, 0.0);
            let turn = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), angle);
            InstanceDesc::new(i % meshes.len(), Rigid::new(turn, at).unwrap())
                .with_user(1000 + i as u64)
        })
        .collect();
    let scene = build_scene(&meshes, &AccelKind::ALL, &descs);
    let mut rng = seeded(41);
    let rays: Vec<Ray> = (0..3000)
        .map(|_| {
            let from = in_cube(&mut rng, 9.0);
            Ray::new(from, in_cube(&mut rng, 4.0) - from)
        })
        .collect();
    let per_ray: Vec<Option<SceneHit>> = rays.iter().map(|r| scene.cast_ray_resolved(r)).collect();
    let mut hits = 0;
    for (ray, got) in rays.iter().zip(&per_ray) {
        let want = scene_brute_force(&meshes, &descs, ray, Kernel::Watertight, u32::MAX).closest;
        assert_eq!(got.is_some(), want.is_some(), "{ray:?}");
        let (Some(got), Some(want)) = (got, want) else {
            continue;
        };
        hits += 1;
        let d = &descs[got.instance as usize];
        let first: u32 = descs[..got.instance as usize]
            .iter()
            .map(|d| meshes[d.mesh].triangle_count() as u32)
            .sum();
        assert_eq!(first + got.triangle, want.triangle);
        assert_eq!(got.user, 1000 + u64::from(got.instance));
        assert_eq!((got.t, got.u, got.v), (want.t, want.u, want.v));
        assert_eq!(got.position, ray.at(got.t));
        let [a, b, c] = meshes[d.mesh].triangle(got.triangle);
        let expected = d.transform.rotation() * (b - a).cross(c - a).normalize();
        assert!(
            (got.normal - expected).length() < 1e-5,
            "{got:?} {expected}"
        );
        assert!((got.normal.length() - 1.0).abs() < 1e-6);
        // Rays from outside a closed outward sphere hit its outside.
        if ray.origin.distance(d.transform.translation()) > 2.0 {
            assert!(got.normal.dot(ray.dir) <= 0.0, "{got:?}");
        }
    }
    assert!(hits > 500, "{hits} hits");

    let mut batched = vec![None; rays.len()];
    scene.cast_ray_batch_resolved(&rays, &mut batched).unwrap();
    assert_eq!(batched, per_ray);
    let view = scene.filtered(RayFilter::ALL);
    let mut with_options = vec![None; rays.len()];
    let options = raybatch::BatchOptions::default().with_min_chunk(64);
    view.cast_ray_batch_resolved_with(&rays, &mut with_options, &options)
        .unwrap();
    assert_eq!(with_options, per_ray);
    // A user value set later is the one hits carry.
    let mut scene = scene;
    scene.set_user(3, 7).unwrap();
    let (ray, _) = rays
        .iter()
        .zip(&per_ray)
        .find(|(_, h)| h.is_some_and(|h| h.instance == 3))
        .expect("a ray hits instance 3");
    assert_eq!(scene.cast_ray_resolved(ray).unwrap().user, 7);
    assert!(scene.set_user(descs.len(), 1).is_err());
    assert_eq!(
        scene.cast_ray_batch_resolved(&rays, &mut batched[1..]),
        Err(BatchError::LengthMismatch {
            rays: rays.len(),
            outputs: rays.len() - 1
        })
    );
}

/// A scaled instance: hits where the scaled mesh is (a unit sphere scaled by 3 is hit at
/// distance 3 from its centre), the world `t` and normal, and a scale out of range is refused.
#[test]
fn scaled_instances_are_hit_where_the_scaled_mesh_is() {
    use raybatch::RayQueries;
    use raybatch::scene::{Scene, SceneError};
    let sphere = icosphere(3);
    let at = Vec3::new(10.0, 0.0, 0.0);
    let big = Rigid::new(Quat::from_rotation_y(0.3), at)
        .unwrap()
        .with_scale(3.0)
        .unwrap();
    let scene = Scene::from_meshes(vec![sphere], &[InstanceDesc::new(0, big)]).unwrap();
    let ray = Ray::new(Vec3::ZERO, Vec3::X);
    let hit = scene.cast_ray_resolved(&ray).unwrap();
    assert!((hit.t - 7.0).abs() < 0.03, "{hit:?}"); // the icosphere's faces lie inside r = 1
    assert!((hit.normal.length() - 1.0).abs() < 1e-6 && hit.normal.x < -0.95);
    assert!(scene.occluded(&Ray::segment(
        Vec3::new(10.0, 0.0, 2.8),
        Vec3::new(10.0, 0.0, 3.2)
    )));
    assert!(!scene.occluded(&Ray::segment(
        Vec3::new(10.0, 0.0, 3.1),
        Vec3::new(10.0, 0.0, 4.0)
    )));
    for scale in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e-7, 2e6] {
        let refused = Rigid::IDENTITY.with_scale(scale);
        assert!(
            matches!(refused, Err(SceneError::BadScale { .. })),
            "{scale}"
        );
    }
    assert_eq!(Rigid::IDENTITY.with_scale(1.0).unwrap(), Rigid::IDENTITY);
}
