//! Scenes beyond the random layouts: an instance at the identity answers bit for bit as the
//! bare tree (every kind, per ray and batched); moving instances (one, many, rebuild), changing
//! layers and deforming a mesh keep answers equal to brute force; `locate` inverts global ids;
//! bad input is a typed error that leaves the scene as it was.

use std::sync::Arc;

use crate::common::meshes::icosphere;
use crate::common::oracles::{all_bits, bits, opt_bits};
use crate::common::rays::{hard_rays, incoherent};
use crate::common::rng::{RngExt, seeded};
use crate::common::scenes::{build_scene, scene_brute_force};
use glam::{Quat, Vec3};
use raybatch::scene::{InstanceDesc, RayFilter, Rigid, Scene, SceneError};
use raybatch::{
    AccelKind, BatchOptions, BatchQueries, BuildOptions, Kernel, Mesh, MeshError, Ray, RayQueries,
};

/// Per-ray and batched closest hits and occlusion of `scene` equal the oracle's on `rays`.
fn assert_matches(scene: &Scene, meshes: &[Mesh], descs: &[InstanceDesc], rays: &[Ray]) {
    let options = BatchOptions::default().with_min_batch(0);
    let mut hits = vec![None; rays.len()];
    scene
        .cast_ray_batch_with(rays, &mut hits, &options)
        .unwrap();
    let mut occluded = vec![false; rays.len()];
    scene
        .occluded_batch_with(rays, &mut occluded, &options)
        .unwrap();
    for (i, ray) in rays.iter().enumerate() {
        let r = scene_brute_force(meshes, descs, ray, Kernel::Watertight, u32::MAX);
        assert_eq!(
            opt_bits(scene.cast_ray(ray)),
            opt_bits(r.closest),
            "{ray:?}"
        );
        assert_eq!(opt_bits(hits[i]), opt_bits(r.closest), "batched {ray:?}");
        assert_eq!(occluded[i], r.occluded, "{ray:?}");
        assert_eq!(all_bits(&scene.all_hits(ray)), all_bits(&r.all), "{ray:?}");
    }
}

/// The descriptions of `scene`'s instances as they are now (a removed one on no layer).
fn descs_of(scene: &Scene) -> Vec<InstanceDesc> {
    scene
        .instances()
        .iter()
        .map(|i| {
            InstanceDesc::new(i.mesh(), i.transform())
                .with_mask(i.mask())
                .with_user(i.user())
        })
        .collect()
}

fn sphere_rays(count: usize, seed: u64) -> Vec<Ray> {
    let big = crate::common::meshes::transformed(&icosphere(1), 6.0, glam::DVec3::ZERO);
    incoherent(&big, count, &mut seeded(seed))
}

#[test]
fn identity_instance_answers_as_the_bare_tree() {
    let mesh = Arc::new(icosphere(3));
    let mut rays = hard_rays(&mesh, 9);
    rays.extend(incoherent(&mesh, 500, &mut seeded(10)));
    for kind in AccelKind::ALL {
        let bare = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        let scene = Scene::new(vec![tree], &[InstanceDesc::new(0, Rigid::IDENTITY)]).unwrap();
        for ray in &rays {
            assert_eq!(
                opt_bits(scene.cast_ray(ray)),
                opt_bits(bare.cast_ray(ray)),
                "{kind:?} {ray:?}"
            );
            assert_eq!(scene.occluded(ray), bare.occluded(ray));
            assert_eq!(
                all_bits(&scene.all_hits(ray)),
                all_bits(&bare.all_hits(ray))
            );
        }
        let options = BatchOptions::default().with_min_batch(0);
        let (mut a, mut b) = (vec![None; rays.len()], vec![None; rays.len()]);
        scene.cast_ray_batch_with(&rays, &mut a, &options).unwrap();
        bare.cast_ray_batch_with(&rays, &mut b, &options).unwrap();
        let bits_of = |h: &[Option<raybatch::Hit>]| {
            h.iter().map(|h| h.as_ref().map(bits)).collect::<Vec<_>>()
        };
        assert_eq!(bits_of(&a), bits_of(&b), "{kind:?} batched");
    }
}

