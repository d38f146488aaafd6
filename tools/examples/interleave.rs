//! The 4-wide tree's two stream engines against each other and against the one-ray loop, on the
//! built-in scenes: nodes shared by the rays that reach them (`Interleave::Never`) vs rays walked
//! side by side (`Interleave::Always`), one thread, incoherent closest-hit rays, best of 4 runs.
//! Every engine's answers are checked equal. What `Interleave::Auto`'s size rule rests on.
//!
//! `cargo run --release -p raybatch-tools --example interleave [-- bunny|city|terrain [RAYS]]`

use std::time::Instant;

use raybatch::{
    BatchOptions, BatchQueries, BuildOptions, Footprint, Hit, Interleave, RayQueries, WideTree,
};
use raybatch_tools::scenes::{self, RaySet};

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "bunny".to_string());
    let scene = scenes::named(&name)
        .unwrap_or_else(|| panic!("unknown scene {name}: bunny, terrain, city or sparse"));
    let count: usize = args
        .next()
        .map_or(500_000, |n| n.parse().expect("a ray count"));
    let rays = scenes::generate(RaySet::Incoherent, &scene.mesh, scene.kind, count, 7);
    let tree = WideTree::build(scene.mesh.clone(), &BuildOptions::default()).unwrap();
    let working_set = tree.heap_bytes() + tree.mesh().heap_bytes();

    let per_ray = best_of_4(|| rays.iter().map(|r| tree.cast_ray(r)).collect());
    let batched = |interleave| {
        let options = BatchOptions::default()
            .with_parallel(false)
            .with_interleave(interleave);
        best_of_4(|| {
            let mut hits = vec![None; rays.len()];
            tree.cast_rays_with(&rays, &mut hits, &options).unwrap();
            hits
        })
    };
    let (shared, interleaved) = (batched(Interleave::Never), batched(Interleave::Always));
    assert!(shared.1 == per_ray.1 && interleaved.1 == per_ray.1);
    println!(
        "{} ({:.1} MB of nodes, leaf order and mesh), {count} incoherent rays, one thread, \
         best of 4 (ms): per ray {:.1}, batched nodes shared {:.1}, batched interleaved {:.1}",
        scene.name,
        working_set as f64 / 1e6,
        per_ray.0,
        shared.0,
        interleaved.0
    );
}

/// The fastest of 4 runs of `f` (ms), and its answers.
fn best_of_4(f: impl Fn() -> Vec<Option<Hit>>) -> (f64, Vec<Option<Hit>>) {
    let mut best = f64::MAX;
    let mut answers = Vec::new();
    for _ in 0..4 {
        let start = Instant::now();
        answers = f();
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
    }
    (best, answers)
}
