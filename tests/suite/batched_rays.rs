//! The batched queries against the single-ray reference, bit for bit, on the rays that test
//! the contract's edges: invalid rays (they miss in every path, alone or among valid rays),
//! rays that miss the structure's box (answered while the batch is prepared), exact duplicate
//! triangles (the lowest id wins every tie) and shuffled batches (answers do not depend on the
//! order of the rays), for every structure of the zoo.

use crate::common::batch::{
    all_combos, batched_closest, batched_hits, batched_occluded, check_combo, check_shuffled,
    compare_closest, kernel_index, ok, single_ray_answers_both, spread_combos,
};
use crate::common::meshes::{icosphere_all_duplicated, icosphere_with_duplicates};
use crate::common::oracles::opt_bits;
use crate::common::rays::{every_nth, hard_rays, invalid_rays};
use crate::common::zoo::all_structures;
use raybatch::brute_force;
use raybatch::{Hit, Kernel, Ray};

/// Invalid rays (NaN or infinite origin or direction, zero or subnormal direction, empty or
/// NaN ranges) miss and are occluded in every path, also when mixed among valid rays.
#[test]
fn invalid_rays_miss_and_are_occluded() {
    let mesh = icosphere_with_duplicates(1);
    let invalid = invalid_rays();
    let valid = every_nth(&hard_rays(&mesh, 5), 7);
    // Alone, and interleaved with valid rays.
    let mut mixed = Vec::new();
    for (i, r) in valid.iter().enumerate() {
        mixed.push(*r);
        mixed.push(invalid[i % invalid.len()]);
    }
    let zoo = all_structures(&mesh);
    let all = all_combos(1, 0);
    for rays in [invalid.clone(), mixed] {
        for (t, tree) in zoo.iter().enumerate() {
            let expected = single_ray_answers_both(&*tree.accel, &rays);
            for combo in spread_combos(&all, t, 32) {
                ok(check_combo(tree, &rays, &expected, &combo));
                let closest = batched_closest(tree, &rays, &combo).unwrap();
                let occluded = batched_occluded(tree, &rays, &combo).unwrap();
                let hits = batched_hits(tree, &rays, &combo);
                for (i, ray) in rays.iter().enumerate() {
                    if ray.is_valid() {
                        continue;
                    }
                    let what = format!("{} {combo:?}: invalid ray {ray:?}", tree.name);
                    assert_eq!(closest[i], None, "{what}");
                    assert!(occluded[i], "{what}");
                    assert!(hits.iter().all(|(j, _)| *j != i), "{what}");
                }
            }
        }
    }
}

/// Rays that miss the structure's box are answered while the batch is prepared
/// (`Accel::cull_bounds`): mostly rays from outside, some aimed past the mesh, some through it,
/// some segments stopping short of it, among invalid rays; closest, any and every hit equal
/// the single-ray answers in every structure, with every batching combination of the spread.
#[test]
fn rays_outside_the_box_answer_as_one_ray_does() {
    let mesh = icosphere_with_duplicates(1);
    let bounds = mesh.bounds();
    let (center, extent) = (bounds.center(), bounds.extent());
    let mut rng = crate::common::rng::seeded(41);
    let invalid = invalid_rays();
    let rays: Vec<Ray> = (0..3_000)
        .map(|i| {
            if i % 50 == 0 {
                return invalid[i / 50 % invalid.len()];
            }
            let origin = center + extent * crate::common::rng::in_cube(&mut rng, 2.0);
            let target = center + extent * crate::common::rng::in_cube(&mut rng, 0.8);
            let tmax = if i % 3 == 0 { 0.4 } else { f32::INFINITY };
            Ray::with_range(origin, target - origin, 0.0, tmax)
        })
        .collect();
    let zoo = all_structures(&mesh);
    let all = all_combos(1, 0);
    for (t, tree) in zoo.iter().enumerate() {
        let expected = single_ray_answers_both(&*tree.accel, &rays);
        let misses = expected[0].closest.iter().filter(|h| h.is_none()).count();
        assert!(
            misses > 500 && misses < 2_500,
            "{}: {misses} misses",
            tree.name
        );
        for combo in spread_combos(&all, t, 8) {
            ok(check_combo(tree, &rays, &expected, &combo));
        }
    }
}

/// Checks the tie rule on `hit`: no triangle hit at the same `t` (in `brute`, the brute-force
/// hits of `ray`) has a lower id.
fn lowest_id_at_t(brute: &[Hit], ray: &Ray, hit: Option<Hit>) -> Result<(), String> {
    let Some(hit) = hit else { return Ok(()) };
    let lowest = brute
        .iter()
        .filter(|h| h.t == hit.t)
        .map(|h| h.triangle)
        .min();
    if lowest != Some(hit.triangle) {
        return Err(format!(
            "hit triangle {} at t = {}, but the triangles hit at that t (brute force) are led \
             by {lowest:?}, for {ray:?}",
            hit.triangle, hit.t
        ));
    }
    Ok(())
}

/// Exact duplicate triangles: every hit is a tie, and the lowest id wins in the single-ray
/// and the batched path, for every structure and combination.
#[test]
fn duplicate_triangles_lowest_id_wins() {
    let mesh = icosphere_all_duplicated(1);
    let rays = every_nth(&hard_rays(&mesh, 6), 3);
    let brute: Vec<Vec<Vec<Hit>>> = Kernel::ALL
        .iter()
        .map(|&k| {
            rays.iter()
                .map(|r| brute_force::all_hits(&mesh, r, k))
                .collect()
        })
        .collect();
    let zoo = all_structures(&mesh);
    let all = all_combos(1, 0);
    let mut ties = 0;
    for (t, tree) in zoo.iter().enumerate() {
        for kernel in Kernel::ALL {
            let brute = &brute[kernel_index(kernel)];
            let single: Vec<Option<Hit>> = rays
                .iter()
                .map(|r| tree.accel.cast_ray_with(r, kernel))
                .collect();
            for (i, ray) in rays.iter().enumerate() {
                let what = format!("{} {kernel:?} ray {i}", tree.name);
                ok(lowest_id_at_t(&brute[i], ray, single[i])
                    .map_err(|e| format!("{what}: single-ray: {e}")));
                ties += usize::from(brute[i].len() >= 2 && single[i].is_some());
            }
            for combo in spread_combos(&all, t, 32) {
                if combo.kernel != kernel {
                    continue;
                }
                let batched = batched_closest(tree, &rays, &combo).unwrap();
                for (i, ray) in rays.iter().enumerate() {
                    let what = format!("{} {combo:?} ray {i}", tree.name);
                    ok(lowest_id_at_t(&brute[i], ray, batched[i])
                        .map_err(|e| format!("{what}: batched: {e}")));
                }
                let expected: Vec<_> = single.iter().map(|h| opt_bits(*h)).collect();
                ok(compare_closest(
                    &format!("{} {combo:?}", tree.name),
                    &rays,
                    &batched,
                    &expected,
                ));
            }
        }
    }
    assert!(ties > 1000, "only {ties} ties");
}

/// Results do not depend on the order of the rays in the batch.
#[test]
fn ray_order_does_not_matter() {
    let mesh = icosphere_with_duplicates(2);
    let rays = every_nth(&hard_rays(&mesh, 8), 3);
    let zoo = all_structures(&mesh);
    let all = all_combos(1, 0);
    for (t, tree) in zoo.iter().enumerate() {
        for (j, combo) in spread_combos(&all, t, 4).iter().enumerate() {
            ok(check_shuffled(tree, &rays, (t * 4 + j) as u64, combo));
        }
    }
}