#[test]
fn translated_instance_answers_as_the_tree_on_shifted_rays() {
    let mesh = Arc::new(icosphere(2));
    let shift = Vec3::new(4.0, -2.0, 8.0);
    let tree = AccelKind::Bvh4
        .build(mesh.clone(), &BuildOptions::default())
        .unwrap();
    let bare = AccelKind::Bvh4
        .build(mesh.clone(), &BuildOptions::default())
        .unwrap();
    let at = Rigid::from_translation(shift).unwrap();
    let scene = Scene::new(vec![tree], &[InstanceDesc::new(0, at)]).unwrap();
    for ray in incoherent(&mesh, 300, &mut seeded(11)) {
        let world = Ray {
            origin: ray.origin + shift,
            ..ray
        };
        let local = Ray {
            origin: world.origin - shift,
            ..ray
        };
        let hit = scene.cast_ray(&world);
        assert_eq!(opt_bits(hit), opt_bits(bare.cast_ray(&local)));
        if let Some(h) = hit {
            let r = scene.resolve(&world, h).unwrap();
            assert_eq!((r.instance, r.triangle), (0, h.triangle));
        }
    }
}

/// A row of spheres of three kinds, shared meshes.
fn row() -> (Vec<Mesh>, Vec<InstanceDesc>, Scene) {
    let meshes = vec![icosphere(1), icosphere(2)];
    let descs: Vec<InstanceDesc> = (0..12)
        .map(|i| {
            let r = Quat::from_rotation_z(i as f32 * 0.4);
            let t = Vec3::new(i as f32 * 1.5 - 8.0, (i % 3) as f32, 0.0);
            InstanceDesc::new(i % 2, Rigid::new(r, t).unwrap())
        })
        .collect();
    let scene = build_scene(&meshes, &[AccelKind::Aabb, AccelKind::Zbt], &descs);
    (meshes, descs, scene)
}

#[test]
fn moving_instances_keeps_answers_exact() {
    let (meshes, _, mut scene) = row();
    let rays = sphere_rays(400, 12);
    let mut rng = seeded(13);
    let random_move = |rng: &mut crate::common::rng::StdRng| {
        let r = Quat::from_euler(
            glam::EulerRot::XYZ,
            rng.random(),
            rng.random(),
            rng.random(),
        );
        let t = Vec3::new(rng.random(), rng.random(), rng.random()) * 8.0 - 4.0;
        Rigid::new(r, t).unwrap()
    };
    scene.set_transform(3, random_move(&mut rng)).unwrap();
    assert_matches(&scene, &meshes, &descs_of(&scene), &rays);
    let moves: Vec<(usize, Rigid)> = (0..12)
        .step_by(2)
        .map(|i| (i, random_move(&mut rng)))
        .collect();
    scene.set_transforms(&moves).unwrap();
    assert_matches(&scene, &meshes, &descs_of(&scene), &rays);
    scene.rebuild_top();
    assert_matches(&scene, &meshes, &descs_of(&scene), &rays);
}

#[test]
fn layers_filter_instances() {
    let (meshes, _, mut scene) = row();
    for i in 0..12 {
        scene.set_mask(i, 1 << (i % 3)).unwrap();
    }
    let descs = descs_of(&scene);
    for ray in sphere_rays(200, 14) {
        for mask in [1, 2, 4, 5, 0] {
            let r = scene_brute_force(&meshes, &descs, &ray, Kernel::Watertight, mask);
            let view = scene.filtered(RayFilter::on_layers(mask));
            assert_eq!(opt_bits(view.cast_ray(&ray)), opt_bits(r.closest));
            assert_eq!(view.occluded(&ray), r.occluded);
            if let Some(h) = view.cast_ray(&ray) {
                let instance = scene.resolve(&ray, h).unwrap().instance as usize;
                assert!(descs[instance].mask & mask != 0);
            }
        }
    }
}

