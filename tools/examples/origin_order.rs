//! What walking a batch in Morton order of the rays' origins buys the structures that walk
//! each ray alone (grid, spatial hash, kd-tree): their batched queries
//! (`BatchQueries::cast_rays`, which take each chunk's rays in that order) against the same
//! rays cast one at a time in the caller's order (what their batched queries did before).
//! One thread; the two are timed in alternation, best of `ROUNDS` each, and their answers
//! compared bit for bit.
//!
//! `cargo run --release -p raybatch-tools --example origin_order [-- terrain|bunny|city|sparse [RAYS]]`

use std::time::Instant;

use raybatch::{Accel, BatchQueries, Footprint, Hit, KdTree, Ray, RayQueries};
use raybatch::{GridOptions, SpatialHash, UniformGrid};
use raybatch_tools::scenes::{self, RaySet};

/// Timed rounds per measurement (alternating per ray and batched).
const ROUNDS: usize = 5;

fn main() {
    let mut args = std::env::args().skip(1);
    let scene = scene(args.next().as_deref().unwrap_or("terrain"));
    let count: usize = args
        .next()
        .map_or(200_000, |n| n.parse().expect("a ray count"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    println!(
        "{} ({} triangles), {count} rays per set, closest hit, one thread; Mrays/s, best of \
         {ROUNDS}: one at a time in the caller's order -> batched (origin order)\n",
        scene.name,
        scene.mesh.triangle_count()
    );
    let sets = [
        RaySet::Incoherent,
        RaySet::Short,
        RaySet::LineOfSight,
        RaySet::Camera,
    ];
    let rays: Vec<(RaySet, Vec<Ray>)> = sets
        .into_iter()
        .map(|set| {
            (
                set,
                scenes::generate(set, &scene.mesh, scene.kind, count, 7),
            )
        })
        .collect();
    let names: Vec<&str> = sets.iter().map(|s| s.name()).collect();
    println!("| structure | {} |", names.join(" | "));
    println!("|---|{}", "---|".repeat(names.len()));
    pool.install(|| {
        let mesh = &scene.mesh;
        let grid = UniformGrid::build(mesh.clone(), &GridOptions::default()).unwrap();
        row(&grid, &rays);
        let hash = SpatialHash::build(mesh.clone(), &SpatialHash::default_options()).unwrap();
        row(&hash, &rays);
        row(&KdTree::build(mesh.clone(), 4).unwrap(), &rays);
    });
}

fn scene(name: &str) -> scenes::Scene {
    scenes::named(name)
        .unwrap_or_else(|| panic!("unknown scene {name}: bunny, terrain, city or sparse"))
}

/// One table row: per ray -> batched, and the ratio, per ray set.
fn row<A: Accel + Footprint>(accel: &A, sets: &[(RaySet, Vec<Ray>)]) {
    let cells: Vec<String> = sets
        .iter()
        .map(|(_, rays)| {
            let (per_ray, batched) = measure(accel, rays);
            format!("{per_ray:.2} -> {batched:.2} ({:.2}x)", batched / per_ray)
        })
        .collect();
    println!("| {} | {} |", accel.name(), cells.join(" | "));
}

/// Mrays/s one at a time and batched (best of [`ROUNDS`] each, in alternation); panics unless
/// both give the same answers bit for bit.
fn measure<A: Accel>(accel: &A, rays: &[Ray]) -> (f64, f64) {
    let mut one_by_one = vec![None; rays.len()];
    let mut batched = vec![None; rays.len()];
    let (mut best_one, mut best_batched) = (0.0f64, 0.0f64);
    let mrays = |start: Instant| rays.len() as f64 / start.elapsed().as_secs_f64() / 1e6;
    for _ in 0..ROUNDS {
        let start = Instant::now();
        for (hit, ray) in one_by_one.iter_mut().zip(rays) {
            *hit = accel.cast_ray(ray);
        }
        best_one = best_one.max(mrays(start));
        let start = Instant::now();
        accel.cast_rays(rays, &mut batched).unwrap();
        best_batched = best_batched.max(mrays(start));
    }
    let bits = |h: &Option<Hit>| h.map(|h| (h.triangle, h.t.to_bits(), h.u.to_bits()));
    for (i, (a, b)) in one_by_one.iter().zip(&batched).enumerate() {
        assert_eq!(bits(a), bits(b), "ray {i}");
    }
    (best_one, best_batched)
}
