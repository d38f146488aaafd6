//! Scenes answer exactly: per ray and batched, closest / any / all hits, both kernels, with
//! layer filters, for instances of random soups under random rigid transforms (shared meshes,
//! mixed tree kinds), equal bit for bit to brute force over every instance's mesh with the ray
//! carried into mesh space by the documented transform (`Rigid::ray_to_mesh`); the tie rule
//! applies to global ids (lowest instance, then lowest triangle).

use std::sync::Mutex;

use crate::common::oracles::{HitBits, all_bits, bits, opt_bits};
use crate::common::rays::invalid_rays;
use crate::common::scenes::{build_scene, instances, scene_brute_force, world_mesh};
use crate::common::strategies::{RaySpec, mesh_strategy, ray_spec};
use glam::Vec3;
use proptest::prelude::*;
use raybatch::scene::{InstanceDesc, RayFilter, Rigid};
use raybatch::{AccelKind, BatchOptions, BatchQueries, Kernel, Mesh, Ray, RayQueries};

/// Compares every query of `accel` (a scene or a filtered view) with the oracle on `rays`.
fn compare<A: RayQueries + BatchQueries>(
    accel: &A,
    meshes: &[Mesh],
    descs: &[InstanceDesc],
    rays: &[Ray],
    mask: u32,
    single_ray_below: usize,
) -> Result<(), String> {
    for kernel in Kernel::ALL {
        let refs: Vec<_> = rays
            .iter()
            .map(|r| scene_brute_force(meshes, descs, r, kernel, mask))
            .collect();
        for (ray, r) in rays.iter().zip(&refs) {
            let got = accel.cast_ray_with(ray, kernel);
            if opt_bits(got) != opt_bits(r.closest) {
                return Err(format!(
                    "{kernel:?} closest {got:?}, expected {:?} for {ray:?}",
                    r.closest
                ));
            }
            if accel.occluded_with(ray, kernel) != r.occluded {
                return Err(format!("{kernel:?} occluded differs for {ray:?}"));
            }
            let mut each = Vec::new();
            accel.for_each_hit_with(ray, kernel, &mut |h| each.push(bits(&h)));
            each.sort_unstable();
            let mut expected = all_bits(&r.all);
            expected.sort_unstable();
            if each != expected {
                return Err(format!(
                    "{kernel:?} all hits {each:?}, expected {expected:?} for {ray:?}"
                ));
            }
        }
        let options = BatchOptions::default()
            .with_kernel(kernel)
            .with_min_batch(0)
            .with_single_ray_below(single_ray_below);
        let mut hits = vec![None; rays.len()];
        accel
            .cast_ray_batch_with(rays, &mut hits, &options)
            .unwrap();
        let mut occluded = vec![false; rays.len()];
        accel
            .occluded_batch_with(rays, &mut occluded, &options)
            .unwrap();
        let all = Mutex::new(Vec::<(usize, HitBits)>::new());
        accel.for_each_hit_batch_with(rays, &options, &|i, h| {
            all.lock().unwrap().push((i, bits(&h)))
        });
        let mut all = all.into_inner().unwrap();
        all.sort_unstable();
        let mut expected_all: Vec<(usize, HitBits)> = refs
            .iter()
            .enumerate()
            .flat_map(|(i, r)| r.all.iter().map(move |h| (i, bits(h))))
            .collect();
        expected_all.sort_unstable();
        for (i, r) in refs.iter().enumerate() {
            if opt_bits(hits[i]) != opt_bits(r.closest) || occluded[i] != r.occluded {
                return Err(format!(
                    "{kernel:?} batched ray {i}: {:?} / {}, expected {:?} / {} for {:?}",
                    hits[i], occluded[i], r.closest, r.occluded, rays[i]
                ));
            }
        }
        if all != expected_all {
            return Err(format!("{kernel:?} batched all hits differ"));
        }
    }
    Ok(())
}

/// Rays aimed at the world-space copies of the instances (`specs[k]` at instance `k % n`),
/// plus the invalid rays.
fn world_rays(meshes: &[Mesh], descs: &[InstanceDesc], specs: &[RaySpec]) -> Vec<Ray> {
    let worlds: Vec<Mesh> = descs.iter().map(|d| world_mesh(meshes, d)).collect();
    let mut rays: Vec<Ray> = specs
        .iter()
        .enumerate()
        .map(|(k, s)| s.resolve(&worlds[k % worlds.len()]))
        .collect();
    rays.extend(invalid_rays());
    rays
}

