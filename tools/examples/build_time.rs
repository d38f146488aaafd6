//! Times the build of every structure ([`AccelKind::ALL`]) over the built-in bunny and terrain,
//! on one thread and on rayon's pool.
//!
//! `cargo run --release -p raybatch-tools --example build_time`
use std::sync::Arc;
use std::time::Instant;

use raybatch::{AccelKind, BuildOptions, Footprint, Mesh};
use raybatch_tools::scenes;

fn main() {
    for scene in [
        scenes::bunny(),
        scenes::terrain(scenes::BUILTIN_TERRAIN_CELLS),
    ] {
        // Shared, so that the timings are the builds and not copies of the mesh.
        let mesh = Arc::new(scene.mesh);
        for parallel in [false, true] {
            let options = BuildOptions::default().with_parallel(parallel);
            let builds: Vec<String> = AccelKind::ALL
                .into_iter()
                .map(|kind| time_build(kind, &mesh, &options))
                .collect();
            println!(
                "{:8} {} triangles, parallel {parallel:5}: {}",
                scene.name,
                mesh.triangle_count(),
                builds.join(", ")
            );
        }
    }
}

/// `name   12.3 ms (24.0 B/tri)` for one build of `kind`.
fn time_build(kind: AccelKind, mesh: &Arc<Mesh>, options: &BuildOptions) -> String {
    let start = Instant::now();
    let accel = kind.build(Arc::clone(mesh), options).unwrap();
    let ms = start.elapsed().as_secs_f64() * 1e3;
    format!(
        "{} {ms:7.1} ms ({:.1} B/tri)",
        kind.name(),
        accel.bytes_per_triangle()
    )
}
