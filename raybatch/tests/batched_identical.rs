//! The batched queries against the single-ray reference, bit for bit.
//!
//! The contract of `raybatch::query::batch`: for every tree ({full, quantized} x leaf {1, 4, 16}
//! x {fixed, split-axis, PNS}), kernel, batch ordering, partition kernel, `single_ray_below`,
//! chunking and thread count, `cast_rays_with` returns exactly `cast_ray_with` for every ray
//! (triangle, `t`, `u`, `v` bits), `occluded_batch_with` exactly `occluded_with`, and
//! `for_each_hit_batch_with` the same multiset of `(ray index, hit)` as `for_each_hit_with` on
//! every ray; whatever the batch size and the order of the rays in the batch. Invalid rays
//! miss, and output slices of the wrong length are an error, not a panic.

mod common;

use std::sync::{Arc, Mutex, OnceLock};

use common::{
    HitBits, LEAF_SIZES, RaySpec, TreeKind, aimed_ray_spec, bits, edges, icosphere,
    icosphere_parts, mesh_strategy, opt_bits, ray_spec,
};
use glam::Vec3;
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use raybatch::query::batch::PartitionKernel;
use raybatch::query::brute_force;
use raybatch::scenes::{self, RaySet, SceneKind};
use raybatch::{
    AabbTree, BatchError, BatchOptions, BatchOrdering, BatchQueries, BuildOptions, Bvh,
    ChildOrdering, Hit, Kernel, Mesh, QuantizedAabbTree, Ray, RayQueries,
};
use rayon::prelude::*;
use rayon::{ThreadPool, ThreadPoolBuilder};

// ---------------------------------------------------------------------------------------------
// Every tree behind one dyn-compatible interface with the batched queries
// ---------------------------------------------------------------------------------------------

/// The single-ray and batched queries of one tree, without generic methods.
trait BatchTree: Sync {
    fn single_cast(&self, ray: &Ray, kernel: Kernel) -> Option<Hit>;
    fn single_occluded(&self, ray: &Ray, kernel: Kernel) -> bool;
    fn single_hits(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit));
    fn batch_cast(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError>;
    fn batch_occluded(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError>;
    fn batch_hits(&self, rays: &[Ray], options: &BatchOptions, f: &(dyn Fn(usize, Hit) + Sync));
    /// `cast_rays` and `occluded_batch` (default options).
    fn batch_cast_default(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), BatchError>;
    fn batch_occluded_default(&self, rays: &[Ray], occluded: &mut [bool])
    -> Result<(), BatchError>;
}

impl<B: Bvh> BatchTree for B {
    fn single_cast(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        RayQueries::cast_ray_with(self, ray, kernel)
    }
    fn single_occluded(&self, ray: &Ray, kernel: Kernel) -> bool {
        RayQueries::occluded_with(self, ray, kernel)
    }
    fn single_hits(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit)) {
        RayQueries::for_each_hit_with(self, ray, kernel, f)
    }
    fn batch_cast(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        BatchQueries::cast_rays_with(self, rays, hits, options)
    }
    fn batch_occluded(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        BatchQueries::occluded_batch_with(self, rays, occluded, options)
    }
    fn batch_hits(&self, rays: &[Ray], options: &BatchOptions, f: &(dyn Fn(usize, Hit) + Sync)) {
        BatchQueries::for_each_hit_batch_with(self, rays, options, f)
    }
    fn batch_cast_default(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), BatchError> {
        BatchQueries::cast_rays(self, rays, hits)
    }
    fn batch_occluded_default(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
    ) -> Result<(), BatchError> {
        BatchQueries::occluded_batch(self, rays, occluded)
    }
}

struct Tree {
    name: String,
    tree: Box<dyn BatchTree>,
}

/// All 18 trees: {AabbTree, QuantizedAabbTree} x {leaf 1, 4, 16} x {Fixed, SplitAxis, Pns}
/// (the combinations of `common::all_trees`, keeping the batched queries).
fn batch_trees(mesh: &Mesh) -> Vec<Tree> {
    let mesh = Arc::new(mesh.clone());
    let mut out = Vec::new();
    for kind in TreeKind::ALL {
        for leaf in LEAF_SIZES {
            for ordering in ChildOrdering::ALL {
                let options = BuildOptions::default()
                    .with_leaf_size(leaf)
                    .with_ordering(ordering);
                let name = format!("{kind:?}/leaf{leaf}/{}", ordering.name());
                let tree: Box<dyn BatchTree> = match kind {
                    TreeKind::Full => Box::new(
                        <AabbTree>::build(mesh.clone(), &options)
                            .unwrap_or_else(|e| panic!("{name}: build failed: {e}")),
                    ),
                    TreeKind::Quantized => Box::new(
                        QuantizedAabbTree::build(mesh.clone(), &options)
                            .unwrap_or_else(|e| panic!("{name}: build failed: {e}")),
                    ),
                };
                out.push(Tree { name, tree });
            }
        }
    }
    assert_eq!(out.len(), 18);
    out
}

// ---------------------------------------------------------------------------------------------
// Batch options under test
// ---------------------------------------------------------------------------------------------

/// Where a batched call runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Threads {
    /// `with_parallel(false)`, on the test thread.
    Sequential,
    /// `with_parallel(true)` inside `ThreadPool::install` of a pool of this many threads.
    Pool(usize),
}

