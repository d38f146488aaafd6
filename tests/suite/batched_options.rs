//! The batched queries against the single-ray reference, bit for bit, across the option space.
//!
//! The contract of the batched queries: for every structure of the zoo, kernel, batch ordering,
//! partition kernel, `single_ray_below`, chunking and thread count, `cast_ray_batch_with` returns
//! exactly `cast_ray_with` for every ray (triangle, `t`, `u`, `v` bits), `occluded_batch_with`
//! exactly `occluded_with`, and `for_each_hit_batch_with` the same multiset of
//! `(ray index, hit)` as `for_each_hit_with` on every ray, whatever the batch size; output
//! slices of the wrong length are an error, not a panic. (Invalid rays, ties and ray order:
//! `batched_rays.rs`; large batches: `batched_large.rs`; random meshes: `batched_proptest.rs`.)

use std::sync::Mutex;

use crate::common::batch::{
    Combo, GARBAGE, THREADS, all_combos, check_zoo, compare_closest, compare_hits,
    compare_occluded, ok, pool, single_ray_answers, spread_combos,
};
use crate::common::meshes::{icosphere, icosphere_all_duplicated, icosphere_with_duplicates};
use crate::common::oracles::bits;
use crate::common::rays::{every_nth, hard_rays};
use crate::common::tier::Tier;
use crate::common::zoo::all_structures;
use raybatch::{BatchError, BatchOrdering, Interleave, Kernel, PartitionKernel, Ray};

/// Every structure with the 2304 combinations of kernel, batch ordering, partition kernel,
/// `single_ray_below`, `max_chunk`, threads and interleaving, on a sample of the hard rays of
/// an icosphere with duplicate triangles: all of them for every structure in the full tier; in
/// the sample, 24 per structure, which together cover every combination at least once.
fn option_combinations(tier: Tier) {
    let mesh = icosphere_with_duplicates(1);
    let rays = every_nth(&hard_rays(&mesh, 1), 11);
    assert!(rays.len() > 120, "{}", rays.len());
    let zoo = all_structures(&mesh);
    let combos = all_combos(1, 0);
    match tier {
        Tier::Sample => {
            assert!(zoo.len() * 24 >= combos.len());
            ok(check_zoo(&zoo, &rays, |t| spread_combos(&combos, t, 24)))
        }
        Tier::Full => ok(check_zoo(&zoo, &rays, |_| combos.clone())),
    }
}

#[test]
fn option_combinations_sample() {
    option_combinations(Tier::Sample);
}

#[test]
#[ignore = "heavy: every structure x every option combination (the full tier)"]
fn every_option_combination_on_every_tree() {
    option_combinations(Tier::Full);
}

/// All the hard rays (aimed at every vertex and edge, axis-parallel with signed zeros, windows,
/// segments, invalid rays) on a plain icosphere and two with duplicate triangles, every
/// structure: six of the 2304 combinations per structure (two in the sample; different ones
/// for each structure), plus one with the default `min_chunk` (4096) and `min_batch` (32).
fn hard_rays_on_icospheres(tier: Tier) {
    for (name, mesh) in [
        ("icosphere", icosphere(1)),
        ("icosphere+dups", icosphere_with_duplicates(2)),
        ("icosphere all duplicated", icosphere_all_duplicated(1)),
    ] {
        let rays = hard_rays(&mesh, 2);
        let zoo = all_structures(&mesh);
        let all = all_combos(1, 0);
        let defaults = all_combos(4096, 32);
        ok(check_zoo(&zoo, &rays, |t| {
            let mut c = spread_combos(&all, t, tier.pick(2, 6));
            c.extend(spread_combos(&defaults, t + 5, 1));
            c
        })
        .map_err(|e| format!("{name}: {e}")));
    }
}

#[test]
fn hard_rays_on_icospheres_sample() {
    hard_rays_on_icospheres(Tier::Sample);
}

#[test]
#[ignore = "heavy: six option combinations per structure (the full tier)"]
fn hard_rays_on_icospheres_full() {
    hard_rays_on_icospheres(Tier::Full);
}