#[test]
fn deformed_mesh_is_refitted_exactly() {
    let (mut meshes, descs, mut scene) = row();
    let rays = sphere_rays(300, 15);
    // Mesh 0 is an AABB tree: squash and stretch it.
    let moved: Vec<Vec3> = meshes[0]
        .vertices()
        .iter()
        .map(|v| Vec3::new(v.x * 1.7, v.y * 0.3 + v.x * v.x, v.z + 0.5))
        .collect();
    scene.deform_mesh(0, moved.clone()).unwrap();
    meshes[0] = Mesh::new(moved, meshes[0].triangles().to_vec()).unwrap();
    assert_matches(&scene, &meshes, &descs, &rays);
}

#[test]
fn locate_inverts_global_ids() {
    let (meshes, descs, scene) = row();
    let mut first = 0u32;
    for (i, d) in descs.iter().enumerate() {
        let n = meshes[d.mesh].triangle_count() as u32;
        assert_eq!(scene.instances()[i].first_id(), first);
        assert_eq!(scene.locate(first), Some((i as u32, 0)));
        assert_eq!(scene.locate(first + n - 1), Some((i as u32, n - 1)));
        first += n;
    }
    assert_eq!(scene.triangle_count(), first as usize);
    assert_eq!(scene.locate(first), None);
}

#[test]
fn bad_input_is_a_typed_error_and_changes_nothing() {
    let (meshes, descs, mut scene) = row();
    let rays = sphere_rays(100, 16);
    let tree = || {
        AccelKind::Aabb
            .build(icosphere(0), &BuildOptions::default())
            .unwrap()
    };
    assert_eq!(
        Scene::new(vec![tree()], &[InstanceDesc::new(1, Rigid::IDENTITY)]).unwrap_err(),
        SceneError::NoSuchMesh { mesh: 1, meshes: 1 }
    );
    assert!(matches!(
        Rigid::new(Quat::from_xyzw(0.0, 0.0, 0.0, 1.5), Vec3::ZERO),
        Err(SceneError::NonRigidTransform { .. })
    ));
    assert_eq!(
        Rigid::new(Quat::IDENTITY, Vec3::new(0.0, f32::INFINITY, 0.0)),
        Err(SceneError::NonFiniteTransform)
    );
    assert_eq!(
        Rigid::new(Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0), Vec3::ZERO),
        Err(SceneError::NonFiniteTransform)
    );
    let far = Rigid::from_translation(Vec3::splat(100.0)).unwrap();
    assert_eq!(
        scene.set_transform(12, far),
        Err(SceneError::NoSuchInstance {
            instance: 12,
            instances: 12
        })
    );
    // One bad index in a batch of moves: nothing moves.
    assert!(scene.set_transforms(&[(0, far), (99, far)]).is_err());
    assert!(scene.set_mask(40, 0).is_err());
    // Deformations: wrong count, NaN, a kind that cannot be refitted, a missing mesh.
    let verts = meshes[0].vertices().to_vec();
    assert_eq!(
        scene.deform_mesh(0, verts[1..].to_vec()),
        Err(SceneError::VertexCountChanged {
            expected: verts.len(),
            given: verts.len() - 1
        })
    );
    let mut nan = verts.clone();
    nan[3].y = f32::NAN;
    assert_eq!(
        scene.deform_mesh(0, nan),
        Err(SceneError::Mesh(MeshError::NonFiniteVertex { vertex: 3 }))
    );
    assert_eq!(
        scene.deform_mesh(1, meshes[1].vertices().to_vec()),
        Err(SceneError::NotRefittable { kind: "zbt" })
    );
    assert!(matches!(
        scene.deform_mesh(2, verts.clone()),
        Err(SceneError::NoSuchMesh { .. })
    ));
    assert_matches(&scene, &meshes, &descs, &rays);
}

#[test]
fn a_triangle_degenerate_at_build_refuses_a_refit_that_gives_it_an_area() {
    let flat = Mesh::new(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(2.0, 0.0, 0.0)],
        vec![[0, 1, 2], [0, 1, 3]],
    )
    .unwrap();
    let tree = AccelKind::Aabb
        .build(flat, &BuildOptions::default())
        .unwrap();
    let mut scene = Scene::new(vec![tree], &[InstanceDesc::new(0, Rigid::IDENTITY)]).unwrap();
    let lifted = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(2.0, 0.0, 1.0)];
    assert_eq!(
        scene.deform_mesh(0, lifted),
        Err(SceneError::NewlyValidTriangle { triangle: 1 })
    );
    let hit = scene
        .cast_ray(&Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z))
        .unwrap();
    assert_eq!(hit.triangle, 0);
}

