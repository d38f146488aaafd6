//! Audio occlusion in a town: 64 sound sources (the street spots nearest the listeners) and 8 listeners walking down a street; every
//! frame, the 512 source-listener segments are traced (all hits) and the transmission losses
//! of the walls they cross add up, per ray and batched (the two are checked equal).
//!
//! Materials are per triangle: the ground and roofs let nothing through (60 dB), walls are
//! glass (6 dB), wood (12 dB), brick (25 dB) or concrete (40 dB), chosen per building. A
//! segment through a wall's edge or corner crosses one wall, not two (see
//! `raybatch::users::audio`).
//!
//! Run: `cargo run --release --example audio_occlusion [frames]`

#[path = "support/town.rs"]
mod town;

use std::time::Instant;

use rand::SeedableRng;
use rand::rngs::StdRng;
use raybatch::glam::Vec3;
use raybatch::scene::Scene;
use raybatch::users::{Materials, Occlusion, occlusion, occlusion_batch};
use raybatch::{Mesh, Ray};
use town::Town;

const SOURCES: usize = 64;
const LISTENERS: usize = 8;
/// Wall materials (name, loss in dB).
const WALLS: [(&str, f32); 4] = [
    ("glass", 6.0),
    ("wood", 12.0),
    ("brick", 25.0),
    ("concrete", 40.0),
];
const GROUND_AND_ROOFS_DB: f32 = 60.0;

fn main() {
    let frames: usize = std::env::args()
        .nth(1)
        .map_or(100, |a| a.parse().expect("a number"));
    let town = Town::new(16, 0, 31);
    // Each mesh with the tree the scene picks for it.
    let scene = Scene::from_meshes(town.meshes.clone(), &town.instances).expect("the town builds");
    let tables = town.meshes.iter().map(wall_losses).collect();
    let materials = Materials::new(&scene, tables).expect("one loss per triangle");

    // The sources: the 64 street spots nearest to where the listeners start.
    let mut rng = StdRng::seed_from_u64(31);
    let start = town.street_point(&mut rng);
    let mut near: Vec<Vec3> = (0..4000).map(|_| town.street_point(&mut rng)).collect();
    near.sort_by(|a, b| a.distance(start).total_cmp(&b.distance(start)));
    let sources: Vec<Vec3> = near[..SOURCES].to_vec();
    let mut segments = Vec::with_capacity(SOURCES * LISTENERS);
    let mut per_ray = vec![Occlusion::default(); SOURCES * LISTENERS];
    let mut batched = per_ray.clone();
    let (mut t_ray, mut t_batch) = (0.0, 0.0);
    for frame in 0..frames {
        // The listeners walk along x in a row, 2 m apart.
        let listeners: Vec<Vec3> = (0..LISTENERS)
            .map(|i| start + Vec3::new(frame as f32 * 1.5, 0.0, i as f32 * 2.0))
            .collect();
        segments.clear();
        segments.extend(
            listeners
                .iter()
                .flat_map(|&l| sources.iter().map(move |&s| Ray::segment(s, l))),
        );

        let t = Instant::now();
        for (out, ray) in per_ray.iter_mut().zip(&segments) {
            *out = occlusion(&scene, &materials, ray, u32::MAX);
        }
        t_ray += t.elapsed().as_secs_f64();
        let t = Instant::now();
        occlusion_batch(&scene, &materials, &segments, u32::MAX, &mut batched)
            .expect("lengths match");
        t_batch += t.elapsed().as_secs_f64();
        assert_eq!(per_ray, batched, "per-ray and batched occlusion differ");

        if frame == 0 || frame + 1 == frames {
            report(frame, &batched[..SOURCES]);
        }
    }
    let ms = |s: f64| s / frames as f64 * 1e3;
    println!(
        "{} segments/frame, {frames} frames, {} threads: per ray (one thread) {:.2} ms/frame, batched {:.2} ms/frame ({:.2}x); answers equal",
        segments.len(),
        rayon::current_num_threads(),
        ms(t_ray),
        ms(t_batch),
        t_ray / t_batch
    );
}

/// Per triangle of a tile: ground and roofs (horizontal) block, walls get their building's
/// material (picked from the wall's position, so a building's faces mostly agree).
fn wall_losses(mesh: &Mesh) -> Vec<f32> {
    (0..mesh.triangle_count() as u32)
        .map(|id| {
            let [a, b, c] = mesh.triangle(id);
            let normal = (b - a).cross(c - a).normalize_or_zero();
            if normal.y.abs() > 0.5 {
                GROUND_AND_ROOFS_DB
            } else {
                let centre = (a + b + c) / 3.0;
                let block =
                    (centre.x / 100.0).floor() as i64 * 31 + (centre.z / 100.0).floor() as i64 * 17;
                WALLS[block.rem_euclid(WALLS.len() as i64) as usize].1
            }
        })
        .collect()
}

/// Listener 0's view of the sources: how many walls each path crosses, and the losses.
fn report(frame: usize, sources: &[Occlusion]) {
    let count = |f: &dyn Fn(u32) -> bool| sources.iter().filter(|o| f(o.crossings)).count();
    let mean = sources.iter().map(|o| o.loss_db).sum::<f32>() / sources.len() as f32;
    let worst = sources.iter().map(|o| o.loss_db).fold(0.0f32, f32::max);
    println!(
        "frame {frame:3}, listener 0: sources behind 0 / 1 / 2 / 3+ walls: {} / {} / {} / {}; mean loss {mean:.1} dB, worst {worst:.0} dB",
        count(&|c| c == 0),
        count(&|c| c == 1),
        count(&|c| c == 2),
        count(&|c| c >= 3),
    );
}
