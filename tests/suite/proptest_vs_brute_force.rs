//! Every structure of the zoo (every kind, leaf size and ordering) and kernel must answer
//! exactly like the brute-force reference: same closest hit (triangle id and the bits of `t`,
//! `u`, `v`), same occlusion, same hits (`all_hits`, and `for_each_hit_with` for both kernels).

use crate::common::oracles::{bits, closest_is_first_of_all_hits, compare_all, describe};
use crate::common::strategies::{RaySpec, aimed_ray_spec, mesh_strategy, ray_spec};
use crate::common::zoo::all_structures;
use proptest::prelude::*;
use raybatch::brute_force;
use raybatch::{Kernel, Mesh};

fn check(mesh: &Mesh, specs: &[RaySpec]) -> Result<(), TestCaseError> {
    let zoo = all_structures(mesh);
    for spec in specs {
        let ray = spec.resolve(mesh);
        compare_all(mesh, &zoo, &ray)
            .map_err(|e| TestCaseError::fail(format!("{spec:?}: {e}\nmesh: {}", describe(mesh))))?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Every structure of the zoo (18 with two kinds) against brute force on random soups
    /// (shared vertices, degenerate, duplicated and coplanar triangles) and random rays
    /// (axis-parallel with signed zeros, aimed at vertices and edge midpoints, starting on the
    /// surface, bounded and unbounded).
    #[test]
    fn trees_match_brute_force(
        mesh in mesh_strategy(),
        specs in prop::collection::vec(ray_spec(), 32),
    ) {
        check(&mesh, &specs)?;
    }

    /// The same on rays aimed exactly at vertices and edge midpoints only, where hits fall on
    /// box boundaries and ties between neighbouring triangles are most frequent.
    #[test]
    fn trees_match_brute_force_on_vertex_rays(
        mesh in mesh_strategy(),
        specs in prop::collection::vec(aimed_ray_spec(), 16),
    ) {
        check(&mesh, &specs)?;
    }

    /// The reference itself is consistent: `all_hits` sorted by `t` (total order) then id, the
    /// closest hit has the smallest `t` and the lowest id among hits at that `t`, `occluded`
    /// agrees, degenerate triangles are never hit, every `t` is in range.
    #[test]
    fn brute_force_is_self_consistent(
        mesh in mesh_strategy(),
        specs in prop::collection::vec(ray_spec(), 16),
    ) {
        for spec in &specs {
            let ray = spec.resolve(&mesh);
            for kernel in Kernel::ALL {
                let all = brute_force::all_hits(&mesh, &ray, kernel);
                let closest = brute_force::cast_ray(&mesh, &ray, kernel);
                let occluded = !all.is_empty() || !ray.is_valid();
                prop_assert_eq!(brute_force::occluded(&mesh, &ray, kernel), occluded);
                prop_assert_eq!(closest.is_some(), !all.is_empty());
                if let Some(c) = closest {
                    let min_t = all.iter().map(|h| h.t).fold(f32::INFINITY, f32::min);
                    prop_assert!(c.t == min_t, "closest {c:?} but smallest t {min_t}");
                    let lowest = all.iter().filter(|h| h.t == c.t).map(|h| h.triangle).min();
                    prop_assert_eq!(Some(c.triangle), lowest, "tie rule broken: {:?}", all);
                    prop_assert!(all.iter().any(|h| bits(h) == bits(&c)));
                }
                for w in all.windows(2) {
                    let order = w[0].t.total_cmp(&w[1].t).then(w[0].triangle.cmp(&w[1].triangle));
                    prop_assert!(order.is_lt(), "all_hits not strictly sorted: {:?}", w);
                }
                for h in &all {
                    prop_assert!(!mesh.is_degenerate(h.triangle), "degenerate triangle hit: {h:?}");
                    prop_assert!(h.t >= ray.tmin && h.t <= ray.tmax, "t out of range: {h:?}");
                    prop_assert!(h.t.is_finite(), "infinite t: {h:?}");
                }
            }
        }
    }

    /// The tie rule seen through `all_hits`: the closest hit is `all_hits()[0]`, bit for bit.
    #[test]
    fn closest_hit_is_first_of_all_hits(
        mesh in mesh_strategy(),
        specs in prop::collection::vec(ray_spec(), 32),
    ) {
        for spec in &specs {
            closest_is_first_of_all_hits(&mesh, &spec.resolve(&mesh))
                .map_err(|e| TestCaseError::fail(format!("{e}\nmesh: {}", describe(&mesh))))?;
        }
    }
}