/// A deformation that collapses a triangle the tree tests (a vertex moved onto the line of
/// the other two) is refused, and the scene keeps answering as before it; rays aimed at the
/// collapsed edge would otherwise hit a triangle with no area.
#[test]
fn a_refit_that_collapses_a_triangle_is_refused() {
    let mesh = Mesh::new(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
        vec![[0, 1, 2], [1, 3, 2]],
    )
    .unwrap();
    let tree = AccelKind::Aabb
        .build(mesh, &BuildOptions::default())
        .unwrap();
    let mut scene = Scene::new(vec![tree], &[InstanceDesc::new(0, Rigid::IDENTITY)]).unwrap();
    let ray = Ray::new(Vec3::new(0.75, 0.75, -1.0), Vec3::Z);
    let before = scene.cast_ray(&ray);
    assert_eq!(before.map(|h| h.triangle), Some(1));
    // Vertex 3 onto the segment from vertex 1 to vertex 2: triangle 1 has no area.
    let collapsed = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.5, 0.5, 0.0)];
    assert_eq!(
        scene.deform_mesh(0, collapsed),
        Err(SceneError::NewlyDegenerateTriangle { triangle: 1 })
    );
    assert_eq!(scene.cast_ray(&ray), before);
}

/// Instances added (a few: inserted into the top level; many: rebuilt) and removed during
/// play: the scene answers as brute force over its live instances, and as a scene built from
/// scratch over them (same instance, triangle and hit, per ray and batched); removed
/// instances keep their index, refuse edits, and a refused addition changes nothing.
#[test]
fn added_and_removed_instances_answer_as_a_scene_built_from_scratch() {
    let meshes = vec![icosphere(1), icosphere(2)];
    let place = |i: usize| {
        let at = Vec3::new((i % 6) as f32 * 2.2 - 5.5, (i / 6) as f32 * 2.2 - 5.5, 0.0);
        InstanceDesc::new(
            i % 2,
            Rigid::new(Quat::from_rotation_z(i as f32), at).unwrap(),
        )
        .with_user(i as u64)
    };
    let first: Vec<InstanceDesc> = (0..2).map(place).collect();
    let mut scene = build_scene(&meshes, &[AccelKind::Bvh8, AccelKind::Zbt], &first);
    // Many at once (rebuilt), then a few at a time (inserted).
    let many: Vec<InstanceDesc> = (2..30).map(place).collect();
    assert_eq!(scene.add_instances(&many), Ok(2..30));
    assert_eq!(
        scene.add_instances(&[place(30), place(31), place(32)]),
        Ok(30..33)
    );
    scene.remove_instance(1).unwrap();
    scene.remove_instance(31).unwrap();
    for i in 33..40 {
        assert_eq!(scene.add_instances(&[place(i)]), Ok(i..i + 1));
    }
    scene.remove_instance(35).unwrap();
    let moved = Rigid::from_translation(Vec3::new(0.0, 3.0, 1.0)).unwrap();
    scene.set_transform(36, moved).unwrap();

    for edit in [
        scene.remove_instance(1),
        scene.set_mask(35, 1),
        scene.set_user(31, 1),
        scene.set_transform(1, Rigid::IDENTITY),
    ] {
        assert!(
            matches!(edit, Err(SceneError::RemovedInstance { .. })),
            "{edit:?}"
        );
    }
    let before = scene.instances().len();
    assert!(matches!(
        scene.add_instances(&[place(40), InstanceDesc::new(9, Rigid::IDENTITY)]),
        Err(SceneError::NoSuchMesh { mesh: 9, .. })
    ));
    assert_eq!(scene.instances().len(), before);
    assert!(scene.instances()[1].is_removed() && scene.instances()[35].is_removed());

    // Rays from all around aimed near the instances, removed ones included.
    let mut rng = seeded(21);
    let rays: Vec<Ray> = (0..1200)
        .map(|k| {
            let from = crate::common::rng::in_cube(&mut rng, 9.0);
            let near =
                place(k % 40).transform.translation() + crate::common::rng::in_cube(&mut rng, 0.8);
            Ray::new(from, near - from)
        })
        .collect();
    assert_matches(&scene, &meshes, &descs_of(&scene), &rays);

    let live: Vec<usize> = (0..scene.instances().len())
        .filter(|&i| !scene.instances()[i].is_removed())
        .collect();
    let fresh_descs: Vec<InstanceDesc> = descs_of(&scene)
        .into_iter()
        .enumerate()
        .filter(|(i, _)| live.contains(i))
        .map(|(_, d)| d)
        .collect();
    let fresh = build_scene(&meshes, &[AccelKind::Bvh8, AccelKind::Zbt], &fresh_descs);
    let mut batched = vec![None; rays.len()];
    scene.cast_ray_batch_resolved(&rays, &mut batched).unwrap();
    let mut hits = 0;
    for (ray, got) in rays.iter().zip(&batched) {
        let want = fresh.cast_ray_resolved(ray);
        let renamed = got.map(|h| raybatch::scene::SceneHit {
            instance: live.iter().position(|&i| i == h.instance as usize).unwrap() as u32,
            ..h
        });
        assert_eq!(renamed, want, "{ray:?}");
        assert_eq!(*got, scene.cast_ray_resolved(ray));
        hits += usize::from(got.is_some());
    }
    assert!(hits > 600, "{hits} hits");
}

