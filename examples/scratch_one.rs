use raybatch::glam::Vec3;
use raybatch::*;
use std::time::Instant;

fn main() {
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let mesh = Mesh::load_obj("data/stanford-bunny.obj").unwrap();
    let b = mesh.bounds();
    let mut s = 0x1234_5678_9abc_def0u64;
    let mut next = || {
        s = s.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let rays: Vec<Ray> = (0..n)
        .map(|_| {
            let o = b.min + (b.max - b.min) * Vec3::new(next(), next(), next());
            let d = loop {
                let d = Vec3::new(next(), next(), next()) * 2.0 - 1.0;
                let l = d.length_squared();
                if l > 1e-6 && l <= 1.0 {
                    break d / l.sqrt();
                }
            };
            Ray::new(o, d)
        })
        .collect();
    let leaf: u32 = std::env::var("LEAF")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4);
    let copies = std::env::var("COPIES").is_ok();
    let opts = BuildOptions::default()
        .with_leaf_size(leaf)
        .with_leaf_corners(copies);
    let tree: AabbTree = AabbTree::build(mesh.clone(), &opts).unwrap();
    let single: Vec<Option<Hit>> = rays.iter().map(|r| tree.cast_ray(r)).collect();
    let mut hits = vec![None; n];
    for ord in BatchOrdering::ALL {
        for par in [0usize, 8, 32] {
            let o = BatchOptions::default()
                .with_ordering(ord)
                .with_parallel(false)
                .with_single_ray_below(par);
            for _ in 0..2 {
                let t0 = Instant::now();
                tree.cast_rays_with(&rays, &mut hits, &o).unwrap();
                let dt = t0.elapsed().as_secs_f64();
                let same = hits.iter().zip(&single).filter(|(a, b)| a == b).count();
                println!(
                    "batched {} par {par} {:.2} Mr/s same {same}",
                    ord.name(),
                    n as f64 / dt / 1e6
                );
            }
        }
    }
    for _ in 0..3 {
        let t0 = Instant::now();
        let hits = rays.iter().filter(|r| tree.cast_ray(r).is_some()).count();
        let dt = t0.elapsed().as_secs_f64();
        println!("full {:.2} Mr/s hits {hits}", n as f64 / dt / 1e6);
    }
}
