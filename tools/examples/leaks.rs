//! The leak target: rays from inside closed meshes (an icosphere, a jittered one, one far from
//! the origin) aimed exactly at vertices and edge midpoints, every one of which must hit, per
//! ray and batched, watertight against Möller-Trumbore and 16-bit quantized vertices.
//!
//! `cargo run --release -p raybatch-tools --example leaks [-- RAYS]` (default 10,000,000 per
//! mesh, generated and answered in chunks of a million). Also checks the f64 judge hits every
//! ray of the first chunk.

use std::sync::Arc;

use raybatch::bvh::QuantizedVertexTree;
use raybatch::bvh::nodes::FullNodes;
use raybatch::mesh::quantized::QuantizedMesh;
use raybatch::{AccelKind, AnyAccel, BatchOptions, BuildOptions, Kernel};
use raybatch_tools::judge::Reference;
use raybatch_tools::scenes::closed::{aimed_rays, closed_meshes};

const CHUNK: usize = 1_000_000;

fn main() {
    let total: usize = std::env::args()
        .nth(1)
        .map_or(10_000_000, |a| a.parse().expect("a ray count"));
    println!("| mesh | mode | rays | leaks per ray | leaks batched |\n|---|---|---:|---:|---:|");
    for closed in closed_meshes() {
        let mesh = Arc::new(closed.mesh.clone());
        let options = BuildOptions::default();
        let default = AccelKind::DEFAULT.build(mesh.clone(), &options).unwrap();
        let q16 = QuantizedMesh::new(&mesh, 16).unwrap();
        let q16 = AnyAccel::new(QuantizedVertexTree::<FullNodes>::build(q16, &options).unwrap());
        let name = AccelKind::DEFAULT.name();
        let modes = [
            (format!("{name} watertight"), &default, Kernel::Watertight),
            (
                format!("{name} moller-trumbore"),
                &default,
                Kernel::MollerTrumbore,
            ),
            ("aabb 16-bit vertices".to_string(), &q16, Kernel::Watertight),
        ];
        let mut leaks = [[0usize; 2]; 3];
        let mut judge_misses = 0;
        let mut hits = vec![None; CHUNK];
        for (c, start) in (0..total).step_by(CHUNK).enumerate() {
            let rays = aimed_rays(&closed, CHUNK.min(total - start), 1000 + c as u64);
            if c == 0 {
                let judge = Reference::new(&mesh);
                judge_misses = judge
                    .closest_all(&rays)
                    .iter()
                    .filter(|h| h.is_none())
                    .count();
            }
            for (m, (_, tree, kernel)) in modes.iter().enumerate() {
                leaks[m][0] += rays
                    .iter()
                    .filter(|r| tree.cast_ray_with(r, *kernel).is_none())
                    .count();
                let hits = &mut hits[..rays.len()];
                let options = BatchOptions::default().with_kernel(*kernel);
                tree.cast_rays_with(&rays, hits, &options).unwrap();
                leaks[m][1] += hits.iter().filter(|h| h.is_none()).count();
            }
        }
        for (m, (name, _, _)) in modes.iter().enumerate() {
            println!(
                "| {} | {name} | {total} | {} | {} |",
                closed.name, leaks[m][0], leaks[m][1]
            );
        }
        eprintln!(
            "{}: the f64 judge missed {judge_misses} of the first chunk's rays",
            closed.name
        );
    }
}