/// `Scene::from_meshes` builds small meshes as 4-wide trees and the others as the library's
/// pick for them, and answers as brute force.
#[test]
fn scenes_pick_a_kind_per_mesh() {
    let meshes = vec![icosphere(1), icosphere(3)];
    assert!(meshes[0].triangle_count() < 256 && meshes[1].triangle_count() >= 256);
    let descs: Vec<InstanceDesc> = (0..6)
        .map(|i| {
            let at = Vec3::new(i as f32 * 2.5 - 6.0, 0.0, 0.0);
            InstanceDesc::new(i % 2, Rigid::from_translation(at).unwrap())
        })
        .collect();
    let scene = Scene::from_meshes(meshes.clone(), &descs).unwrap();
    assert_eq!(scene.meshes()[0].kind(), AccelKind::Bvh4);
    assert_eq!(scene.meshes()[1].kind(), AccelKind::for_mesh(&meshes[1]));
    assert_eq!(Scene::kind_for(&meshes[1]), AccelKind::for_mesh(&meshes[1]));
    assert_matches(&scene, &meshes, &descs, &sphere_rays(300, 5));
    let bad = [InstanceDesc::new(2, Rigid::IDENTITY)];
    assert!(matches!(
        Scene::from_meshes(meshes, &bad),
        Err(SceneError::NoSuchMesh { mesh: 2, meshes: 2 })
    ));
}

