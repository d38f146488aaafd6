//! Temporary: per-ray structures/variants alternated in one process.
//! zz_ab MESH RAYS ROUNDS closest|any TREE[:COPY[:VARIANT]]...
use std::time::Instant;

use raybatch::{AccelKind, AnyAccel, BuildOptions, LeafCopy, Mesh};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mesh = std::sync::Arc::new(Mesh::load_obj(&args[0]).unwrap());
    let rays =
        raybatch_tools::formats::read_rays(std::fs::File::open(&args[1]).unwrap(), None).unwrap();
    let rounds: usize = args[2].parse().unwrap();
    let any = args[3] == "any";
    let specs = &args[4..];
    let trees: Vec<(AnyAccel, u32)> = specs
        .iter()
        .map(|spec| {
            let mut parts = spec.split(':');
            let kind = AccelKind::from_name(parts.next().unwrap()).unwrap();
            let copy = LeafCopy::from_name(parts.next().unwrap_or("auto")).unwrap();
            let variant = parts.next().map_or(0, |v| v.parse().unwrap());
            let options = BuildOptions {
                leaf_copy: copy,
                ..BuildOptions::default()
            };
            (kind.build(mesh.clone(), &options).unwrap(), variant)
        })
        .collect();
    let mut best = vec![f64::MAX; specs.len()];
    let mut reference = None;
    for _ in 0..rounds {
        for (k, (tree, v)) in trees.iter().enumerate() {
            let _ = v;
            let start = Instant::now();
            let sum: f64 = if any {
                rays.iter().filter(|r| tree.occluded(r)).count() as f64
            } else {
                rays.iter()
                    .map(|r| {
                        tree.cast_ray(r)
                            .map_or(0.0, |h| h.t as f64 + h.triangle as f64)
                    })
                    .sum()
            };
            best[k] = best[k].min(start.elapsed().as_secs_f64() * 1e3);
            assert_eq!(*reference.get_or_insert(sum), sum);
        }
    }
    let tris = mesh.triangle_count() as f64;
    let line: Vec<String> = specs
        .iter()
        .zip(&best)
        .zip(&trees)
        .map(|((s, b), (t, _))| {
            format!(
                "{s}={b:.1} ({:.1} B/tri)",
                raybatch::Footprint::heap_bytes(t) as f64 / tris
            )
        })
        .collect();
    println!("{} {}: {}", args[0], args[1], line.join(" "));
}