/// The default-option entry points (`cast_ray_batch`, `occluded_batch`, `for_each_hit_batch`) in the
/// global pool and inside pools of 1, 2 and 3 threads.
#[test]
fn default_entry_points_match_single_ray() {
    let mesh = icosphere_with_duplicates(2);
    let rays = hard_rays(&mesh, 3);
    for tree in all_structures(&mesh) {
        let exp = single_ray_answers(&*tree.accel, &rays, Kernel::Watertight);
        for threads in [None, Some(1), Some(2), Some(3)] {
            let what = format!("{} default options, pool {threads:?}", tree.name);
            let run = || {
                let mut hits = vec![Some(GARBAGE); rays.len()];
                tree.accel.cast_ray_batch(&rays, &mut hits).unwrap();
                let mut occ: Vec<bool> = (0..rays.len()).map(|i| i % 3 == 0).collect();
                tree.accel.occluded_batch(&rays, &mut occ).unwrap();
                let sink = Mutex::new(Vec::new());
                let defaults = raybatch::BatchOptions::default();
                tree.accel
                    .for_each_hit_batch_with(&rays, &defaults, &|i, h| {
                        sink.lock().unwrap().push((i, bits(&h)))
                    });
                let mut all = sink.into_inner().unwrap();
                all.sort_unstable();
                (hits, occ, all)
            };
            let (hits, occ, all) = match threads {
                None => run(),
                Some(n) => pool(n).install(run),
            };
            ok(compare_closest(&what, &rays, &hits, &exp.closest));
            ok(compare_occluded(&what, &rays, &occ, &exp.occluded));
            ok(compare_hits(&what, &rays, &all, &exp.hits));
        }
    }
}

/// Batches of 0, 1, 2, 7, 64 and 1000 rays taken from the hard rays, every structure, each size
/// with both small-batch paths (`min_batch` 0: batched engine; 32: single-ray fallback).
#[test]
fn batch_sizes() {
    let mesh = icosphere_with_duplicates(1);
    let pool_rays = hard_rays(&mesh, 4);
    let zoo = all_structures(&mesh);
    let all = all_combos(1, 0);
    for (s, size) in [0usize, 1, 2, 7, 64, 1000].into_iter().enumerate() {
        let rays: Vec<Ray> = pool_rays
            .iter()
            .cycle()
            .skip(s * 97)
            .take(size)
            .copied()
            .collect();
        ok(check_zoo(&zoo, &rays, |t| {
            let mut c = spread_combos(&all, t + 3 * s, 4);
            c.push(Combo {
                min_batch: 32,
                ..c[0]
            });
            c
        })
        .map_err(|e| format!("batch of {size}: {e}")));
    }
}

/// Output slices of the wrong length are an error, never a panic, whatever the path.
#[test]
fn length_mismatch_is_an_error() {
    let mesh = icosphere_with_duplicates(1);
    let all_rays = hard_rays(&mesh, 7);
    let zoo = all_structures(&mesh);
    let mut combos = Vec::new();
    for threads in THREADS {
        for min_batch in [0, 32] {
            combos.push(Combo {
                kernel: Kernel::Watertight,
                ordering: BatchOrdering::ByOctant,
                partition: PartitionKernel::detect(),
                single_ray_below: 8,
                max_chunk: 7,
                min_chunk: 1,
                min_batch,
                threads,
                interleave: Interleave::Auto,
            });
        }
    }
    for tree in zoo.iter().step_by(5) {
        for n in [0usize, 1, 5, 100, 1000] {
            let rays = &all_rays[..n];
            for outputs in [0, 1, n.saturating_sub(1), n + 1, 2 * n + 3] {
                if outputs == n {
                    continue;
                }
                let expected = Err(BatchError::LengthMismatch { rays: n, outputs });
                for combo in &combos {
                    let options = combo.options();
                    let what = format!("{} {combo:?}: {n} rays, {outputs} outputs", tree.name);
                    let mut hits = vec![None; outputs];
                    let got =
                        combo.run(|| tree.accel.cast_ray_batch_with(rays, &mut hits, &options));
                    assert_eq!(got, expected, "cast_ray_batch_with {what}");
                    let mut occ = vec![false; outputs];
                    let got =
                        combo.run(|| tree.accel.occluded_batch_with(rays, &mut occ, &options));
                    assert_eq!(got, expected, "occluded_batch_with {what}");
                }
                let mut hits = vec![None; outputs];
                let got = tree.accel.cast_ray_batch(rays, &mut hits);
                assert_eq!(got, expected, "cast_ray_batch {}", tree.name);
                let mut occ = vec![false; outputs];
                let got = tree.accel.occluded_batch(rays, &mut occ);
                assert_eq!(got, expected, "occluded_batch {}", tree.name);
                assert!(!format!("{}", got.unwrap_err()).is_empty());
            }
        }
    }
}
