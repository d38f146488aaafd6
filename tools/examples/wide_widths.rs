//! The 4-wide and the 8-wide tree, per ray and batched (all rays in one call, one thread),
//! alternated within one process, best of `ROUNDS` each: closest hit on incoherent rays and
//! any hit on line-of-sight segments. Every variant's answers are checked equal to the 4-wide
//! tree's per-ray answers. Ratios of two runs made side by side hold on a noisy machine where
//! separate runs drift.
//!
//! `cargo run --release -p raybatch-tools --example wide_widths [-- SCENE|FILE.obj [RAYS
//! [ROUNDS]]]`

use std::time::Instant;

use raybatch::{
    BatchOptions, BatchQueries, BuildOptions, Hit, Ray, RayQueries, WideTree, WideTree8,
};
use raybatch_tools::scenes::{self, RaySet};

/// The four ways of answering a query, in the order they are timed and printed.
const VARIANTS: [&str; 4] = [
    "bvh4 per ray",
    "bvh8 per ray",
    "bvh4 batched",
    "bvh8 batched",
];

fn main() {
    let mut args = std::env::args().skip(1);
    let scene = scenes::from_arg(args.next().as_deref());
    let count: usize = args
        .next()
        .map_or(1_000_000, |n| n.parse().expect("a count"));
    let rounds: usize = args.next().map_or(5, |n| n.parse().expect("a count"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| {
        let options = BuildOptions::default();
        let trees = (
            WideTree::build(scene.mesh.clone(), &options).unwrap(),
            WideTree8::build(scene.mesh.clone(), &options).unwrap(),
        );
        let closest = scenes::generate(RaySet::Incoherent, &scene.mesh, scene.kind, count, 7);
        let times = race(rounds, |v| closest_hits(&trees, v, &closest));
        report(scene.name, "closest hit, incoherent", count, rounds, &times);
        let segments = scenes::generate(RaySet::LineOfSight, &scene.mesh, scene.kind, count, 7);
        let times = race(rounds, |v| occlusion(&trees, v, &segments));
        report(scene.name, "any hit, line of sight", count, rounds, &times);
    });
}

/// Runs every variant `rounds` times in turn; returns each one's best time in ms. Panics if a
/// variant's answers differ from the first's.
fn race<T: PartialEq>(rounds: usize, mut run: impl FnMut(usize) -> T) -> [f64; 4] {
    let mut best = [f64::INFINITY; 4];
    let mut reference = None;
    for _ in 0..rounds {
        for (v, best) in best.iter_mut().enumerate() {
            let start = Instant::now();
            let answers = run(v);
            *best = best.min(start.elapsed().as_secs_f64() * 1e3);
            match &reference {
                None => reference = Some(answers),
                Some(first) => assert!(*first == answers, "{} answers differ", VARIANTS[v]),
            }
        }
    }
    best
}

/// Closest hits of `rays` through variant `v`, as bits (so that equal means bit-identical).
fn closest_hits(
    (bvh4, bvh8): &(WideTree, WideTree8),
    v: usize,
    rays: &[Ray],
) -> Vec<Option<(u32, u32)>> {
    let mut hits: Vec<Option<Hit>> = vec![None; rays.len()];
    let options = BatchOptions::default();
    match v {
        0 => hits
            .iter_mut()
            .zip(rays)
            .for_each(|(h, r)| *h = bvh4.cast_ray(r)),
        1 => hits
            .iter_mut()
            .zip(rays)
            .for_each(|(h, r)| *h = bvh8.cast_ray(r)),
        2 => bvh4.cast_rays_with(rays, &mut hits, &options).unwrap(),
        _ => bvh8.cast_rays_with(rays, &mut hits, &options).unwrap(),
    }
    hits.iter()
        .map(|h| h.map(|h| (h.triangle, h.t.to_bits())))
        .collect()
}

/// Occlusion of `segments` through variant `v`.
fn occlusion((bvh4, bvh8): &(WideTree, WideTree8), v: usize, segments: &[Ray]) -> Vec<bool> {
    let mut occluded = vec![false; segments.len()];
    match v {
        0 => occluded
            .iter_mut()
            .zip(segments)
            .for_each(|(o, s)| *o = bvh4.occluded(s)),
        1 => occluded
            .iter_mut()
            .zip(segments)
            .for_each(|(o, s)| *o = bvh8.occluded(s)),
        2 => bvh4.occluded_batch(segments, &mut occluded).unwrap(),
        _ => bvh8.occluded_batch(segments, &mut occluded).unwrap(),
    }
    occluded
}

/// One line per variant: best time and speed relative to the 4-wide tree's per-ray and
/// batched times.
fn report(scene: &str, query: &str, count: usize, rounds: usize, times: &[f64; 4]) {
    println!("{scene}, {query}, {count} rays, one thread, best of {rounds}:");
    for (name, ms) in VARIANTS.iter().zip(times) {
        println!(
            "  {name:<13} {ms:8.1} ms  speed vs bvh4 per ray {:.2}, vs bvh4 batched {:.2}",
            times[0] / ms,
            times[2] / ms,
        );
    }
}
