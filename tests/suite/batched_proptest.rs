//! The batched queries against the single-ray reference, bit for bit, on random input: random
//! triangle soups (duplicates, degenerate and coplanar triangles, sometimes over an icosphere),
//! random batches of rays (some with `tmin > 0`, some invalid) and random option combinations,
//! for every structure of the zoo; in order and shuffled.

use crate::common::batch::{Combo, check_shuffled, check_zoo, combo_strategy};
use crate::common::oracles::describe;
use crate::common::rays::invalid_rays;
use crate::common::strategies::{RaySpec, aimed_ray_spec, mesh_strategy, ray_spec};
use crate::common::zoo::{ZOO_SIZE, all_structures};
use proptest::prelude::*;
use raybatch::{Mesh, Ray};

/// How a generated ray is changed after it is resolved on the mesh.
#[derive(Clone, Copy, Debug)]
enum Tweak {
    None,
    /// `tmin = 0.3 tmax` (with `tmax = 3` if it was unbounded).
    TminFraction,
    /// Replaced by one of [`invalid_rays`].
    Invalid(usize),
}

fn tweak() -> impl Strategy<Value = Tweak> {
    prop_oneof![
        8 => Just(Tweak::None),
        2 => Just(Tweak::TminFraction),
        1 => (0usize..14).prop_map(Tweak::Invalid),
    ]
}

fn apply(spec: &RaySpec, tweak: Tweak, mesh: &Mesh) -> Ray {
    let ray = spec.resolve(mesh);
    match tweak {
        Tweak::None => ray,
        Tweak::TminFraction => {
            let tmax = if ray.tmax.is_finite() { ray.tmax } else { 3.0 };
            Ray::with_range(ray.origin, ray.dir, 0.3 * tmax, tmax)
        }
        Tweak::Invalid(k) => invalid_rays()[k],
    }
}

const BATCH_SIZES: [usize; 6] = [0, 1, 2, 7, 64, 1000];

/// A batch of ray specs of one of [`BATCH_SIZES`].
fn batch_strategy() -> impl Strategy<Value = Vec<(RaySpec, Tweak)>> {
    prop::sample::select(BATCH_SIZES.to_vec()).prop_flat_map(|n| {
        prop::collection::vec(
            (prop_oneof![2 => ray_spec(), 1 => aimed_ray_spec()], tweak()),
            n,
        )
    })
}

fn resolve_all(specs: &[(RaySpec, Tweak)], mesh: &Mesh) -> Vec<Ray> {
    specs.iter().map(|(s, t)| apply(s, *t, mesh)).collect()
}

/// Random triangle soups (duplicates, degenerate and coplanar triangles, sometimes over an
/// icosphere), random batches of rays, every structure, two random option combinations each.
fn batched_equals_single_ray(
    mesh: &Mesh,
    specs: &[(RaySpec, Tweak)],
    combos: &[Combo],
) -> Result<(), TestCaseError> {
    let rays = resolve_all(specs, mesh);
    let zoo = all_structures(mesh);
    check_zoo(&zoo, &rays, |t| combos[2 * t..2 * t + 2].to_vec())
        .map_err(|e| TestCaseError::fail(format!("{e}\nmesh: {}", describe(mesh))))
}

/// The same batches shuffled: results mapped back to the original order are the same.
fn ray_order_does_not_matter(
    mesh: &Mesh,
    specs: &[(RaySpec, Tweak)],
    seed: u64,
    combos: &[Combo],
) -> Result<(), TestCaseError> {
    let rays = resolve_all(specs, mesh);
    for (t, tree) in all_structures(mesh).iter().enumerate() {
        check_shuffled(tree, &rays, seed, &combos[t])
            .map_err(|e| TestCaseError::fail(format!("{e}\nmesh: {}", describe(mesh))))?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn prop_batched_equals_single_ray(
        mesh in mesh_strategy(),
        specs in batch_strategy(),
        combos in prop::collection::vec(combo_strategy(), 2 * ZOO_SIZE),
    ) {
        batched_equals_single_ray(&mesh, &specs, &combos)?;
    }

    #[test]
    fn prop_ray_order_does_not_matter(
        mesh in mesh_strategy(),
        specs in batch_strategy(),
        seed in any::<u64>(),
        combos in prop::collection::vec(combo_strategy(), ZOO_SIZE),
    ) {
        ray_order_does_not_matter(&mesh, &specs, seed, &combos)?;
    }
}

// The full tier: four times the cases.
proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    #[ignore = "heavy: 96 random cases (the full tier)"]
    fn prop_batched_equals_single_ray_full(
        mesh in mesh_strategy(),
        specs in batch_strategy(),
        combos in prop::collection::vec(combo_strategy(), 2 * ZOO_SIZE),
    ) {
        batched_equals_single_ray(&mesh, &specs, &combos)?;
    }

    #[test]
    #[ignore = "heavy: 96 random cases (the full tier)"]
    fn prop_ray_order_does_not_matter_full(
        mesh in mesh_strategy(),
        specs in batch_strategy(),
        seed in any::<u64>(),
        combos in prop::collection::vec(combo_strategy(), ZOO_SIZE),
    ) {
        ray_order_does_not_matter(&mesh, &specs, seed, &combos)?;
    }
}
