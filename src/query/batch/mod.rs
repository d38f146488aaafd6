//! Batched queries: a whole array of rays goes down the tree once (seed 001).
//!
//! Rays are prepared once, grouped by direction octant with a counting sort, and each
//! group is traversed with move-to-front partitioning (`traverse`): every node's box is
//! fetched, dequantized or recomputed once per group, every leaf triangle loaded once per
//! group, and the box test runs over structure-of-arrays lanes (`lanes`) with SIMD across
//! rays ([`partition`]: AVX-512, AVX2 or portable, chosen at run time). Grouping by octant lets the precomputed child order (PNS) apply to the whole
//! group. The triangle kernels are the very functions the single-ray path runs.
//!
//! Large batches are split into chunks processed by rayon (in whatever pool is current: wrap a
//! call in `ThreadPool::install` to choose the thread count). Each worker thread keeps its own
//! scratch arrays in a thread-local, so steady-state calls allocate nothing and share nothing.
//! Small batches go through the single-ray path.
//!
//! **Identical results**: every answer equals the single-ray answer bit for bit (same triangle,
//! `t`, `u`, `v`; same occlusion bool; the same set of hits), whatever the batch size, ray
//! order or thread count. Box tests are conservative, a triangle is accepted by the tie rule
//! of [`crate::query`], and the kernels are shared, so the visiting order cannot change the
//! outcome.

pub(crate) mod lanes;
pub mod partition;
pub(crate) mod traverse;

use std::cell::RefCell;

use rayon::prelude::*;

use crate::geom::ray::flush_subnormals;
use crate::geom::{
    Kernel, KernelTask, MollerTrumbore, PreparedRay, Ray, TriangleTest, Watertight, octant,
};
use crate::query::Hit;
use crate::query::single::RayQueries;
use crate::tree::Bvh;
use lanes::Lanes;
pub use partition::PartitionKernel;
use traverse::{AnyLanes, ClosestLanes, EveryLane, LaneVisitor, traverse_group};

/// How rays of one batch are grouped so that node ordering applies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BatchOrdering {
    /// Group by direction octant and use each node's precomputed order (the default).
    #[default]
    ByOctant,
    /// One group for all directions, children in fixed order.
    Unordered,
}

impl BatchOrdering {
    pub const ALL: [BatchOrdering; 2] = [BatchOrdering::ByOctant, BatchOrdering::Unordered];

    pub fn name(self) -> &'static str {
        match self {
            BatchOrdering::ByOctant => "by-octant",
            BatchOrdering::Unordered => "unordered",
        }
    }
}

/// Options of the batched queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BatchOptions {
    pub kernel: Kernel,
    pub ordering: BatchOrdering,
    /// Split large batches over rayon's current thread pool.
    pub parallel: bool,
    /// Batches smaller than this use the single-ray path. The default, 2048, sits in the
    /// crossover the bench's batch-size sweep measured on the bunny (batched lost at 64-1k rays
    /// and won from 4k on, one thread).
    pub min_batch: usize,
    /// Smallest chunk handed to one rayon task.
    pub min_chunk: usize,
    /// Largest chunk traversed as one batch: bigger chunks share each node fetch among more
    /// rays, smaller ones keep the working set in cache.
    pub max_chunk: usize,
    /// A node reached by fewer rays than this finishes its subtree one ray at a time.
    pub single_ray_below: usize,
    /// Implementation of the box test over many rays ([`PartitionKernel::detect`] by
    /// default); all give identical results.
    pub partition: PartitionKernel,
}

impl Default for BatchOptions {
    fn default() -> Self {
        Self {
            kernel: Kernel::Watertight,
            ordering: BatchOrdering::ByOctant,
            parallel: true,
            min_batch: 2048,
            min_chunk: 4096,
            max_chunk: 1 << 20,
            single_ray_below: 8,
            partition: PartitionKernel::detect(),
        }
    }
}

impl BatchOptions {
    pub fn with_kernel(mut self, kernel: Kernel) -> Self {
        self.kernel = kernel;
        self
    }
    pub fn with_ordering(mut self, ordering: BatchOrdering) -> Self {
        self.ordering = ordering;
        self
    }
    pub fn with_parallel(mut self, parallel: bool) -> Self {
        self.parallel = parallel;
        self
    }
    pub fn with_min_batch(mut self, min_batch: usize) -> Self {
        self.min_batch = min_batch;
        self
    }
    pub fn with_min_chunk(mut self, min_chunk: usize) -> Self {
        self.min_chunk = min_chunk.max(1);
        self
    }
    pub fn with_max_chunk(mut self, max_chunk: usize) -> Self {
        self.max_chunk = max_chunk.max(1);
        self
    }
    pub fn with_single_ray_below(mut self, rays: usize) -> Self {
        self.single_ray_below = rays;
        self
    }
    pub fn with_partition(mut self, partition: PartitionKernel) -> Self {
        self.partition = partition;
        self
    }
}

/// A batched call whose output slice does not match its input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchError {
    LengthMismatch { rays: usize, outputs: usize },
}

