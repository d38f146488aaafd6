//! Moving instances: what keeping the top-level tree current costs per frame, refit or rebuild,
//! and what each leaves for the queries.
//!
//! 10,000 crates (the `props` world) over a 1 km square all move every frame (a random walk
//! and a turn). Per frame: `set_transforms` (new boxes, one bottom-up refit of the top level)
//! and, in a second scene, the same plus `rebuild_top` (binned SAH). After the frames, the
//! same 200,000 rays (batched, closest hit) are cast at both, to show how much a tree that was
//! only refitted has degraded. Also: 100 instances (1%) moved one by one with `set_transform`
//! (a refit of each path to the root).
//!
//! Run: `cargo run --release -p raybatch-tools --example scene_motion [instances] [frames]`

use std::time::Instant;

use raybatch::BatchQueries;
use raybatch::glam::Vec3;
use raybatch::scene::{Rigid, Scene};
use raybatch::{AccelKind, Hit};
use raybatch_tools::scenes::instanced::{WorldRays, props, world_rays, yawed};
use raybatch_tools::scenes::rng::SplitMix64;

fn main() {
    let mut args = std::env::args()
        .skip(1)
        .map(|a| a.parse::<usize>().expect("a number"));
    let count = args.next().unwrap_or(10_000);
    let frames = args.next().unwrap_or(100);
    let world = props(count, 1000.0, 7);
    let mut refitted = world.build(AccelKind::Aabb).expect("scene");
    let mut rebuilt = world.build(AccelKind::Aabb).expect("scene");
    let mut rng = SplitMix64::new(8);
    let mut poses: Vec<(f32, Vec3)> = (0..count)
        .map(|i| {
            (
                rng.range_f32(0.0, std::f32::consts::TAU),
                refitted.instances()[i].transform().translation(),
            )
        })
        .collect();
    let (mut refit_time, mut rebuild_time) = (0.0, 0.0);
    for _ in 0..frames {
        let moves = step(&mut poses, &mut rng);
        let t = Instant::now();
        refitted.set_transforms(&moves).expect("valid moves");
        refit_time += t.elapsed().as_secs_f64();
        let t = Instant::now();
        rebuilt.set_transforms(&moves).expect("valid moves");
        rebuilt.rebuild_top();
        rebuild_time += t.elapsed().as_secs_f64();
    }
    let per_frame = |s: f64| s / frames as f64 * 1e3;
    println!("{count} instances moving, {frames} frames:");
    println!(
        "  set_transforms + refit          {:8.3} ms/frame",
        per_frame(refit_time)
    );
    println!(
        "  set_transforms + rebuild_top    {:8.3} ms/frame",
        per_frame(rebuild_time)
    );

    let rays = world_rays(WorldRays::Long, &world.bounds(), 200_000, 9);
    let q_refit = query_time(&refitted, &rays);
    let q_rebuilt = query_time(&rebuilt, &rays);
    println!(
        "  200k long rays after the frames: refitted tree {q_refit:.1} ms, rebuilt tree {q_rebuilt:.1} ms"
    );

    let t = Instant::now();
    let few = count / 100;
    for _ in 0..frames {
        for i in 0..few {
            let (yaw, at) = &mut poses[i * 100];
            *yaw += 0.05;
            *at += Vec3::new(0.3, 0.0, 0.1);
            refitted
                .set_transform(i * 100, yawed(*yaw, *at))
                .expect("valid move");
        }
    }
    println!(
        "  {few} instances (1%) moved one by one (set_transform, path refit): {:.3} ms/frame",
        per_frame(t.elapsed().as_secs_f64())
    );
}

/// One frame of motion for every instance: a step of up to 1 unit and a small turn.
fn step(poses: &mut [(f32, Vec3)], rng: &mut SplitMix64) -> Vec<(usize, Rigid)> {
    poses
        .iter_mut()
        .enumerate()
        .map(|(i, (yaw, at))| {
            *yaw += rng.range_f32(-0.1, 0.1);
            *at += Vec3::new(rng.range_f32(-1.0, 1.0), 0.0, rng.range_f32(-1.0, 1.0));
            (i, yawed(*yaw, *at))
        })
        .collect()
}

/// Milliseconds to cast `rays` batched (best of 3).
fn query_time(scene: &Scene, rays: &[raybatch::Ray]) -> f64 {
    let mut hits: Vec<Option<Hit>> = vec![None; rays.len()];
    (0..3)
        .map(|_| {
            let t = Instant::now();
            scene.cast_rays(rays, &mut hits).expect("lengths match");
            t.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}
