//! Per-ray versus batched closest-hit and any-hit queries on the built-in bunny and city, for
//! several batch sizes, on one thread (criterion reports time per batch; throughput is rays/s),
//! for every structure of [`AccelKind::ALL`]: ids read `GROUP/STRUCTURE/ENGINE[/BATCH SIZE]`,
//! so `cargo bench --bench per_ray_vs_batched -- aabb/` runs one structure.
//!
//! `cargo bench -p raybatch-tools --bench per_ray_vs_batched`; set
//! `RUSTFLAGS="-C target-cpu=native"` to let the compiler use every instruction set of this
//! machine (the crate itself never forces it).

use std::sync::Arc;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use raybatch::{AccelKind, AnyAccel, BatchOptions, BuildOptions, Hit, Mesh};
use raybatch_tools::scenes::{self, RaySet, SceneKind, generate};

/// `kind` built over `mesh` with the default options.
fn build(kind: AccelKind, mesh: &Arc<Mesh>) -> AnyAccel {
    kind.build(Arc::clone(mesh), &BuildOptions::default())
        .expect("the built-in scenes build")
}

fn closest(c: &mut Criterion) {
    let scene = scenes::bunny();
    let all = generate(RaySet::Incoherent, &scene.mesh, SceneKind::Object, 65536, 7);
    let mesh = Arc::new(scene.mesh);
    let options = BatchOptions::default().with_parallel(false);
    let mut group = c.benchmark_group("bunny_closest_incoherent");
    for kind in AccelKind::ALL {
        let tree = build(kind, &mesh);
        for size in [64usize, 256, 1024, 4096, 16384, 65536] {
            let rays = &all[..size];
            let mut hits: Vec<Option<Hit>> = vec![None; size];
            group.throughput(Throughput::Elements(size as u64));
            let id = |engine| BenchmarkId::new(format!("{}/{engine}", kind.name()), size);
            group.bench_with_input(id("per_ray"), &size, |b, _| {
                b.iter(|| {
                    for (h, r) in hits.iter_mut().zip(rays) {
                        *h = tree.cast_ray(r);
                    }
                })
            });
            group.bench_with_input(id("batched"), &size, |b, _| {
                b.iter(|| tree.cast_rays_with(rays, &mut hits, &options).unwrap())
            });
        }
    }
    group.finish();
}

fn line_of_sight(c: &mut Criterion) {
    let scene = scenes::city(scenes::BUILTIN_CITY_BLOCKS);
    let rays = generate(RaySet::LineOfSight, &scene.mesh, SceneKind::City, 65536, 7);
    let mesh = Arc::new(scene.mesh);
    let options = BatchOptions::default().with_parallel(false);
    let mut out = vec![false; rays.len()];
    let mut group = c.benchmark_group("city_line_of_sight");
    group.throughput(Throughput::Elements(rays.len() as u64));
    for kind in AccelKind::ALL {
        let tree = build(kind, &mesh);
        group.bench_function(format!("{}/per_ray", kind.name()), |b| {
            b.iter(|| {
                for (o, r) in out.iter_mut().zip(&rays) {
                    *o = tree.occluded(r);
                }
            })
        });
        group.bench_function(format!("{}/batched", kind.name()), |b| {
            b.iter(|| tree.occluded_batch_with(&rays, &mut out, &options).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, closest, line_of_sight);
criterion_main!(benches);
