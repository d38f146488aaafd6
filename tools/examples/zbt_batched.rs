//! The zero-byte tree's batched closest-hit queries against the AABB tree's, alternately in one
//! process (one thread, incoherent rays, all rays in one call), best of `ROUNDS` each: the ratio
//! issue 8's batched target is about, without the other variants `zbt_variants` times.
//!
//! `cargo run --release -p raybatch-tools --example zbt_batched [-- SCENE|FILE.obj [RAYS [ROUNDS
//! [PACKET_FROM,...]]]]` (the last: values of `BatchOptions::packet_from` to time, each with
//! both trees, `off` for none; by default the default options only).

use std::time::Instant;

use raybatch::zbt::ZbtOptions;
use raybatch::{AabbTree, BatchOptions, BatchQueries, BuildOptions, ZeroByteTree};
use raybatch_tools::scenes::{self, RaySet};

fn main() {
    let mut args = std::env::args().skip(1);
    let scene = scenes::from_arg(args.next().as_deref());
    let count: usize = args.next().map_or(200_000, |n| n.parse().expect("a count"));
    let rounds: usize = args.next().map_or(7, |n| n.parse().expect("a count"));
    // Values of `BatchOptions::packet_from` to time, each with both trees (`off`: none).
    let packet_from = args.next();
    let rays = scenes::generate(RaySet::Incoherent, &scene.mesh, scene.kind, count, 7);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    pool.install(|| {
        let aabb: AabbTree = AabbTree::build(scene.mesh.clone(), &BuildOptions::default()).unwrap();
        let (zbt, perm) = ZeroByteTree::build(scene.mesh.clone(), &ZbtOptions::default()).unwrap();
        let variants: Vec<(String, BatchOptions)> = match &packet_from {
            None => vec![("default".into(), BatchOptions::default())],
            Some(list) => list
                .split(',')
                .map(|v| {
                    let from = if v == "off" { usize::MAX } else { v.parse().unwrap() };
                    (format!("packet_from {v}"), BatchOptions::default().with_packet_from(from))
                })
                .collect(),
        };
        let mut a_hits = vec![None; rays.len()];
        let mut z_hits = vec![None; rays.len()];
        let mut best = vec![[f64::INFINITY; 2]; variants.len()];
        let mut same = true;
        for _ in 0..rounds {
            for ((_, options), best) in variants.iter().zip(&mut best) {
                let start = Instant::now();
                aabb.cast_rays_with(&rays, &mut a_hits, options).unwrap();
                best[0] = best[0].min(start.elapsed().as_secs_f64() * 1e3);
                let start = Instant::now();
                zbt.cast_rays_with(&rays, &mut z_hits, options).unwrap();
                best[1] = best[1].min(start.elapsed().as_secs_f64() * 1e3);
                same &= a_hits.iter().zip(&z_hits).all(|(a, z)| {
                    a.map(|h| h.t.to_bits()) == z.map(|h| h.t.to_bits())
                        && a.map(|h| h.triangle) == z.map(|h| perm[h.triangle as usize])
                });
            }
        }
        for ((name, _), best) in variants.iter().zip(&best) {
            println!(
                "{} {count} rays, best of {rounds}, {name}: aabb {:.2} ms, zbt {:.2} ms, zbt/aabb speed {:.3}",
                scene.name,
                best[0],
                best[1],
                best[0] / best[1],
            );
        }
        if !same {
            println!("answers differ (ties?)");
        }
    });
}