impl std::fmt::Display for BatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BatchError::LengthMismatch { rays, outputs } => write!(
                f,
                "output slice has {outputs} entries for {rays} rays; they must be equal"
            ),
        }
    }
}

impl std::error::Error for BatchError {}

fn check_lengths(rays: usize, outputs: usize) -> Result<(), BatchError> {
    if rays == outputs {
        Ok(())
    } else {
        Err(BatchError::LengthMismatch { rays, outputs })
    }
}

/// Per-thread working arrays, reused from call to call.
#[derive(Default)]
struct Scratch {
    lanes: Lanes,
    stack: Vec<(u32, u32)>,
    best: Vec<Hit>,
    keys: Vec<u8>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Runs `f` with this thread's scratch (or a fresh one if a callback re-entered a batch query).
fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    SCRATCH.with(|cell| match cell.try_borrow_mut() {
        Ok(mut scratch) => f(&mut scratch),
        Err(_) => f(&mut Scratch::default()),
    })
}

/// Number of groups: the 8 octants (a single group when unordered).
const GROUPS: usize = 8;

/// Prepares the chunk's rays and fills the lanes grouped by octant (one group when unordered)
/// with a counting sort; returns where each group starts (group `g` is lanes
/// `starts[g]..starts[g + 1]`). Invalid rays get no lane: they miss.
fn prepare_groups(rays: &[Ray], ordering: BatchOrdering, s: &mut Scratch) -> [usize; GROUPS + 1] {
    // Pass 1: each ray's group (GROUPS for an invalid ray), and the group sizes.
    s.keys.clear();
    let mut counts = [0usize; GROUPS + 1];
    for ray in rays {
        let key = match (ray.validate(), ordering) {
            (Err(_), _) => GROUPS,
            (Ok(()), BatchOrdering::ByOctant) => octant(flush_subnormals(ray.dir)) as usize,
            (Ok(()), BatchOrdering::Unordered) => 0,
        };
        counts[key] += 1;
        s.keys.push(key as u8);
    }
    let mut starts = [0usize; GROUPS + 1];
    for g in 0..GROUPS {
        starts[g + 1] = starts[g] + counts[g];
    }
    // Pass 2: prepare each valid ray straight into its lane.
    let mut next = starts;
    s.lanes.reset(starts[GROUPS]);
    for (id, (ray, &key)) in rays.iter().zip(&s.keys).enumerate() {
        let key = key as usize;
        if key < GROUPS {
            s.lanes
                .set(next[key], &PreparedRay::from_valid(ray), id as u32);
            next[key] += 1;
        }
    }
    starts
}

/// One group's traversal, packaged for [`Kernel::dispatch`].
struct GroupTask<'a, B: ?Sized, V> {
    tree: &'a B,
    scratch: &'a mut Scratch,
    start: usize,
    end: usize,
    octant_mask: u8,
    partition: PartitionKernel,
    single_ray_below: usize,
    visitor: &'a mut V,
}

impl<B: Bvh + ?Sized, V: LaneVisitor> KernelTask for GroupTask<'_, B, V> {
    type Output = ();
    fn run<K: TriangleTest>(self) {
        let s = self.scratch;
        traverse_group::<B, K, V>(
            self.tree,
            &mut s.lanes,
            self.start,
            self.end,
            self.octant_mask,
            self.partition,
            self.single_ray_below,
            &mut s.stack,
            self.visitor,
        );
    }
}

/// Runs every group of a prepared chunk with `visitor`.
fn run_groups<B: Bvh + ?Sized, V: LaneVisitor>(
    tree: &B,
    options: &BatchOptions,
    starts: &[usize; GROUPS + 1],
    scratch: &mut Scratch,
    visitor: &mut V,
) {
    for g in 0..GROUPS {
        let (start, end) = (starts[g], starts[g + 1]);
        if start == end {
            continue;
        }
        let octant_mask = match options.ordering {
            BatchOrdering::ByOctant => 1u8 << g,
            BatchOrdering::Unordered => 0,
        };
        let task = GroupTask {
            tree,
            scratch: &mut *scratch,
            start,
            end,
            octant_mask,
            partition: options.partition,
            single_ray_below: options.single_ray_below,
            visitor: &mut *visitor,
        };
        // Rays of a group have different dominant axes, so the watertight kernel dispatches
        // per ray (`Watertight` calls the same `WatertightAxis` function as the single path).
        match options.kernel {
            Kernel::Watertight => task.run::<Watertight>(),
            Kernel::MollerTrumbore => task.run::<MollerTrumbore>(),
        }
    }
}

fn closest_chunk<B: Bvh + ?Sized>(
    tree: &B,
    rays: &[Ray],
    hits: &mut [Option<Hit>],
    options: &BatchOptions,
) {
    with_scratch(|s| {
        let starts = prepare_groups(rays, options.ordering, s);
        let mut best = std::mem::take(&mut s.best);
        best.clear();
        best.extend(rays.iter().map(|r| Hit {
            t: r.tmax,
            triangle: u32::MAX,
            u: 0.0,
            v: 0.0,
        }));
        run_groups(
            tree,
            options,
            &starts,
            s,
            &mut ClosestLanes { best: &mut best },
        );
        for (out, b) in hits.iter_mut().zip(&best) {
            *out = (b.triangle != u32::MAX).then_some(*b);
        }
        s.best = best;
    })
}

