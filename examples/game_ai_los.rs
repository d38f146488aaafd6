//! Game AI line of sight: 1,000 agents in a town each check 32 targets per frame, for 100
//! frames, while 500 vehicles move. Three ways to answer a frame's 32,000 sightlines:
//!
//! - per ray: `scene.occluded(&segment)` for each, spread over rayon's threads;
//! - batched: one `scene.occluded_batch(&segments, &mut out)`;
//! - queue: two "AI system" threads submit their halves to a `LosQueue` (lock-free, tickets),
//!   one `flush` answers them as a batch, answers are read by ticket; once request by request
//!   (`submit`), once each system's list at once (`submit_all`).
//!
//! Then the same sightlines with a filter each (`RayFilter`): every agent rides a vehicle,
//! and its sightlines pass through that vehicle (`ignoring`), answered as one batch
//! (`scene.filtered_batch(&filters)`) and checked against `scene.filtered(filter)` per ray.
//!
//! Every frame checks that the three agree on every sightline. The town (`support/town.rs`)
//! is 16 x 16 blocks of box buildings, one mesh per block, plus 500 crates as vehicles
//! (rotated instances that move every frame: `set_transforms`, a refit of the top level).
//!
//! Run: `cargo run --release --example game_ai_los [agents] [frames]`
//! (`RAYON_NUM_THREADS=1` for one thread).

#[path = "support/town.rs"]
mod town;

use std::time::Instant;

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use raybatch::glam::Vec3;
use raybatch::scene::{RayFilter, Rigid, Scene};
use raybatch::users::{LosQueue, Ticket};
use raybatch::{BatchQueries, Ray, RayQueries};
use rayon::prelude::*;
use town::{Town, yawed};

/// Targets each agent checks per frame.
const TARGETS: usize = 32;
/// Moving vehicles.
const VEHICLES: usize = 500;

fn main() {
    let mut args = std::env::args()
        .skip(1)
        .map(|a| a.parse::<usize>().expect("a number"));
    let agents = args.next().unwrap_or(1000).max(2);
    let frames = args.next().unwrap_or(100);
    let town = Town::new(16, VEHICLES, 11);
    let first_vehicle = town.first_vehicle;
    let mut scene = build_scene(&town);
    println!(
        "town: {} instances ({} static blocks, {VEHICLES} vehicles), {} triangles",
        scene.instances().len(),
        first_vehicle,
        scene.triangle_count()
    );

    // Agents stand in the streets, at eye height.
    let mut rng = StdRng::seed_from_u64(12);
    let mut positions: Vec<Vec3> = (0..agents).map(|_| town.street_point(&mut rng)).collect();
    let mut vehicles: Vec<(f32, Vec3)> = scene.instances()[first_vehicle..]
        .iter()
        .map(|i| (0.0, i.transform().translation()))
        .collect();
    let requests = agents * TARGETS;
    let queue = LosQueue::with_capacity(requests).expect("a frame's sightlines fit a queue");
    let mut segments = Vec::with_capacity(requests);
    let (mut per_ray, mut batched, mut queued) = (
        vec![false; requests],
        vec![false; requests],
        vec![false; requests],
    );
    let mut tickets: [Vec<Ticket>; 2] =
        [Vec::with_capacity(requests), Vec::with_capacity(requests)];
    let (mut t_ray, mut t_batch, mut t_queue, mut t_lists, mut t_filtered, mut blocked) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0usize);
    let mut t_submit = 0.0;
    let mut listed = vec![false; requests];
    // Agent `i` rides vehicle `i % VEHICLES`: its sightlines pass through it.
    let filters: Vec<RayFilter> = (0..requests)
        .map(|k| RayFilter::ALL.ignoring((first_vehicle + (k / TARGETS) % VEHICLES) as u32))
        .collect();
    let (mut filtered, mut filtered_per_ray) = (vec![false; requests], vec![false; requests]);
    for _ in 0..frames {
        move_world(
            &mut scene,
            &mut positions,
            &mut vehicles,
            first_vehicle,
            &mut rng,
        );
        segments.clear();
        segments.extend((0..requests).map(|k| {
            let (i, j) = (k / TARGETS, k % TARGETS);
            // Another agent, never the same one (a sightline of length zero is invalid).
            let target = (i + 1 + (j * 37) % (agents - 1)) % agents;
            Ray::segment(positions[i], positions[target])
        }));

        let t = Instant::now();
        per_ray
            .par_iter_mut()
            .zip(&segments)
            .for_each(|(out, ray)| *out = scene.occluded(ray));
        t_ray += t.elapsed().as_secs_f64();

        let t = Instant::now();
        scene
            .occluded_batch(&segments, &mut batched)
            .expect("lengths match");
        t_batch += t.elapsed().as_secs_f64();

        let t = Instant::now();
        submit_from_two_threads(&queue, &segments, &mut tickets);
        t_submit += t.elapsed().as_secs_f64();
        queue.flush(&scene).expect("one flush at a time");
        for (half, list) in tickets.iter().enumerate() {
            let offset = half * segments.len().div_ceil(2);
            for (k, &ticket) in list.iter().enumerate() {
                queued[offset + k] = queue.occluded(ticket).expect("answered this frame");
            }
        }
        t_queue += t.elapsed().as_secs_f64();

        let t = Instant::now();
        let firsts = submit_lists_from_two_threads(&queue, &segments);
        queue.flush(&scene).expect("one flush at a time");
        let half = segments.len().div_ceil(2);
        for (k, out) in listed.iter_mut().enumerate() {
            let ticket = firsts[k / half].offset(k % half);
            *out = queue.occluded(ticket).expect("answered this frame");
        }
        t_lists += t.elapsed().as_secs_f64();

        let t = Instant::now();
        scene
            .filtered_batch(&filters)
            .occluded_batch(&segments, &mut filtered)
            .expect("lengths match");
        t_filtered += t.elapsed().as_secs_f64();
        filtered_per_ray
            .par_iter_mut()
            .zip(segments.par_iter().zip(&filters))
            .for_each(|(out, (ray, filter))| *out = scene.filtered(*filter).occluded(ray));

        assert_eq!(filtered, filtered_per_ray, "filtered answers differ");
        assert_eq!(per_ray, batched, "per-ray and batched answers differ");
        assert_eq!(batched, queued, "batched and queued answers differ");
        assert_eq!(batched, listed, "batched and listed answers differ");
        blocked += batched.iter().filter(|&&b| b).count();
    }
    let ms = |s: f64| s / frames as f64 * 1e3;
    let rate = |s: f64| (requests * frames) as f64 / s / 1e6;
    println!(
        "{agents} agents x {TARGETS} targets = {requests} sightlines/frame, {frames} frames, {:.0}% blocked, {} threads",
        100.0 * blocked as f64 / (requests * frames) as f64,
        rayon::current_num_threads()
    );
    println!(
        "  per ray  {:7.2} ms/frame  {:6.2} M/s",
        ms(t_ray),
        rate(t_ray)
    );
    println!(
        "  batched  {:7.2} ms/frame  {:6.2} M/s  ({:.2}x per ray)",
        ms(t_batch),
        rate(t_batch),
        t_ray / t_batch
    );
    println!(
        "  queue    {:7.2} ms/frame  {:6.2} M/s  ({:.2}x batched)  submit: one per request ({:.2} ms of it submitting)",
        ms(t_queue),
        rate(t_queue),
        t_batch / t_queue,
        ms(t_submit)
    );
    println!(
        "  queue    {:7.2} ms/frame  {:6.2} M/s  ({:.2}x batched)  submit_all: one per system",
        ms(t_lists),
        rate(t_lists),
        t_batch / t_lists
    );
    println!(
        "  filtered {:7.2} ms/frame  {:6.2} M/s  ({:.2}x batched)  a filter per sightline",
        ms(t_filtered),
        rate(t_filtered),
        t_batch / t_filtered
    );
    println!("  all four gave the same answer on every sightline of every frame, and the");
    println!("  filtered batch the per-ray answer through each sightline's filter");
}