/// Rays resolved in mesh space (origins and targets near the mesh) and carried to the world
/// by instance `k % n`'s transform: short rays that start next to a far instance.
fn near_rays(meshes: &[Mesh], descs: &[InstanceDesc], specs: &[RaySpec]) -> Vec<Ray> {
    specs
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let d = &descs[k % descs.len()];
            let r = s.resolve(&meshes[d.mesh]);
            let origin = d.transform.point_to_world(r.origin);
            let dir = d.transform.rotation() * r.dir;
            Ray::with_range(origin, dir, r.tmin, r.tmax)
        })
        .collect()
}

fn kinds_from(offset: usize) -> Vec<AccelKind> {
    (0..AccelKind::ALL.len())
        .map(|i| AccelKind::ALL[(i + offset) % AccelKind::ALL.len()])
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Random soups (ties, degenerate and duplicated triangles), 1 to 6 instances of up to 3
    /// meshes (shared), random rotations and translations, mixed tree kinds, layer masks.
    #[test]
    fn scene_matches_brute_force(
        meshes in prop::collection::vec(mesh_strategy(), 1..=3),
        descs in instances(3, 6),
        specs in prop::collection::vec(ray_spec(), 24),
        offset in 0usize..6,
        mask in prop_oneof![Just(u32::MAX), 1u32..4],
        single_ray_below in prop_oneof![Just(0usize), Just(4), Just(1000)],
    ) {
        let descs: Vec<InstanceDesc> = descs
            .into_iter()
            .map(|d| InstanceDesc { mesh: d.mesh % meshes.len(), ..d })
            .collect();
        let scene = build_scene(&meshes, &kinds_from(offset), &descs);
        let rays = world_rays(&meshes, &descs, &specs);
        let result = if mask == u32::MAX {
            compare(&scene, &meshes, &descs, &rays, mask, single_ray_below)
        } else {
            compare(&scene.filtered(RayFilter::on_layers(mask)), &meshes, &descs, &rays, mask, single_ray_below)
        };
        result.map_err(TestCaseError::fail)?;
    }
}

/// Rays from `back` direction lengths behind their origin (range shifted to match): the
/// same lines, seen from far away, where the transform's rounding is largest.
fn from_far(rays: &[Ray], back: f32) -> Vec<Ray> {
    rays.iter()
        .map(|r| Ray::with_range(r.origin - r.dir * back, r.dir, r.tmin + back, r.tmax + back))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Far from the origin: instances moved by up to 3,000 units, rays starting up to 1,000
    /// direction lengths away. The top level's padded boxes must still cover the rounding of
    /// the mesh-space rays (the module docs of `scene::instance`).
    #[test]
    fn far_scene_matches_brute_force(
        meshes in prop::collection::vec(mesh_strategy(), 1..=2),
        descs in instances(2, 4),
        specs in prop::collection::vec(ray_spec(), 16),
        scale in prop_oneof![Just(1000.0f32), 1.0f32..1000.0],
        back in prop_oneof![Just(1000.0f32), 0.0f32..1000.0],
    ) {
        let descs: Vec<InstanceDesc> = descs
            .into_iter()
            .map(|d| {
                let t = d.transform;
                let transform = Rigid::new(t.rotation(), t.translation() * scale).unwrap();
                InstanceDesc { mesh: d.mesh % meshes.len(), transform, ..d }
            })
            .collect();
        let scene = build_scene(&meshes, &[AccelKind::Aabb, AccelKind::Bvh4], &descs);
        let mut rays = from_far(&world_rays(&meshes, &descs, &specs), back);
        rays.extend(near_rays(&meshes, &descs, &specs));
        compare(&scene, &meshes, &descs, &rays, u32::MAX, 0).map_err(TestCaseError::fail)?;
    }
}

/// Two instances of one mesh at the same place: every hit is a tie, won by the lower
/// instance (lower global id), per ray and batched; `resolve` names the instance.
#[test]
fn ties_between_instances_go_to_the_lower_instance() {
    let meshes = vec![crate::common::meshes::icosphere(1)];
    let at = Rigid::from_translation(Vec3::new(0.5, 0.0, 0.0)).unwrap();
    let descs = vec![InstanceDesc::new(0, at), InstanceDesc::new(0, at)];
    let scene = build_scene(&meshes, &[AccelKind::Bvh4], &descs);
    let ray = Ray::new(Vec3::new(0.61, 0.13, -5.0), Vec3::Z);
    let hit = scene.cast_ray(&ray).unwrap();
    let resolved = scene.resolve(&ray, hit).unwrap();
    assert_eq!(resolved.instance, 0);
    assert_eq!(scene.all_hits(&ray).len(), 4);
    let rays = vec![ray; 64];
    compare(&scene, &meshes, &descs, &rays, u32::MAX, 0).unwrap();
}
