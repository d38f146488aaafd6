//! The wide trees (4-wide, 8-wide, quantized 4-wide, quantized 8-wide), per ray and batched (all rays in one
//! call, one thread), alternated within one process, best of `ROUNDS` each: closest hit on
//! incoherent rays and any hit on line-of-sight segments. Every variant's answers are checked
//! equal to the 4-wide tree's per-ray answers. Ratios of runs made side by side hold on a
//! noisy machine where separate runs drift.
//!
//! `cargo run --release -p raybatch-tools --example wide_widths [-- SCENE|FILE.obj [RAYS
//! [ROUNDS]]]`

use std::time::Instant;

use raybatch::{
    BatchOptions, BatchQueries, BuildOptions, Footprint, Hit, QuantizedWideTree,
    QuantizedWideTree8, Ray, RayQueries, WideTree, WideTree8,
};
use raybatch_tools::scenes::{self, RaySet};

/// The trees compared.
const TREES: usize = 4;

/// A tree's closest-hit and any-hit answers, per ray or batched (object-safe, so the trees
/// can sit in one array).
trait Answers: Sync {
    fn label(&self) -> &'static str;
    fn bytes(&self) -> usize;
    fn closest_hits(&self, batched: bool, rays: &[Ray]) -> Vec<Option<(u32, u32)>>;
    fn occlusion(&self, batched: bool, segments: &[Ray]) -> Vec<bool>;
}

impl<T: BatchQueries + RayQueries + Footprint + Sync> Answers for T {
    fn label(&self) -> &'static str {
        self.name()
    }

    fn bytes(&self) -> usize {
        self.heap_bytes()
    }

    /// Closest hits, as bits (so that equal means bit-identical).
    fn closest_hits(&self, batched: bool, rays: &[Ray]) -> Vec<Option<(u32, u32)>> {
        let mut hits: Vec<Option<Hit>> = vec![None; rays.len()];
        if batched {
            self.cast_rays_with(rays, &mut hits, &BatchOptions::default())
                .unwrap();
        } else {
            hits.iter_mut()
                .zip(rays)
                .for_each(|(h, r)| *h = self.cast_ray(r));
        }
        hits.iter()
            .map(|h| h.map(|h| (h.triangle, h.t.to_bits())))
            .collect()
    }

    fn occlusion(&self, batched: bool, segments: &[Ray]) -> Vec<bool> {
        let mut occluded = vec![false; segments.len()];
        if batched {
            self.occluded_batch(segments, &mut occluded).unwrap();
        } else {
            occluded
                .iter_mut()
                .zip(segments)
                .for_each(|(o, s)| *o = self.occluded(s));
        }
        occluded
    }
}

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
        let mesh = &scene.mesh;
        let trees: [Box<dyn Answers>; TREES] = [
            Box::new(WideTree::build(mesh.clone(), &options).unwrap()),
            Box::new(WideTree8::build(mesh.clone(), &options).unwrap()),
            Box::new(QuantizedWideTree::build(mesh.clone(), &options).unwrap()),
            Box::new(QuantizedWideTree8::build(mesh.clone(), &options).unwrap()),
        ];
        for tree in &trees {
            let per_triangle = tree.bytes() as f64 / mesh.triangle_count() as f64;
            println!("{}: {per_triangle:.1} bytes per triangle", tree.label());
        }
        let rays = |set| scenes::generate(set, mesh, scene.kind, count, 7);
        let closest = rays(RaySet::Incoherent);
        let times = race(rounds, |v| trees[v / 2].closest_hits(v % 2 == 1, &closest));
        let query = (scene.name, "closest hit, incoherent");
        report(&trees, query, (count, rounds), &times);
        let segments = rays(RaySet::LineOfSight);
        let times = race(rounds, |v| trees[v / 2].occlusion(v % 2 == 1, &segments));
        let query = (scene.name, "any hit, line of sight");
        report(&trees, query, (count, rounds), &times);
    });
}

/// Runs every variant (tree `v / 2`, batched if `v` is odd) `rounds` times in turn; returns
/// each one's best time in ms. Panics if a variant's answers differ from the first's.
fn race<T: PartialEq>(rounds: usize, mut run: impl FnMut(usize) -> T) -> [f64; 2 * TREES] {
    let mut best = [f64::INFINITY; 2 * TREES];
    let mut reference = None;
    for _ in 0..rounds {
        for (v, best) in best.iter_mut().enumerate() {
            let start = Instant::now();
            let answers = run(v);
            *best = best.min(start.elapsed().as_secs_f64() * 1e3);
            match &reference {
                None => reference = Some(answers),
                Some(first) => assert!(*first == answers, "variant {v}: answers differ"),
            }
        }
    }
    best
}

/// One line per variant: best time and speed relative to the 4-wide tree's per-ray and
/// batched times.
fn report(
    trees: &[Box<dyn Answers>; TREES],
    (scene, query): (&str, &str),
    (count, rounds): (usize, usize),
    times: &[f64; 2 * TREES],
) {
    println!("{scene}, {query}, {count} rays, one thread, best of {rounds}:");
    for (v, ms) in times.iter().enumerate() {
        let how = if v % 2 == 1 { "batched" } else { "per ray" };
        println!(
            "  {:<5} {how:<7} {ms:8.1} ms  speed vs bvh4 per ray {:.2}, vs bvh4 batched {:.2}",
            trees[v / 2].label(),
            times[0] / ms,
            times[1] / ms,
        );
    }
}
