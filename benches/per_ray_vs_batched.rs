//! Per-ray versus batched queries on the Stanford bunny the repository ships (`data/`), one
//! thread: closest hit on incoherent rays and any hit on line-of-sight segments, for batches of
//! 1,024 to 1,048,576 rays, with the tree [`AccelKind::for_mesh`] picks and with the binary
//! AABB tree. Criterion reports time per batch; its throughput is rays per second.
//!
//! Ids read `QUERY/STRUCTURE/ENGINE/BATCH SIZE`, so
//! `cargo bench --bench per_ray_vs_batched -- closest/bvh8/` runs one structure and query.
//! `RUSTFLAGS="-C target-cpu=native"` lets the compiler use every instruction set of the
//! machine (the crate never forces it).

use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use raybatch::{
    AccelKind, AnyAccel, BatchOptions, BatchQueries, BuildOptions, Footprint, Hit, Mesh, Ray,
    RayQueries,
};

const SIZES: [usize; 6] = [1 << 10, 1 << 12, 1 << 14, 1 << 16, 1 << 18, 1 << 20];

fn bunny() -> Mesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/stanford-bunny.obj");
    Mesh::load_obj(path).expect("the repository ships the bunny")
}

/// A point uniform in `mesh`'s box, grown by half its size on each side.
fn around(rng: &mut StdRng, mesh: &Mesh) -> Vec3 {
    let b = mesh.bounds();
    let (lo, hi) = (b.min - b.extent() * 0.5, b.max + b.extent() * 0.5);
    Vec3::new(
        rng.random_range(lo.x..hi.x),
        rng.random_range(lo.y..hi.y),
        rng.random_range(lo.z..hi.z),
    )
}

/// Incoherent rays: from a point around the mesh through a point around the mesh.
fn incoherent(mesh: &Mesh, count: usize) -> Vec<Ray> {
    let mut rng = StdRng::seed_from_u64(7);
    (0..count)
        .map(|_| {
            let from = around(&mut rng, mesh);
            Ray::new(from, around(&mut rng, mesh) - from)
        })
        .collect()
}

/// Line-of-sight segments between two points around the mesh.
fn sightlines(mesh: &Mesh, count: usize) -> Vec<Ray> {
    let mut rng = StdRng::seed_from_u64(11);
    (0..count)
        .map(|_| Ray::segment(around(&mut rng, mesh), around(&mut rng, mesh)))
        .collect()
}

fn structures(mesh: &Mesh) -> Vec<AnyAccel> {
    let mut kinds = vec![AccelKind::for_mesh(mesh), AccelKind::Aabb];
    kinds.dedup();
    kinds
        .into_iter()
        .map(|k| {
            k.build(mesh.clone(), &BuildOptions::default())
                .expect("bunny builds")
        })
        .collect()
}

fn closest(c: &mut Criterion) {
    let mesh = bunny();
    let all = incoherent(&mesh, SIZES[SIZES.len() - 1]);
    let options = BatchOptions::default().with_parallel(false);
    let mut group = c.benchmark_group("closest");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500));
    for tree in structures(&mesh) {
        for size in SIZES {
            let rays = &all[..size];
            let mut hits: Vec<Option<Hit>> = vec![None; size];
            group.throughput(Throughput::Elements(size as u64));
            let id = |engine| BenchmarkId::new(format!("{}/{engine}", tree.name()), size);
            group.bench_function(id("per_ray"), |b| {
                b.iter(|| {
                    for (h, r) in hits.iter_mut().zip(rays) {
                        *h = tree.cast_ray(r);
                    }
                })
            });
            group.bench_function(id("batched"), |b| {
                b.iter(|| tree.cast_ray_batch_with(rays, &mut hits, &options).unwrap())
            });
        }
    }
    group.finish();
}

fn any_hit(c: &mut Criterion) {
    let mesh = bunny();
    let all = sightlines(&mesh, SIZES[SIZES.len() - 1]);
    let options = BatchOptions::default().with_parallel(false);
    let mut group = c.benchmark_group("any");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500));
    for tree in structures(&mesh) {
        for size in SIZES {
            let rays = &all[..size];
            let mut out = vec![false; size];
            group.throughput(Throughput::Elements(size as u64));
            let id = |engine| BenchmarkId::new(format!("{}/{engine}", tree.name()), size);
            group.bench_function(id("per_ray"), |b| {
                b.iter(|| {
                    for (o, r) in out.iter_mut().zip(rays) {
                        *o = tree.occluded(r);
                    }
                })
            });
            group.bench_function(id("batched"), |b| {
                b.iter(|| tree.occluded_batch_with(rays, &mut out, &options).unwrap())
            });
        }
    }
    group.finish();
}

criterion_group!(benches, closest, any_hit);
criterion_main!(benches);