fn any_chunk<B: Bvh + ?Sized>(tree: &B, rays: &[Ray], out: &mut [bool], options: &BatchOptions) {
    out.fill(false);
    with_scratch(|s| {
        let starts = prepare_groups(rays, options.ordering, s);
        run_groups(tree, options, &starts, s, &mut AnyLanes { occluded: out });
    })
}

fn every_chunk<B: Bvh + ?Sized, F: Fn(usize, Hit)>(
    tree: &B,
    rays: &[Ray],
    offset: usize,
    f: &F,
    options: &BatchOptions,
) {
    with_scratch(|s| {
        let starts = prepare_groups(rays, options.ordering, s);
        run_groups(tree, options, &starts, s, &mut EveryLane { offset, f });
    })
}

/// Chunk length for `n` rays: at most `max_chunk` (so a chunk's lanes stay in cache), and
/// when parallel, small enough to give each thread about four chunks.
fn chunk_len(n: usize, options: &BatchOptions) -> usize {
    let mut chunk = n.min(options.max_chunk);
    if options.parallel {
        let per_thread = n.div_ceil(4 * rayon::current_num_threads());
        chunk = chunk.min(per_thread.max(options.min_chunk));
    }
    chunk.max(1)
}

/// Runs `f` on matching chunks of `rays` and `out`, on rayon's pool when `options.parallel`.
fn for_each_chunk<T: Send>(
    rays: &[Ray],
    out: &mut [T],
    options: &BatchOptions,
    f: impl Fn(&[Ray], &mut [T]) + Sync,
) {
    let chunk = chunk_len(rays.len(), options);
    if options.parallel {
        rays.par_chunks(chunk)
            .zip(out.par_chunks_mut(chunk))
            .for_each(|(r, o)| f(r, o));
    } else {
        rays.chunks(chunk)
            .zip(out.chunks_mut(chunk))
            .for_each(|(r, o)| f(r, o));
    }
}

/// The batched queries, for every [`Bvh`]. Output slices must be as long as `rays`.
pub trait BatchQueries: Bvh {
    /// Closest hit of every ray (`hits[i]` for `rays[i]`), identical to
    /// [`RayQueries::cast_ray`] on each ray.
    fn cast_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), BatchError> {
        self.cast_rays_with(rays, hits, &BatchOptions::default())
    }

    /// [`BatchQueries::cast_rays`] with options.
    fn cast_rays_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        check_lengths(rays.len(), hits.len())?;
        if rays.len() < options.min_batch {
            for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
                *hit = self.cast_ray_with(ray, options.kernel);
            }
            return Ok(());
        }
        for_each_chunk(rays, hits, options, |r, h| {
            closest_chunk(self, r, h, options)
        });
        Ok(())
    }

    /// Occlusion of every ray (`occluded[i]` for `rays[i]`), identical to
    /// [`RayQueries::occluded`]. A ray is retired from the batch at its first hit.
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) -> Result<(), BatchError> {
        self.occluded_batch_with(rays, occluded, &BatchOptions::default())
    }

    /// [`BatchQueries::occluded_batch`] with options.
    fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        check_lengths(rays.len(), occluded.len())?;
        if rays.len() < options.min_batch {
            for (ray, out) in rays.iter().zip(occluded.iter_mut()) {
                *out = self.occluded_with(ray, options.kernel);
            }
            return Ok(());
        }
        for_each_chunk(rays, occluded, options, |r, o| {
            any_chunk(self, r, o, options)
        });
        Ok(())
    }

    /// Calls `f(i, hit)` for every hit of every ray `rays[i]`, in no particular order and
    /// possibly from several threads at once; the set of calls equals
    /// [`RayQueries::for_each_hit`] on each ray.
    fn for_each_hit_batch(&self, rays: &[Ray], f: impl Fn(usize, Hit) + Sync) {
        self.for_each_hit_batch_with(rays, &BatchOptions::default(), f)
    }

    /// [`BatchQueries::for_each_hit_batch`] with options.
    fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: impl Fn(usize, Hit) + Sync,
    ) {
        if rays.len() < options.min_batch {
            for (i, ray) in rays.iter().enumerate() {
                self.for_each_hit_with(ray, options.kernel, |h| f(i, h));
            }
            return;
        }
        let chunk = chunk_len(rays.len(), options);
        if options.parallel {
            rays.par_chunks(chunk)
                .enumerate()
                .for_each(|(c, r)| every_chunk(self, r, c * chunk, &f, options));
        } else {
            rays.chunks(chunk)
                .enumerate()
                .for_each(|(c, r)| every_chunk(self, r, c * chunk, &f, options));
        }
    }
}

impl<B: Bvh + ?Sized> BatchQueries for B {}
