//! Cooked structures and scenes: what loads answers every query as the structure that was
//! saved and as brute force, per ray and batched, for every kind that cooks and every leaf
//! option; kinds that do not cook say so; files go to disk and back.

use std::sync::Arc;

use crate::common::oracles::{all_bits, bits, opt_bits};
use crate::common::scenes::{build_scene, instances};
use crate::common::strategies::{RaySpec, mesh_strategy, ray_spec};
use proptest::prelude::*;
use raybatch::{
    AccelKind, AnyAccel, BatchQueries, BuildOptions, CookError, Kernel, LeafCopy, Mesh, Ray,
    RayQueries, Scene, brute_force,
};

/// The kinds that cook ([`AccelKind::cooks`]: the binary and the wide trees), in the list's
/// order.
fn cooked() -> Vec<AccelKind> {
    AccelKind::ALL.into_iter().filter(|k| k.cooks()).collect()
}

/// `loaded` answers each ray as brute force over `mesh` and as `saved`, per ray and batched.
fn compare(mesh: &Mesh, saved: &AnyAccel, loaded: &AnyAccel, rays: &[Ray]) -> Result<(), String> {
    for ray in rays {
        let expected = brute_force::cast_ray(mesh, ray, Kernel::Watertight);
        let got = loaded.cast_ray(ray);
        if opt_bits(got) != opt_bits(expected) || opt_bits(got) != opt_bits(saved.cast_ray(ray)) {
            return Err(format!(
                "closest {got:?}, expected {expected:?} for {ray:?}"
            ));
        }
        if loaded.occluded(ray) != brute_force::occluded(mesh, ray, Kernel::Watertight) {
            return Err(format!("occluded differs for {ray:?}"));
        }
        let mut each = Vec::new();
        loaded.for_each_hit(ray, &mut |h| each.push(bits(&h)));
        each.sort_unstable();
        let mut all = all_bits(&brute_force::all_hits(mesh, ray, Kernel::Watertight));
        all.sort_unstable();
        if each != all {
            return Err(format!("all hits differ for {ray:?}"));
        }
    }
    let mut batched = vec![None; rays.len()];
    loaded.cast_ray_batch(rays, &mut batched).unwrap();
    for (ray, hit) in rays.iter().zip(&batched) {
        if opt_bits(*hit) != opt_bits(loaded.cast_ray(ray)) {
            return Err(format!("batched {hit:?} differs from per ray for {ray:?}"));
        }
    }
    Ok(())
}

fn resolve(specs: &[RaySpec], mesh: &Mesh) -> Vec<Ray> {
    specs.iter().map(|s| s.resolve(mesh)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random soups (ties, degenerate and duplicated triangles), every kind that cooks, leaf
    /// sizes and copies drawn at random.
    #[test]
    fn loaded_structures_answer_as_saved_and_as_brute_force(
        mesh in mesh_strategy(),
        specs in prop::collection::vec(ray_spec(), 32),
        leaf in 1u32..=8,
        wide_leaf in 1u32..=16,
        copy in prop::sample::select(LeafCopy::ALL.to_vec()),
    ) {
        let mesh = Arc::new(mesh);
        let rays = resolve(&specs, &mesh);
        let options = BuildOptions::default()
            .with_leaf_size(leaf)
            .with_wide_leaf_size(wide_leaf)
            .with_leaf_copy(copy);
        for kind in cooked() {
            let saved = kind.build(mesh.clone(), &options).unwrap();
            let loaded = AnyAccel::from_cooked(&saved.to_cooked().unwrap()).unwrap();
            prop_assert_eq!(loaded.kind(), kind);
            let checked = compare(&mesh, &saved, &loaded, &rays);
            prop_assert!(checked.is_ok(), "{:?}: {}", kind, checked.unwrap_err());
        }
    }

    /// Scenes of random soups under random transforms and layers, meshes of every kind that
    /// cooks, one instance removed: the loaded scene answers as the saved one, resolved hits
    /// included.
    #[test]
    fn loaded_scenes_answer_as_saved(
        meshes in prop::collection::vec(mesh_strategy(), 1..=3),
        descs in instances(3, 5),
        specs in prop::collection::vec(ray_spec(), 24),
        offset in 0usize..6,
        removed in 0usize..5,
    ) {
        let meshes: Vec<Mesh> = descs.iter().map(|d| d.mesh).max().map_or(meshes.clone(), |m| {
            (0..=m).map(|i| meshes[i % meshes.len()].clone()).collect()
        });
        let cooked = cooked();
        let kinds: Vec<AccelKind> = (0..cooked.len()).map(|i| cooked[(i + offset) % cooked.len()]).collect();
        let mut saved = build_scene(&meshes, &kinds, &descs);
        saved.remove_instance(removed % descs.len()).unwrap();
        let loaded = Scene::from_cooked(&saved.to_cooked().unwrap()).unwrap();
        let rays: Vec<Ray> = specs
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let d = &descs[k % descs.len()];
                let r = s.resolve(&meshes[d.mesh]);
                Ray::with_range(d.transform.point_to_world(r.origin), d.transform.rotation() * r.dir, r.tmin, r.tmax)
            })
            .collect();
        for ray in &rays {
            prop_assert_eq!(opt_bits(loaded.cast_ray(ray)), opt_bits(saved.cast_ray(ray)));
            prop_assert_eq!(loaded.occluded(ray), saved.occluded(ray));
            prop_assert_eq!(loaded.cast_ray_resolved(ray), saved.cast_ray_resolved(ray));
        }
        let mut batched = (vec![None; rays.len()], vec![None; rays.len()]);
        saved.cast_ray_batch(&rays, &mut batched.0).unwrap();
        loaded.cast_ray_batch(&rays, &mut batched.1).unwrap();
        prop_assert_eq!(batched.0, batched.1);
    }
}

#[test]
fn kinds_that_do_not_cook_say_so() {
    let mesh = Arc::new(crate::common::meshes::icosphere(1));
    for kind in AccelKind::ALL {
        let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        match tree.to_cooked() {
            Ok(_) => assert!(kind.cooks(), "{kind:?}"),
            Err(CookError::Unsupported(k)) => assert!(k == kind && !kind.cooks(), "{kind:?}"),
            Err(e) => panic!("{kind:?}: {e}"),
        }
    }
}
