//! Moving instances: what keeping the top-level tree current costs per frame, refit or rebuild,
//! and what each leaves for the queries.
//!
//! 10,000 crates over a 1 km square all move every frame (a random walk
//! and a turn). Per frame: `set_transforms` (new boxes, one bottom-up refit of the top level)
//! and, in a second scene, the same plus `rebuild_top` (binned SAH). After the frames, the
//! same 200,000 rays (batched, closest hit) are cast at both, to show how much a tree that was
//! only refitted has degraded. Also: 100 instances (1%) moved one by one with `set_transform`
//! (a refit of each path to the root), and crates spawned (`add_instances`: each inserted
//! down one path) and destroyed (`remove_instance`: one path refitted) during play.
//!
//! Run: `cargo run --release --example scene_motion [instances] [frames]`

#[path = "support/town.rs"]
mod town;

use std::time::Instant;

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use raybatch::glam::Vec3;
use raybatch::scene::{InstanceDesc, Rigid, Scene};
use raybatch::{AccelKind, BatchQueries, BuildOptions, Hit, Ray};
use town::{box_mesh, yawed};

/// Side of the square the crates stand on, in metres.
const SIDE: f32 = 1000.0;

fn main() {
    let mut args = std::env::args()
        .skip(1)
        .map(|a| a.parse::<usize>().expect("a number"));
    let count = args.next().unwrap_or(10_000);
    let frames = args.next().unwrap_or(100);
    let mut rng = StdRng::seed_from_u64(8);
    let mut poses: Vec<(f32, Vec3)> = (0..count)
        .map(|_| {
            let at = Vec3::new(
                rng.random_range(0.0..SIDE),
                0.0,
                rng.random_range(0.0..SIDE),
            );
            (rng.random_range(0.0..std::f32::consts::TAU), at)
        })
        .collect();
    let mut refitted = crates(&poses);
    let mut rebuilt = crates(&poses);
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

    let rays = long_rays(200_000, &mut rng);
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

    // Spawning and destroying: 10 crates a frame each way.
    let (mut spawn_time, mut destroy_time) = (0.0, 0.0);
    for frame in 0..frames {
        let spawned: Vec<InstanceDesc> = (0..10)
            .map(|k| {
                let at = Vec3::new(frame as f32 * 3.0, 0.0, k as f32 * 3.0);
                InstanceDesc::new(0, yawed(0.0, at))
            })
            .collect();
        let t = Instant::now();
        refitted
            .add_instances(&spawned)
            .expect("a crate mesh exists");
        spawn_time += t.elapsed().as_secs_f64();
        let t = Instant::now();
        for i in 0..10 {
            refitted.remove_instance(frame * 10 + i).expect("live");
        }
        destroy_time += t.elapsed().as_secs_f64();
    }
    println!(
        "  10 crates spawned a frame (add_instances, inserted): {:.3} ms/frame; \
         10 destroyed (remove_instance): {:.3} ms/frame",
        per_frame(spawn_time),
        per_frame(destroy_time)
    );
}

/// A scene of one crate mesh placed at every pose.
fn crates(poses: &[(f32, Vec3)]) -> Scene {
    let mesh = box_mesh(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    let tree = AccelKind::for_mesh(&mesh)
        .build(mesh, &BuildOptions::default())
        .expect("a crate builds");
    let instances: Vec<InstanceDesc> = poses
        .iter()
        .map(|&(yaw, at)| InstanceDesc::new(0, yawed(yaw, at)))
        .collect();
    Scene::new(vec![tree], &instances).expect("one mesh, placed")
}

/// Rays across the square, low over the ground, from one side to a random point.
fn long_rays(count: usize, rng: &mut StdRng) -> Vec<Ray> {
    (0..count)
        .map(|_| {
            let from = Vec3::new(rng.random_range(0.0..SIDE), 1.0, 0.0);
            let to = Vec3::new(rng.random_range(0.0..SIDE), 0.5, SIDE);
            Ray::new(from, to - from)
        })
        .collect()
}

/// One frame of motion for every instance: a step of up to 1 unit and a small turn.
fn step(poses: &mut [(f32, Vec3)], rng: &mut StdRng) -> Vec<(usize, Rigid)> {
    poses
        .iter_mut()
        .enumerate()
        .map(|(i, (yaw, at))| {
            *yaw += rng.random_range(-0.1..0.1);
            *at += Vec3::new(
                rng.random_range(-1.0..1.0),
                0.0,
                rng.random_range(-1.0..1.0),
            );
            (i, yawed(*yaw, *at))
        })
        .collect()
}

/// Milliseconds to cast `rays` batched (best of 3).
fn query_time(scene: &Scene, rays: &[Ray]) -> f64 {
    let mut hits: Vec<Option<Hit>> = vec![None; rays.len()];
    (0..3)
        .map(|_| {
            let t = Instant::now();
            scene
                .cast_ray_batch(rays, &mut hits)
                .expect("lengths match");
            t.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}
