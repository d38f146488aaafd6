//! The harness of the batched tests: the option space of the batched queries (kernel, batch
//! ordering, partition kernel, `single_ray_below`, chunking, threads), the single-ray answers a
//! batch must reproduce bit for bit, and the comparisons.

use std::sync::{Mutex, OnceLock};

use proptest::prelude::*;
use raybatch::{BatchOptions, BatchOrdering, Hit, Interleave, Kernel, PartitionKernel, Ray};
use rayon::{ThreadPool, ThreadPoolBuilder};

use super::oracles::{HitBits, bits, opt_bits};
use super::rng::permutation;
use super::zoo::{Built, Tested};

/// Where a batched call runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Threads {
    /// `with_parallel(false)`, on the test thread.
    Sequential,
    /// `with_parallel(true)` inside `ThreadPool::install` of a pool of this many threads.
    Pool(usize),
}

pub const THREADS: [Threads; 4] = [
    Threads::Sequential,
    Threads::Pool(1),
    Threads::Pool(2),
    Threads::Pool(3),
];
/// Every partition kernel; those the CPU lacks fall back to the portable one inside the
/// library, so every one is valid on every machine.
pub const PARTITIONS: [PartitionKernel; 3] = PartitionKernel::ALL;
pub const SINGLE_RAY_BELOW: [usize; 3] = [0, 8, 1000];
pub const MAX_CHUNKS: [usize; 4] = [1, 7, 64, usize::MAX];
/// The forced choices: `Auto` is one of them for each structure.
pub const INTERLEAVES: [Interleave; 2] = [Interleave::Always, Interleave::Never];

/// Rayon pools of 1, 2 and 3 threads, built once for the whole binary.
pub fn pool(threads: usize) -> &'static ThreadPool {
    static POOLS: OnceLock<Vec<ThreadPool>> = OnceLock::new();
    &POOLS.get_or_init(|| {
        (1..=3)
            .map(|n| ThreadPoolBuilder::new().num_threads(n).build().unwrap())
            .collect()
    })[threads - 1]
}

/// One point of the option space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Combo {
    pub kernel: Kernel,
    pub ordering: BatchOrdering,
    pub partition: PartitionKernel,
    pub single_ray_below: usize,
    pub max_chunk: usize,
    pub min_chunk: usize,
    pub min_batch: usize,
    pub threads: Threads,
    pub interleave: Interleave,
}

impl Combo {
    pub fn options(&self) -> BatchOptions {
        BatchOptions::default()
            .with_kernel(self.kernel)
            .with_ordering(self.ordering)
            .with_partition(self.partition)
            .with_single_ray_below(self.single_ray_below)
            .with_max_chunk(self.max_chunk)
            .with_min_chunk(self.min_chunk)
            .with_min_batch(self.min_batch)
            .with_parallel(self.threads != Threads::Sequential)
            .with_interleave(self.interleave)
    }

    /// Runs `f` where this combination says (test thread or a pool).
    pub fn run<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
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
/// `max_chunk`, threads and interleaving (2304), with the given `min_chunk` and `min_batch`.
pub fn all_combos(min_chunk: usize, min_batch: usize) -> Vec<Combo> {
    let mut out = Vec::new();
    for kernel in Kernel::ALL {
        for ordering in BatchOrdering::ALL {
            for partition in PARTITIONS {
                for single_ray_below in SINGLE_RAY_BELOW {
                    for max_chunk in MAX_CHUNKS {
                        for threads in THREADS {
                            for interleave in INTERLEAVES {
                                out.push(Combo {
                                    kernel,
                                    ordering,
                                    partition,
                                    single_ray_below,
                                    max_chunk,
                                    min_chunk,
                                    min_batch,
                                    threads,
                                    interleave,
                                });
                            }
                        }
                    }
                }
            }
        }
    }
    assert_eq!(out.len(), 2304);
    out
}

/// The `per_tree` combinations structure number `tree` of the zoo gets: with `per_tree = 32`,
/// the zoo's first 72 structures together get each of the 2304 combinations exactly once
/// (7919 is prime to 2304, so `k -> 7919 k mod 2304` is a permutation), in a scrambled
/// assignment; further structures get them again, in other assignments.
pub fn spread_combos(all: &[Combo], tree: usize, per_tree: usize) -> Vec<Combo> {
    (0..per_tree)
        .map(|j| all[((tree * per_tree + j) * 7919) % all.len()])
        .collect()
}

pub fn combo_strategy() -> impl Strategy<Value = Combo> {
    (
        prop::sample::select(Kernel::ALL.to_vec()),
        prop::sample::select(BatchOrdering::ALL.to_vec()),
        prop::sample::select(PARTITIONS.to_vec()),
        prop::sample::select(SINGLE_RAY_BELOW.to_vec()),
        prop::sample::select(MAX_CHUNKS.to_vec()),
        prop_oneof![3 => Just(1usize), 1 => Just(4096usize)],
        prop_oneof![4 => Just(0usize), 1 => Just(1usize), 1 => Just(32usize)],
        prop::sample::select(THREADS.to_vec()),
        prop::sample::select(INTERLEAVES.to_vec()),
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
                interleave,
            )| Combo {
                kernel,
                ordering,
                partition,
                single_ray_below,
                max_chunk,
                min_chunk,
                min_batch,
                threads,
                interleave,
            },
        )
}

