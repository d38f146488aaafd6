//! Scratch: instruction counts per mode under callgrind (MODE=single|batch|batch-unordered).
use raybatch::glam::Vec3;
use raybatch::*;

fn main() {
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000);
    let mode = std::env::var("MODE").unwrap_or_default();
    let leaf: u32 = std::env::var("LEAF")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4);
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
            let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            Ray::new(o, d)
        })
        .collect();
    let tree: AabbTree = AabbTree::build(
        mesh,
        &BuildOptions::default()
            .with_leaf_size(leaf)
            .with_leaf_corners(std::env::var("COPIES").is_ok()),
    )
    .unwrap();
    let mut hits = vec![None; n];
    let o = BatchOptions::default().with_parallel(false);
    match mode.as_str() {
        "single" => hits
            .iter_mut()
            .zip(&rays)
            .for_each(|(h, r)| *h = tree.cast_ray(r)),
        "batch" => tree.cast_rays_with(&rays, &mut hits, &o).unwrap(),
        _ => tree
            .cast_rays_with(&rays, &mut hits, &o.with_ordering(BatchOrdering::Unordered))
            .unwrap(),
    }
    println!("{}", hits.iter().flatten().count());
}