const THREADS: [Threads; 4] = [
    Threads::Sequential,
    Threads::Pool(1),
    Threads::Pool(2),
    Threads::Pool(3),
];
const PARTITIONS: [PartitionKernel; 3] = [
    PartitionKernel::Avx512,
    PartitionKernel::Avx2,
    PartitionKernel::Portable,
];
const SINGLE_RAY_BELOW: [usize; 3] = [0, 8, 1000];
const MAX_CHUNKS: [usize; 4] = [1, 7, 64, usize::MAX];

/// Rayon pools of 1, 2 and 3 threads, built once for the whole binary.
fn pool(threads: usize) -> &'static ThreadPool {
    static POOLS: OnceLock<Vec<ThreadPool>> = OnceLock::new();
    &POOLS.get_or_init(|| {
        (1..=3)
            .map(|n| ThreadPoolBuilder::new().num_threads(n).build().unwrap())
            .collect()
    })[threads - 1]
}

/// One point of the option space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Combo {
    kernel: Kernel,
    ordering: BatchOrdering,
    partition: PartitionKernel,
    single_ray_below: usize,
    max_chunk: usize,
    min_chunk: usize,
    min_batch: usize,
    threads: Threads,
}

impl Combo {
    fn options(&self) -> BatchOptions {
        BatchOptions::default()
            .with_kernel(self.kernel)
            .with_ordering(self.ordering)
            .with_partition(self.partition)
            .with_single_ray_below(self.single_ray_below)
            .with_max_chunk(self.max_chunk)
            .with_min_chunk(self.min_chunk)
            .with_min_batch(self.min_batch)
            .with_parallel(self.threads != Threads::Sequential)
    }

    /// Runs `f` where this combination says (test thread or a pool).
    fn run<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match self.threads {
            Threads::Sequential => f(),
            Threads::Pool(n) => pool(n).install(|| {
                assert_eq!(rayon::current_num_threads(), n);
                f()
            }),
        }
    }
}

/// Every combination of kernel, batch ordering, partition kernel, `single_ray_below`,
/// `max_chunk` and threads (576), with the given `min_chunk` and `min_batch`.
fn all_combos(min_chunk: usize, min_batch: usize) -> Vec<Combo> {
    let mut out = Vec::new();
    for kernel in Kernel::ALL {
        for ordering in BatchOrdering::ALL {
            for partition in PARTITIONS {
                for single_ray_below in SINGLE_RAY_BELOW {
                    for max_chunk in MAX_CHUNKS {
                        for threads in THREADS {
                            out.push(Combo {
                                kernel,
                                ordering,
                                partition,
                                single_ray_below,
                                max_chunk,
                                min_chunk,
                                min_batch,
                                threads,
                            });
                        }
                    }
                }
            }
        }
    }
    assert_eq!(out.len(), 576);
    out
}

/// The `per_tree` combinations tree number `tree` of 18 gets: with `per_tree = 32`, the 18
/// trees together get each of the 576 combinations exactly once (7919 is prime to 576, so
/// `k -> 7919 k mod 576` is a permutation), in a scrambled assignment.
fn spread_combos(all: &[Combo], tree: usize, per_tree: usize) -> Vec<Combo> {
    (0..per_tree)
        .map(|j| all[((tree * per_tree + j) * 7919) % all.len()])
        .collect()
}

fn combo_strategy() -> impl Strategy<Value = Combo> {
    (
        prop::sample::select(Kernel::ALL.to_vec()),
        prop::sample::select(BatchOrdering::ALL.to_vec()),
        prop::sample::select(PARTITIONS.to_vec()),
        prop::sample::select(SINGLE_RAY_BELOW.to_vec()),
        prop::sample::select(MAX_CHUNKS.to_vec()),
        prop_oneof![3 => Just(1usize), 1 => Just(4096usize)],
        prop_oneof![4 => Just(0usize), 1 => Just(1usize), 1 => Just(32usize)],
        prop::sample::select(THREADS.to_vec()),
    )
        .prop_map(
            |(
                kernel,
                ordering,
                partition,
                single_ray_below,
                max_chunk,
                min_chunk,
                min_batch,
                threads,
            )| Combo {
                kernel,
                ordering,
                partition,
                single_ray_below,
                max_chunk,
                min_chunk,
                min_batch,
                threads,
            },
        )
}

// ---------------------------------------------------------------------------------------------
// Single-ray reference and comparison
// ---------------------------------------------------------------------------------------------

/// The single-ray answers of one tree for a batch, with one kernel.
struct Expected {
    closest: Vec<Option<HitBits>>,
    occluded: Vec<bool>,
    /// `(ray index, hit)`, sorted.
    hits: Vec<(usize, HitBits)>,
}

fn single_ray_answers(tree: &dyn BatchTree, rays: &[Ray], kernel: Kernel) -> Expected {
    let closest = rays
        .iter()
        .map(|r| opt_bits(tree.single_cast(r, kernel)))
        .collect();
    let occluded = rays
        .iter()
        .map(|r| tree.single_occluded(r, kernel))
        .collect();
    let mut hits = Vec::new();
    for (i, r) in rays.iter().enumerate() {
        tree.single_hits(r, kernel, &mut |h| hits.push((i, bits(&h))));
    }
    hits.sort_unstable();
    Expected {
        closest,
        occluded,
        hits,
    }
}

/// Both kernels' answers, indexed like [`Kernel::ALL`].
fn single_ray_answers_both(tree: &dyn BatchTree, rays: &[Ray]) -> [Expected; 2] {
    Kernel::ALL.map(|k| single_ray_answers(tree, rays, k))
}

fn kernel_index(kernel: Kernel) -> usize {
    Kernel::ALL.iter().position(|&k| k == kernel).unwrap()
}