/// The single-ray answers of one structure for a batch, with one kernel.
pub struct Expected {
    pub closest: Vec<Option<HitBits>>,
    pub occluded: Vec<bool>,
    /// `(ray index, hit)`, sorted.
    pub hits: Vec<(usize, HitBits)>,
}

pub fn single_ray_answers(tree: &dyn Tested, rays: &[Ray], kernel: Kernel) -> Expected {
    let closest = rays
        .iter()
        .map(|r| opt_bits(tree.cast_ray_with(r, kernel)))
        .collect();
    let occluded = rays.iter().map(|r| tree.occluded_with(r, kernel)).collect();
    let mut hits = Vec::new();
    for (i, r) in rays.iter().enumerate() {
        tree.for_each_hit_with(r, kernel, &mut |h| hits.push((i, bits(&h))));
    }
    hits.sort_unstable();
    Expected {
        closest,
        occluded,
        hits,
    }
}

/// Both kernels' answers, indexed like [`Kernel::ALL`].
pub fn single_ray_answers_both(tree: &dyn Tested, rays: &[Ray]) -> [Expected; 2] {
    Kernel::ALL.map(|k| single_ray_answers(tree, rays, k))
}

pub fn kernel_index(kernel: Kernel) -> usize {
    Kernel::ALL.iter().position(|&k| k == kernel).unwrap()
}

/// A hit no query can return, written into output slices beforehand so that an output the
/// batch forgot to write is caught.
pub const GARBAGE: Hit = Hit {
    t: -7.0,
    triangle: 0xdead,
    u: -1.0,
    v: -1.0,
};

pub fn batched_closest(
    tree: &Built,
    rays: &[Ray],
    combo: &Combo,
) -> Result<Vec<Option<Hit>>, String> {
    let options = combo.options();
    let mut hits = vec![Some(GARBAGE); rays.len()];
    combo
        .run(|| tree.accel.cast_ray_batch_with(rays, &mut hits, &options))
        .map_err(|e| format!("{} {combo:?}: cast_ray_batch_with failed: {e}", tree.name))?;
    Ok(hits)
}

pub fn batched_occluded(tree: &Built, rays: &[Ray], combo: &Combo) -> Result<Vec<bool>, String> {
    let options = combo.options();
    // Alternating garbage: every output must be written.
    let mut out: Vec<bool> = (0..rays.len()).map(|i| i % 2 == 0).collect();
    combo
        .run(|| tree.accel.occluded_batch_with(rays, &mut out, &options))
        .map_err(|e| format!("{} {combo:?}: occluded_batch_with failed: {e}", tree.name))?;
    Ok(out)
}

pub fn batched_hits(tree: &Built, rays: &[Ray], combo: &Combo) -> Vec<(usize, HitBits)> {
    let options = combo.options();
    let sink = Mutex::new(Vec::new());
    combo.run(|| {
        tree.accel.for_each_hit_batch_with(rays, &options, &|i, h| {
            sink.lock().unwrap().push((i, bits(&h)));
        })
    });
    let mut hits = sink.into_inner().unwrap();
    hits.sort_unstable();
    hits
}

pub fn compare_closest(
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

pub fn compare_occluded(
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
pub fn compare_hits(
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
pub fn check_combo(
    tree: &Built,
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

/// [`check_combo`] for every structure of `zoo` with the combinations `combos(its index)`.
pub fn check_zoo(
    zoo: &[Built],
    rays: &[Ray],
    combos: impl Fn(usize) -> Vec<Combo>,
) -> Result<(), String> {
    for (t, tree) in zoo.iter().enumerate() {
        let expected = single_ray_answers_both(&*tree.accel, rays);
        for combo in combos(t) {
            check_combo(tree, rays, &expected, &combo)?;
        }
    }
    Ok(())
}

#[track_caller]
pub fn ok(result: Result<(), String>) {
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// Shuffles `rays`, returning the shuffled rays and `perm` with `shuffled[k] = rays[perm[k]]`.
pub fn shuffled(rays: &[Ray], seed: u64) -> (Vec<Ray>, Vec<usize>) {
    let perm = permutation(rays.len(), seed);
    (perm.iter().map(|&i| rays[i]).collect(), perm)
}

/// Batches the shuffled rays and maps the answers back to the original order; they must be
/// the single-ray answers of the original order and the batched answers of the original
/// order.
pub fn check_shuffled(tree: &Built, rays: &[Ray], seed: u64, combo: &Combo) -> Result<(), String> {
    let (shuffled, perm) = shuffled(rays, seed);
    let what = format!("{} {combo:?} shuffled (seed {seed})", tree.name);
    let exp = single_ray_answers(&*tree.accel, rays, combo.kernel);

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