/// Every mesh with the tree the scene picks for it.
fn build_scene(town: &Town) -> Scene {
    Scene::from_meshes(town.meshes.clone(), &town.instances).expect("the town builds")
}

/// One frame of motion: agents shuffle, vehicles drive and turn (one refit of the top level).
fn move_world(
    scene: &mut Scene,
    agents: &mut [Vec3],
    vehicles: &mut [(f32, Vec3)],
    first_vehicle: usize,
    rng: &mut StdRng,
) {
    for p in agents.iter_mut() {
        *p += Vec3::new(
            rng.random_range(-0.3..0.3),
            0.0,
            rng.random_range(-0.3..0.3),
        );
    }
    let moves: Vec<(usize, Rigid)> = vehicles
        .iter_mut()
        .enumerate()
        .map(|(k, (yaw, at))| {
            *yaw += rng.random_range(-0.05..0.05);
            *at += Vec3::new(yaw.cos(), 0.0, yaw.sin()) * 0.5;
            (first_vehicle + k, yawed(*yaw, *at))
        })
        .collect();
    scene.set_transforms(&moves).expect("vehicles exist");
}

/// Two threads each submit their half of the segments as one list; returns the two first
/// tickets.
fn submit_lists_from_two_threads(queue: &LosQueue, segments: &[Ray]) -> [Ticket; 2] {
    let half = segments.len().div_ceil(2);
    let (a, b) = segments.split_at(half);
    std::thread::scope(|s| {
        let first = s.spawn(|| queue.submit_all(a).expect("capacity"));
        let second = s.spawn(|| queue.submit_all(b).expect("capacity"));
        [
            first.join().expect("no panic"),
            second.join().expect("no panic"),
        ]
    })
}

/// Two threads, as two AI systems would, each submit half of the segments to the queue and
/// keep their tickets.
fn submit_from_two_threads(queue: &LosQueue, segments: &[Ray], tickets: &mut [Vec<Ticket>; 2]) {
    let half = segments.len().div_ceil(2);
    let [first, second] = tickets;
    std::thread::scope(|s| {
        for (part, list) in segments.chunks(half).zip([first, second]) {
            s.spawn(move || {
                list.clear();
                list.extend(part.iter().map(|r| queue.submit_ray(*r).expect("capacity")));
            });
        }
    });
}