/// A hit no query can return, written into output slices beforehand so that an output the
/// batch forgot to write is caught.
const GARBAGE: Hit = Hit {
    t: -7.0,
    triangle: 0xdead,
    u: -1.0,
    v: -1.0,
};

fn batched_closest(tree: &Tree, rays: &[Ray], combo: &Combo) -> Result<Vec<Option<Hit>>, String> {
    let options = combo.options();
    let mut hits = vec![Some(GARBAGE); rays.len()];
    combo
        .run(|| tree.tree.batch_cast(rays, &mut hits, &options))
        .map_err(|e| format!("{} {combo:?}: cast_rays_with failed: {e}", tree.name))?;
    Ok(hits)
}

fn batched_occluded(tree: &Tree, rays: &[Ray], combo: &Combo) -> Result<Vec<bool>, String> {
    let options = combo.options();
    // Alternating garbage: every output must be written.
    let mut out: Vec<bool> = (0..rays.len()).map(|i| i % 2 == 0).collect();
    combo
        .run(|| tree.tree.batch_occluded(rays, &mut out, &options))
        .map_err(|e| format!("{} {combo:?}: occluded_batch_with failed: {e}", tree.name))?;
    Ok(out)
}

fn batched_hits(tree: &Tree, rays: &[Ray], combo: &Combo) -> Vec<(usize, HitBits)> {
    let options = combo.options();
    let sink = Mutex::new(Vec::new());
    combo.run(|| {
        tree.tree.batch_hits(rays, &options, &|i, h| {
            sink.lock().unwrap().push((i, bits(&h)));
        })
    });
    let mut hits = sink.into_inner().unwrap();
    hits.sort_unstable();
    hits
}

fn compare_closest(
    what: &str,
    rays: &[Ray],
    got: &[Option<Hit>],
    expected: &[Option<HitBits>],
) -> Result<(), String> {
    let got: Vec<Option<HitBits>> = got.iter().map(|h| opt_bits(*h)).collect();
    let bad: Vec<usize> = (0..rays.len()).filter(|&i| got[i] != expected[i]).collect();
    match bad.first() {
        None => Ok(()),
        Some(&i) => Err(format!(
            "{what}: closest hit differs for {} of {} rays; first: ray {i} = {:?}: batched \
             {:?}, single-ray {:?} (bits: triangle, t, u, v)",
            bad.len(),
            rays.len(),
            rays[i],
            got[i],
            expected[i]
        )),
    }
}

fn compare_occluded(
    what: &str,
    rays: &[Ray],
    got: &[bool],
    expected: &[bool],
) -> Result<(), String> {
    let bad: Vec<usize> = (0..rays.len()).filter(|&i| got[i] != expected[i]).collect();
    match bad.first() {
        None => Ok(()),
        Some(&i) => Err(format!(
            "{what}: occlusion differs for {} of {} rays; first: ray {i} = {:?}: batched {}, \
             single-ray {}",
            bad.len(),
            rays.len(),
            rays[i],
            got[i],
            expected[i]
        )),
    }
}

/// Compares two sorted multisets of `(ray, hit)`, describing the first ray where they differ.
fn compare_hits(
    what: &str,
    rays: &[Ray],
    got: &[(usize, HitBits)],
    expected: &[(usize, HitBits)],
) -> Result<(), String> {
    if got == expected {
        return Ok(());
    }
    if let Some(&(i, _)) = got.iter().find(|(i, _)| *i >= rays.len()) {
        return Err(format!(
            "{what}: every-hit callback got ray index {i} for a batch of {} rays",
            rays.len()
        ));
    }
    let first = got
        .iter()
        .zip(expected)
        .find(|(a, b)| a != b)
        .map(|(a, b)| a.0.min(b.0))
        .unwrap_or_else(|| {
            let longer = if got.len() > expected.len() {
                got
            } else {
                expected
            };
            longer[got.len().min(expected.len())].0
        });
    let of = |v: &[(usize, HitBits)]| -> Vec<HitBits> {
        v.iter()
            .filter(|(i, _)| *i == first)
            .map(|(_, h)| *h)
            .collect()
    };
    Err(format!(
        "{what}: every-hit multisets differ ({} batched, {} single-ray calls); first differing \
         ray {first} = {:?}: batched {:?}, single-ray {:?} (bits: triangle, t, u, v)",
        got.len(),
        expected.len(),
        rays[first],
        of(got),
        of(expected)
    ))
}

/// Runs the three batched queries of `tree` with `combo` and compares each with the single-ray
/// answers.
fn check_combo(
    tree: &Tree,
    rays: &[Ray],
    expected: &[Expected; 2],
    combo: &Combo,
) -> Result<(), String> {
    let exp = &expected[kernel_index(combo.kernel)];
    let what = format!("{} {combo:?}", tree.name);
    let closest = batched_closest(tree, rays, combo)?;
    compare_closest(&what, rays, &closest, &exp.closest)?;
    let occluded = batched_occluded(tree, rays, combo)?;
    compare_occluded(&what, rays, &occluded, &exp.occluded)?;
    let hits = batched_hits(tree, rays, combo);
    compare_hits(&what, rays, &hits, &exp.hits)
}

/// [`check_combo`] for every tree with the combinations `combos(tree index)`.
fn check_trees(
    trees: &[Tree],
    rays: &[Ray],
    combos: impl Fn(usize) -> Vec<Combo>,
) -> Result<(), String> {
    for (t, tree) in trees.iter().enumerate() {
        let expected = single_ray_answers_both(&*tree.tree, rays);
        for combo in combos(t) {
            check_combo(tree, rays, &expected, &combo)?;
        }
    }
    Ok(())
}