/// Ten thousand random edits during play (add one or a few, remove, move, change layers),
/// each followed by rays through the scene: every answer, per ray and batched, names the same
/// instance, triangle and hit as a scene built from scratch over the live instances.
#[test]
#[ignore = "heavy: 10,000 edits, each checked against a scene built from scratch (the full tier)"]
fn ten_thousand_random_edits_answer_as_fresh_scenes() {
    let meshes = vec![icosphere(0), icosphere(1)];
    let mut rng = seeded(77);
    let place = |rng: &mut crate::common::rng::StdRng| {
        let at = crate::common::rng::in_cube(rng, 6.0);
        let turn = Quat::from_rotation_z(rng.random_range(0.0..6.0));
        let scale = [0.5, 1.0, 2.0][rng.random_range(0..3)];
        let rigid = Rigid::new(turn, at).unwrap().with_scale(scale).unwrap();
        InstanceDesc::new(rng.random_range(0..2), rigid).with_mask(rng.random_range(1..4))
    };
    let first: Vec<InstanceDesc> = (0..8).map(|_| place(&mut rng)).collect();
    let mut scene = build_scene(&meshes, &[AccelKind::Bvh4, AccelKind::Bvh8], &first);
    let options = BatchOptions::default().with_min_batch(0);
    for edit in 0..10_000 {
        let count = scene.instances().len();
        let live: Vec<usize> = (0..count)
            .filter(|&i| !scene.instances()[i].is_removed())
            .collect();
        match rng.random_range(0..10) {
            0..=2 => {
                let n = if rng.random_range(0..8) == 0 { 5 } else { 1 };
                let added: Vec<InstanceDesc> = (0..n).map(|_| place(&mut rng)).collect();
                scene.add_instances(&added).unwrap();
            }
            3..=4 if live.len() > 4 => {
                let i = live[rng.random_range(0..live.len())];
                scene.remove_instance(i).unwrap();
            }
            5..=7 if !live.is_empty() => {
                let i = live[rng.random_range(0..live.len())];
                scene.set_transform(i, place(&mut rng).transform).unwrap();
            }
            _ if !live.is_empty() => {
                let i = live[rng.random_range(0..live.len())];
                scene.set_mask(i, rng.random_range(1..4)).unwrap();
            }
            _ => {}
        }
        let live: Vec<usize> = (0..scene.instances().len())
            .filter(|&i| !scene.instances()[i].is_removed())
            .collect();
        let descs = descs_of(&scene);
        let fresh_descs: Vec<InstanceDesc> = live.iter().map(|&i| descs[i]).collect();
        let fresh = build_scene(&meshes, &[AccelKind::Bvh4, AccelKind::Bvh8], &fresh_descs);
        let rays: Vec<Ray> = (0..24)
            .map(|_| {
                let from = crate::common::rng::in_cube(&mut rng, 9.0);
                let aim = crate::common::rng::in_cube(&mut rng, 6.0);
                Ray::new(from, aim - from)
            })
            .collect();
        let mask = [u32::MAX, 1, 2][edit % 3];
        let (view, fresh_view) = (
            scene.filtered(RayFilter::on_layers(mask)),
            fresh.filtered(RayFilter::on_layers(mask)),
        );
        let mut batched = vec![None; rays.len()];
        view.cast_ray_batch_resolved_with(&rays, &mut batched, &options)
            .unwrap();
        let mut occluded = vec![false; rays.len()];
        view.occluded_batch_with(&rays, &mut occluded, &options)
            .unwrap();
        for (k, ray) in rays.iter().enumerate() {
            let want = fresh_view.cast_ray_resolved(ray);
            let got = view.cast_ray_resolved(ray);
            let renamed = got.map(|h| raybatch::scene::SceneHit {
                instance: live.iter().position(|&i| i == h.instance as usize).unwrap() as u32,
                ..h
            });
            assert_eq!(renamed, want, "edit {edit}: {ray:?}");
            assert_eq!(batched[k], got, "edit {edit}: batched {ray:?}");
            assert_eq!(
                occluded[k],
                fresh_view.occluded(ray),
                "edit {edit}: {ray:?}"
            );
        }
    }
}

#[test]
fn a_mesh_added_later_answers_once_placed() {
    let meshes = vec![icosphere(1), icosphere(2)];
    let at = |x: f32| Rigid::from_translation(Vec3::new(x, 0.0, 0.0)).unwrap();
    let descs = [
        InstanceDesc::new(0, at(-2.0)),
        InstanceDesc::new(1, at(2.0)),
    ];
    let mut scene = build_scene(&meshes[..1], &[AccelKind::Bvh8], &descs[..1]);
    let rays = sphere_rays(400, 31);
    let before: Vec<_> = rays.iter().map(|r| opt_bits(scene.cast_ray(r))).collect();
    let tree = AccelKind::Zbt
        .build(meshes[1].clone(), &BuildOptions::default())
        .unwrap();
    // Added but not placed: nothing changes.
    assert_eq!(scene.add_mesh(tree), 1);
    assert_eq!(scene.meshes().len(), 2);
    let after: Vec<_> = rays.iter().map(|r| opt_bits(scene.cast_ray(r))).collect();
    assert_eq!(before, after);
    // Placed: the scene answers as one built with both meshes.
    assert_eq!(scene.add_instances(&descs[1..]), Ok(1..2));
    assert_matches(&scene, &meshes, &descs, &rays);
}
