//! Times the SAH build of the built-in scenes on one thread and on rayon's pool.
//!
//! `cargo run --release --example build_time`
use std::time::Instant;

use raybatch::scenes;
use raybatch::{AabbTree, BuildOptions, Bvh, QuantizedAabbTree};

fn main() {
    for scene in [
        scenes::bunny(),
        scenes::terrain(scenes::BUILTIN_TERRAIN_CELLS),
    ] {
        for parallel in [false, true] {
            let options = BuildOptions::default().with_parallel(parallel);
            let start = Instant::now();
            let tree: AabbTree = AabbTree::build(scene.mesh.clone(), &options).unwrap();
            let full_ms = start.elapsed().as_secs_f64() * 1e3;
            let start = Instant::now();
            let quantized = QuantizedAabbTree::build(scene.mesh.clone(), &options).unwrap();
            let quantized_ms = start.elapsed().as_secs_f64() * 1e3;
            println!(
                "{:8} {} triangles, parallel {parallel:5}: full {full_ms:7.1} ms ({:.1} B/tri), quantized {quantized_ms:7.1} ms ({:.1} B/tri), depth {}",
                scene.name,
                scene.mesh.triangle_count(),
                tree.bytes_per_triangle(),
                quantized.bytes_per_triangle(),
                tree.depth()
            );
        }
    }
}