#[track_caller]
fn ok(result: Result<(), String>) {
    if let Err(e) = result {
        panic!("{e}");
    }
}

// ---------------------------------------------------------------------------------------------
// Meshes and rays
// ---------------------------------------------------------------------------------------------

/// The unit icosphere with extra copies of some of its triangles: exact duplicates inserted at
/// low and high ids (ties broken by id), plus rotated and flipped copies (same plane).
fn icosphere_with_duplicates(subdivisions: u32) -> Mesh {
    let (v, t) = icosphere_parts(subdivisions);
    let mut tris = t.clone();
    for (k, &[a, b, c]) in t.iter().enumerate().step_by(3) {
        let at = (k * 37) % (tris.len() + 1);
        match k % 4 {
            0 => tris.insert(at, [a, b, c]),
            1 => tris.push([a, b, c]),
            2 => tris.insert(at, [b, c, a]),
            _ => tris.insert(at, [a, c, b]),
        }
    }
    Mesh::new(v, tris).unwrap()
}

/// The unit icosphere, every triangle present twice (ids `k` and `2n - 1 - k`) plus a third
/// copy of every fifth triangle at the front: every hit is a tie between exact duplicates.
fn icosphere_all_duplicated(subdivisions: u32) -> Mesh {
    let (v, t) = icosphere_parts(subdivisions);
    let mut tris: Vec<[u32; 3]> = t.iter().step_by(5).copied().collect();
    tris.extend(t.iter().copied());
    tris.extend(t.iter().rev().copied());
    Mesh::new(v, tris).unwrap()
}

/// A selection of invalid rays: they must miss everything, in every path.
fn invalid_rays() -> Vec<Ray> {
    let o = Vec3::new(0.1, 0.2, -3.0);
    let d = Vec3::new(0.01, -0.02, 1.0);
    let sub = f32::MIN_POSITIVE / 4.0;
    vec![
        Ray::new(Vec3::new(f32::NAN, 0.0, -3.0), d),
        Ray::new(Vec3::new(0.0, f32::INFINITY, -3.0), d),
        Ray::new(o, Vec3::new(0.0, f32::NAN, 1.0)),
        Ray::new(o, Vec3::new(f32::NEG_INFINITY, 0.0, 1.0)),
        Ray::new(o, Vec3::ZERO),
        Ray::new(o, Vec3::new(-0.0, 0.0, -0.0)),
        Ray::new(o, Vec3::new(sub, -sub, sub)),
        Ray::with_range(o, d, 2.0, 1.0),
        Ray::with_range(o, d, -0.5, 10.0),
        Ray::with_range(o, d, f32::NAN, 10.0),
        Ray::with_range(o, d, 0.0, f32::NAN),
        Ray::with_range(o, d, f32::INFINITY, f32::INFINITY),
        Ray::with_range(o, d, 0.0, f32::NEG_INFINITY),
        Ray::segment(o, o),
    ]
}

/// Ray `i` of the mixes: a valid ray's range variant.
fn with_range_variant(i: usize, origin: Vec3, target: Vec3) -> Ray {
    let d = target - origin;
    match i % 6 {
        0 => Ray::new(origin, d),
        // A segment ending exactly at the target.
        1 => Ray::segment(origin, target),
        // Starting exactly at the target.
        2 => Ray::with_range(origin, d, 1.0, f32::INFINITY),
        // tmin = 0.3 * tmax.
        3 => Ray::with_range(origin, d, 0.6, 2.0),
        // Through the target and beyond, as a segment.
        4 => Ray::segment(origin, origin + 2.0 * d),
        _ => Ray::with_range(origin, d, 0.3 * 1.5, 1.5),
    }
}

