//! Per-ray versus batched closest-hit and any-hit queries on the built-in bunny, for several
//! batch sizes, on one thread (criterion reports time per batch; throughput is rays/s).
//!
//! `cargo bench --bench per_ray_vs_batched`; set `RUSTFLAGS="-C target-cpu=native"` to let the
//! compiler use every instruction set of this machine (the crate itself never forces it).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use raybatch::scenes::rays::{RaySet, generate};
use raybatch::scenes::{self, SceneKind};
use raybatch::{AabbTree, BatchOptions, BatchQueries, BuildOptions, Hit, RayQueries};

fn closest(c: &mut Criterion) {
    let scene = scenes::bunny();
    let tree: AabbTree = AabbTree::build(scene.mesh.clone(), &BuildOptions::default()).unwrap();
    let all = generate(RaySet::Incoherent, &scene.mesh, SceneKind::Object, 65536, 7);
    let options = BatchOptions::default().with_parallel(false);
    let mut group = c.benchmark_group("bunny_closest_incoherent");
    for size in [64usize, 256, 1024, 4096, 16384, 65536] {
        let rays = &all[..size];
        let mut hits: Vec<Option<Hit>> = vec![None; size];
        group.throughput(Throughput::Elements(size as u64));
        group.bench_with_input(BenchmarkId::new("per_ray", size), &size, |b, _| {
            b.iter(|| {
                for (h, r) in hits.iter_mut().zip(rays) {
                    *h = tree.cast_ray(r);
                }
            })
        });
        group.bench_with_input(BenchmarkId::new("batched", size), &size, |b, _| {
            b.iter(|| tree.cast_rays_with(rays, &mut hits, &options).unwrap())
        });
    }
    group.finish();
}

fn line_of_sight(c: &mut Criterion) {
    let scene = scenes::city(scenes::BUILTIN_CITY_BLOCKS);
    let tree: AabbTree = AabbTree::build(scene.mesh.clone(), &BuildOptions::default()).unwrap();
    let rays = generate(RaySet::LineOfSight, &scene.mesh, SceneKind::City, 65536, 7);
    let options = BatchOptions::default().with_parallel(false);
    let mut out = vec![false; rays.len()];
    let mut group = c.benchmark_group("city_line_of_sight");
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_function("per_ray", |b| {
        b.iter(|| {
            for (o, r) in out.iter_mut().zip(&rays) {
                *o = tree.occluded(r);
            }
        })
    });
    group.bench_function("batched", |b| {
        b.iter(|| tree.occluded_batch_with(&rays, &mut out, &options).unwrap())
    });
    group.finish();
}

criterion_group!(benches, closest, line_of_sight);
criterion_main!(benches);