/// Rays at the hard places of a mesh around the origin: aimed exactly at every vertex and
/// every edge midpoint from inside and outside, axis-parallel rays through vertices and edge
/// midpoints with `+0` / `-0` components, random rays and segments (some with `tmin > 0`), and
/// invalid rays mixed in.
fn hard_rays(mesh: &Mesh, seed: u64) -> Vec<Ray> {
    let mut rng = StdRng::seed_from_u64(seed);
    let verts = mesh.vertices();
    let mut targets: Vec<Vec3> = verts.to_vec();
    targets.extend(
        edges(mesh)
            .iter()
            .map(|&(a, b)| (verts[a as usize] + verts[b as usize]) * 0.5),
    );
    let origins = [
        Vec3::ZERO,
        Vec3::new(3.0, 0.5, -2.0),
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(-2.5, -2.5, 2.5),
        verts[0],
    ];
    let mut rays = Vec::new();
    for (k, &origin) in origins.iter().enumerate() {
        for (i, &target) in targets.iter().enumerate() {
            if target != origin {
                rays.push(with_range_variant(i + k, origin, target));
            }
        }
    }
    // Axis-parallel through the targets: the two other components exactly those of the target.
    for (i, &target) in targets.iter().enumerate() {
        let axis = i % 3;
        let negative = (i / 3) % 2 == 1;
        let zeros = (i / 6) % 4;
        let mut dir = [0.0f32; 3];
        let mut origin = target.to_array();
        for (k, o) in [(axis + 1) % 3, (axis + 2) % 3].into_iter().enumerate() {
            dir[o] = if zeros >> k & 1 == 1 { -0.0 } else { 0.0 };
        }
        dir[axis] = if negative { -1.0 } else { 1.0 };
        origin[axis] = if negative { 3.0 } else { -3.0 };
        let (origin, dir) = (Vec3::from_array(origin), Vec3::from_array(dir));
        rays.push(match i % 4 {
            0 | 1 => Ray::new(origin, dir),
            2 => Ray::with_range(origin, dir, 0.3 * 6.0, 6.0),
            _ => Ray::segment(origin, target),
        });
    }
    // Random rays, some axis-parallel-ish with zero components, and random segments.
    for i in 0..400 {
        let origin = Vec3::new(
            rng.random_range(-3.0f32..3.0),
            rng.random_range(-3.0f32..3.0),
            rng.random_range(-3.0f32..3.0),
        );
        let mut dir = Vec3::new(
            rng.random_range(-1.0f32..1.0),
            rng.random_range(-1.0f32..1.0),
            rng.random_range(-1.0f32..1.0),
        );
        if i % 5 == 0 {
            dir[i % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
        }
        let target = Vec3::new(
            rng.random_range(-1.2f32..1.2),
            rng.random_range(-1.2f32..1.2),
            rng.random_range(-1.2f32..1.2),
        );
        rays.push(match i % 4 {
            0 => Ray::new(origin, dir),
            1 => Ray::segment(origin, target),
            2 => Ray::with_range(origin, dir, 0.3 * 4.0, 4.0),
            _ => with_range_variant(i, origin, target),
        });
    }
    // Invalid rays at scattered positions.
    let invalid = invalid_rays();
    for (k, ray) in invalid.iter().cycle().take(invalid.len() * 3).enumerate() {
        let at = (k * 131) % (rays.len() + 1);
        rays.insert(at, *ray);
    }
    rays
}

/// Every `step`-th ray.
fn every_nth(rays: &[Ray], step: usize) -> Vec<Ray> {
    rays.iter().step_by(step).copied().collect()
}

// ---------------------------------------------------------------------------------------------
// Deterministic tests
// ---------------------------------------------------------------------------------------------

/// Every tree with every one of the 576 combinations of kernel, batch ordering, partition
/// kernel, `single_ray_below`, `max_chunk` and threads, on a sample of the hard rays of an
/// icosphere with duplicate triangles.
#[test]
fn every_option_combination_on_every_tree() {
    let mesh = icosphere_with_duplicates(1);
    let rays = every_nth(&hard_rays(&mesh, 1), 11);
    assert!(rays.len() > 120, "{}", rays.len());
    let trees = batch_trees(&mesh);
    let combos = all_combos(1, 0);
    ok(check_trees(&trees, &rays, |_| combos.clone()));
}

/// All the hard rays (aimed at every vertex and edge, axis-parallel with signed zeros, windows,
/// segments, invalid rays) on a plain icosphere and two with duplicate triangles, every tree:
/// six of the 576 combinations per tree (108 different ones in all), plus one with the default
/// `min_chunk` (4096) and `min_batch` (32).
#[test]
fn hard_rays_on_icospheres() {
    for (name, mesh) in [
        ("icosphere", icosphere(1)),
        ("icosphere+dups", icosphere_with_duplicates(2)),
        ("icosphere all duplicated", icosphere_all_duplicated(1)),
    ] {
        let rays = hard_rays(&mesh, 2);
        let trees = batch_trees(&mesh);
        let all = all_combos(1, 0);
        let defaults = all_combos(4096, 32);
        ok(check_trees(&trees, &rays, |t| {
            let mut c = spread_combos(&all, t, 6);
            c.extend(spread_combos(&defaults, t + 5, 1));
            c
        })
        .map_err(|e| format!("{name}: {e}")));
    }
}

/// The default-option entry points (`cast_rays`, `occluded_batch`, `for_each_hit_batch`) in the
/// global pool and inside pools of 1, 2 and 3 threads.
#[test]
fn default_entry_points_match_single_ray() {
    let mesh = icosphere_with_duplicates(2);
    let rays = hard_rays(&mesh, 3);
    for tree in batch_trees(&mesh) {
        let exp = single_ray_answers(&*tree.tree, &rays, Kernel::Watertight);
        for threads in [None, Some(1), Some(2), Some(3)] {
            let what = format!("{} default options, pool {threads:?}", tree.name);
            let run = || {
                let mut hits = vec![Some(GARBAGE); rays.len()];
                tree.tree.batch_cast_default(&rays, &mut hits).unwrap();
                let mut occ: Vec<bool> = (0..rays.len()).map(|i| i % 3 == 0).collect();
                tree.tree.batch_occluded_default(&rays, &mut occ).unwrap();
                let sink = Mutex::new(Vec::new());
                tree.tree
                    .batch_hits(&rays, &BatchOptions::default(), &|i, h| {
                        sink.lock().unwrap().push((i, bits(&h)))
                    });
                let mut all = sink.into_inner().unwrap();
                all.sort_unstable();
                (hits, occ, all)
            };
            let (hits, occ, all) = match threads {
                None => run(),
                Some(n) => pool(n).install(run),
            };
            ok(compare_closest(&what, &rays, &hits, &exp.closest));
            ok(compare_occluded(&what, &rays, &occ, &exp.occluded));
            ok(compare_hits(&what, &rays, &all, &exp.hits));
        }
    }
}

/// Batches of 0, 1, 2, 7, 64 and 1000 rays taken from the hard rays, every tree, each size
/// with both small-batch paths (`min_batch` 0: batched engine; 32: single-ray fallback).
#[test]
fn batch_sizes() {
    let mesh = icosphere_with_duplicates(1);
    let pool_rays = hard_rays(&mesh, 4);
    let trees = batch_trees(&mesh);
    let all = all_combos(1, 0);
    for (s, size) in [0usize, 1, 2, 7, 64, 1000].into_iter().enumerate() {
        let rays: Vec<Ray> = pool_rays
            .iter()
            .cycle()
            .skip(s * 97)
            .take(size)
            .copied()
            .collect();
        ok(check_trees(&trees, &rays, |t| {
            let mut c = spread_combos(&all, t + 3 * s, 4);
            c.push(Combo {
                min_batch: 32,
                ..c[0]
            });
            c
        })
        .map_err(|e| format!("batch of {size}: {e}")));
    }
}

/// Invalid rays (NaN or infinite origin or direction, zero or subnormal direction, empty or
/// NaN ranges) miss in every path, also when mixed among valid rays.
#[test]
fn invalid_rays_miss() {
    let mesh = icosphere_with_duplicates(1);
    let invalid = invalid_rays();
    let valid = every_nth(&hard_rays(&mesh, 5), 7);
    // Alone, and interleaved with valid rays.
    let mut mixed = Vec::new();
    for (i, r) in valid.iter().enumerate() {
        mixed.push(*r);
        mixed.push(invalid[i % invalid.len()]);
    }
    let trees = batch_trees(&mesh);
    let all = all_combos(1, 0);
    for rays in [invalid.clone(), mixed] {
        for (t, tree) in trees.iter().enumerate() {
            let expected = single_ray_answers_both(&*tree.tree, &rays);
            for combo in spread_combos(&all, t, 32) {
                ok(check_combo(tree, &rays, &expected, &combo));
                let closest = batched_closest(tree, &rays, &combo).unwrap();
                let occluded = batched_occluded(tree, &rays, &combo).unwrap();
                let hits = batched_hits(tree, &rays, &combo);
                for (i, ray) in rays.iter().enumerate() {
                    if ray.is_valid() {
                        continue;
                    }
                    let what = format!("{} {combo:?}: invalid ray {ray:?}", tree.name);
                    assert_eq!(closest[i], None, "{what}");
                    assert!(!occluded[i], "{what}");
                    assert!(hits.iter().all(|(j, _)| *j != i), "{what}");
                }
            }
        }
    }
}

/// Checks the tie rule on `hit`: no triangle hit at the same `t` (in `brute`, the brute-force
/// hits of `ray`) has a lower id.
fn lowest_id_at_t(brute: &[Hit], ray: &Ray, hit: Option<Hit>) -> Result<(), String> {
    let Some(hit) = hit else { return Ok(()) };
    let lowest = brute
        .iter()
        .filter(|h| h.t == hit.t)
        .map(|h| h.triangle)
        .min();
    if lowest != Some(hit.triangle) {
        return Err(format!(
            "hit triangle {} at t = {}, but the triangles hit at that t (brute force) are led \
             by {lowest:?}, for {ray:?}",
            hit.triangle, hit.t
        ));
    }
    Ok(())
}

/// Exact duplicate triangles: every hit is a tie, and the lowest id wins in the single-ray
/// and the batched path, for every tree and combination.
#[test]
fn duplicate_triangles_lowest_id_wins() {
    let mesh = icosphere_all_duplicated(1);
    let rays = every_nth(&hard_rays(&mesh, 6), 3);
    let brute: Vec<Vec<Vec<Hit>>> = Kernel::ALL
        .iter()
        .map(|&k| {
            rays.iter()
                .map(|r| brute_force::all_hits(&mesh, r, k))
                .collect()
        })
        .collect();
    let trees = batch_trees(&mesh);
    let all = all_combos(1, 0);
    let mut ties = 0;
    for (t, tree) in trees.iter().enumerate() {
        for kernel in Kernel::ALL {
            let brute = &brute[kernel_index(kernel)];
            let single: Vec<Option<Hit>> = rays
                .iter()
                .map(|r| tree.tree.single_cast(r, kernel))
                .collect();
            for (i, ray) in rays.iter().enumerate() {
                let what = format!("{} {kernel:?} ray {i}", tree.name);
                ok(lowest_id_at_t(&brute[i], ray, single[i])
                    .map_err(|e| format!("{what}: single-ray: {e}")));
                ties += usize::from(brute[i].len() >= 2 && single[i].is_some());
            }
            for combo in spread_combos(&all, t, 32) {
                if combo.kernel != kernel {
                    continue;
                }
                let batched = batched_closest(tree, &rays, &combo).unwrap();
                for (i, ray) in rays.iter().enumerate() {
                    let what = format!("{} {combo:?} ray {i}", tree.name);
                    ok(lowest_id_at_t(&brute[i], ray, batched[i])
                        .map_err(|e| format!("{what}: batched: {e}")));
                }
                let expected: Vec<_> = single.iter().map(|h| opt_bits(*h)).collect();
                ok(compare_closest(
                    &format!("{} {combo:?}", tree.name),
                    &rays,
                    &batched,
                    &expected,
                ));
            }
        }
    }
    assert!(ties > 1000, "only {ties} ties");
}

/// Output slices of the wrong length are an error, never a panic, whatever the path.
#[test]
fn length_mismatch_is_an_error() {
    let mesh = icosphere_with_duplicates(1);
    let all_rays = hard_rays(&mesh, 7);
    let trees = batch_trees(&mesh);
    let mut combos = Vec::new();
    for threads in THREADS {
        for min_batch in [0, 32] {
            combos.push(Combo {
                kernel: Kernel::Watertight,
                ordering: BatchOrdering::ByOctant,
                partition: PartitionKernel::detect(),
                single_ray_below: 8,
                max_chunk: 7,
                min_chunk: 1,
                min_batch,
                threads,
            });
        }
    }
    for tree in trees.iter().step_by(5) {
        for n in [0usize, 1, 5, 100, 1000] {
            let rays = &all_rays[..n];
            for outputs in [0, 1, n.saturating_sub(1), n + 1, 2 * n + 3] {
                if outputs == n {
                    continue;
                }
                let expected = Err(BatchError::LengthMismatch { rays: n, outputs });
                for combo in &combos {
                    let options = combo.options();
                    let what = format!("{} {combo:?}: {n} rays, {outputs} outputs", tree.name);
                    let mut hits = vec![None; outputs];
                    let got = combo.run(|| tree.tree.batch_cast(rays, &mut hits, &options));
                    assert_eq!(got, expected, "cast_rays_with {what}");
                    let mut occ = vec![false; outputs];
                    let got = combo.run(|| tree.tree.batch_occluded(rays, &mut occ, &options));
                    assert_eq!(got, expected, "occluded_batch_with {what}");
                }
                let mut hits = vec![None; outputs];
                let got = tree.tree.batch_cast_default(rays, &mut hits);
                assert_eq!(got, expected, "cast_rays {}", tree.name);
                let mut occ = vec![false; outputs];
                let got = tree.tree.batch_occluded_default(rays, &mut occ);
                assert_eq!(got, expected, "occluded_batch {}", tree.name);
                assert!(!format!("{}", got.unwrap_err()).is_empty());
            }
        }
    }
}

/// Shuffles `rays`, returning the shuffled rays and `perm` with `shuffled[k] = rays[perm[k]]`.
fn shuffled(rays: &[Ray], seed: u64) -> (Vec<Ray>, Vec<usize>) {
    let mut perm: Vec<usize> = (0..rays.len()).collect();
    perm.shuffle(&mut StdRng::seed_from_u64(seed));
    (perm.iter().map(|&i| rays[i]).collect(), perm)
}

/// Batches the shuffled rays and maps the answers back to the original order; they must be
/// the single-ray answers of the original order and the batched answers of the original
/// order.
fn check_shuffled(tree: &Tree, rays: &[Ray], seed: u64, combo: &Combo) -> Result<(), String> {
    let (shuffled, perm) = shuffled(rays, seed);
    let what = format!("{} {combo:?} shuffled (seed {seed})", tree.name);
    let exp = single_ray_answers(&*tree.tree, rays, combo.kernel);

    let got = batched_closest(tree, &shuffled, combo)?;
    let mut back = vec![None; rays.len()];
    for (k, &i) in perm.iter().enumerate() {
        back[i] = got[k];
    }
    compare_closest(&what, rays, &back, &exp.closest)?;
    let in_order = batched_closest(tree, rays, combo)?;
    compare_closest(
        &format!("{what} vs in order"),
        rays,
        &back,
        &in_order.iter().map(|h| opt_bits(*h)).collect::<Vec<_>>(),
    )?;

    let got = batched_occluded(tree, &shuffled, combo)?;
    let mut back = vec![false; rays.len()];
    for (k, &i) in perm.iter().enumerate() {
        back[i] = got[k];
    }
    compare_occluded(&what, rays, &back, &exp.occluded)?;
    compare_occluded(
        &format!("{what} vs in order"),
        rays,
        &back,
        &batched_occluded(tree, rays, combo)?,
    )?;

    let mut back: Vec<(usize, HitBits)> = batched_hits(tree, &shuffled, combo)
        .into_iter()
        .map(|(k, h)| (perm[k], h))
        .collect();
    back.sort_unstable();
    compare_hits(&what, rays, &back, &exp.hits)?;
    compare_hits(
        &format!("{what} vs in order"),
        rays,
        &back,
        &batched_hits(tree, rays, combo),
    )
}

/// Results do not depend on the order of the rays in the batch.
#[test]
fn ray_order_does_not_matter() {
    let mesh = icosphere_with_duplicates(2);
    let rays = every_nth(&hard_rays(&mesh, 8), 3);
    let trees = batch_trees(&mesh);
    let all = all_combos(1, 0);
    for (t, tree) in trees.iter().enumerate() {
        for (j, combo) in spread_combos(&all, t, 4).iter().enumerate() {
            ok(check_shuffled(tree, &rays, (t * 4 + j) as u64, combo));
        }
    }
}

/// 100,000 rays (the hard rays of an icosphere with duplicates, then random rays through its
/// bounds, some with `tmin = 0.3 tmax`) on six trees (each node format and leaf size, each
/// ordering twice): every query with one combination, closest and any hit with another.
#[test]
fn hundred_thousand_rays() {
    let mesh = icosphere_with_duplicates(3);
    let mut rays = hard_rays(&mesh, 9);
    let mut rng = StdRng::seed_from_u64(10);
    while rays.len() < 100_000 {
        let p = |rng: &mut StdRng, r: f32| {
            Vec3::new(
                rng.random_range(-r..r),
                rng.random_range(-r..r),
                rng.random_range(-r..r),
            )
        };
        let (origin, target) = (p(&mut rng, 2.0), p(&mut rng, 1.0));
        rays.push(with_range_variant(rays.len(), origin, target));
    }
    rays.truncate(100_000);
    let trees = batch_trees(&mesh);
    let all = all_combos(1, 0);
    for (n, t) in [0, 4, 8, 9, 13, 17].into_iter().enumerate() {
        let tree = &trees[t];
        let kernel = Kernel::ALL[n % 2];
        let exp = single_ray_answers(&*tree.tree, &rays, kernel);
        let mut combos: Vec<Combo> = spread_combos(&all, t, 32)
            .into_iter()
            .filter(|c| c.kernel == kernel && c.max_chunk != 1)
            .take(2)
            .collect();
        assert_eq!(combos.len(), 2);
        combos[0].min_chunk = 4096;
        for (j, combo) in combos.iter().enumerate() {
            let what = format!("{} {combo:?} (100k rays)", tree.name);
            let closest = batched_closest(tree, &rays, combo).unwrap();
            ok(compare_closest(&what, &rays, &closest, &exp.closest));
            let occluded = batched_occluded(tree, &rays, combo).unwrap();
            ok(compare_occluded(&what, &rays, &occluded, &exp.occluded));
            if j == 0 {
                let hits = batched_hits(tree, &rays, combo);
                ok(compare_hits(&what, &rays, &hits, &exp.hits));
            }
        }
    }
}

/// Closest hit of `count` incoherent rays on the Stanford bunny, batched with the default
/// options (parallel, global pool) against the single-ray path.
fn bunny_closest(count: usize) {
    let scene = scenes::bunny();
    let rays = scenes::rays::generate(
        RaySet::Incoherent,
        &scene.mesh,
        SceneKind::Object,
        count,
        42,
    );
    assert_eq!(rays.len(), count);
    let tree: AabbTree = AabbTree::build(scene.mesh, &BuildOptions::default()).unwrap();
    let expected: Vec<Option<HitBits>> = rays
        .par_iter()
        .map(|r| opt_bits(RayQueries::cast_ray(&tree, r)))
        .collect();
    let mut hits = vec![Some(GARBAGE); count];
    BatchQueries::cast_rays(&tree, &rays, &mut hits).unwrap();
    ok(compare_closest(
        &format!("bunny, {count} incoherent rays, default options"),
        &rays,
        &hits,
        &expected,
    ));
    assert!(expected.iter().filter(|h| h.is_some()).count() > count / 10);
}

#[test]
fn bunny_1m_incoherent_closest() {
    bunny_closest(1_000_000);
}

// ---------------------------------------------------------------------------------------------
// Property tests
// ---------------------------------------------------------------------------------------------

/// How a generated ray is changed after it is resolved on the mesh.
#[derive(Clone, Copy, Debug)]
enum Tweak {
    None,
    /// `tmin = 0.3 tmax` (with `tmax = 3` if it was unbounded).
    TminFraction,
    /// Replaced by one of [`invalid_rays`].
    Invalid(usize),
}

fn tweak() -> impl Strategy<Value = Tweak> {
    prop_oneof![
        8 => Just(Tweak::None),
        2 => Just(Tweak::TminFraction),
        1 => (0usize..14).prop_map(Tweak::Invalid),
    ]
}

fn apply(spec: &RaySpec, tweak: Tweak, mesh: &Mesh) -> Ray {
    let ray = spec.resolve(mesh);
    match tweak {
        Tweak::None => ray,
        Tweak::TminFraction => {
            let tmax = if ray.tmax.is_finite() { ray.tmax } else { 3.0 };
            Ray::with_range(ray.origin, ray.dir, 0.3 * tmax, tmax)
        }
        Tweak::Invalid(k) => invalid_rays()[k],
    }
}

const BATCH_SIZES: [usize; 6] = [0, 1, 2, 7, 64, 1000];

/// A batch of ray specs of one of [`BATCH_SIZES`].
fn batch_strategy() -> impl Strategy<Value = Vec<(RaySpec, Tweak)>> {
    prop::sample::select(BATCH_SIZES.to_vec()).prop_flat_map(|n| {
        prop::collection::vec(
            (prop_oneof![2 => ray_spec(), 1 => aimed_ray_spec()], tweak()),
            n,
        )
    })
}

fn resolve_all(specs: &[(RaySpec, Tweak)], mesh: &Mesh) -> Vec<Ray> {
    specs.iter().map(|(s, t)| apply(s, *t, mesh)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Random triangle soups (duplicates, degenerate and coplanar triangles, sometimes over an
    /// icosphere), random batches of rays, every tree, two random option combinations each.
    #[test]
    fn prop_batched_equals_single_ray(
        mesh in mesh_strategy(),
        specs in batch_strategy(),
        combos in prop::collection::vec(combo_strategy(), 36),
    ) {
        let rays = resolve_all(&specs, &mesh);
        let trees = batch_trees(&mesh);
        check_trees(&trees, &rays, |t| combos[2 * t..2 * t + 2].to_vec())
            .map_err(|e| TestCaseError::fail(format!("{e}\nmesh: {}", common::describe(&mesh))))?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The same batches shuffled: results mapped back to the original order are the same.
    #[test]
    fn prop_ray_order_does_not_matter(
        mesh in mesh_strategy(),
        specs in batch_strategy(),
        seed in any::<u64>(),
        combos in prop::collection::vec(combo_strategy(), 18),
    ) {
        let rays = resolve_all(&specs, &mesh);
        for (t, tree) in batch_trees(&mesh).iter().enumerate() {
            check_shuffled(tree, &rays, seed, &combos[t])
                .map_err(|e| TestCaseError::fail(format!("{e}\nmesh: {}", common::describe(&mesh))))?;
        }
    }
}
