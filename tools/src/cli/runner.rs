//! Answering a whole ray set with one tree: the single place where query engines plug in.
//!
//! The tree is a [`Measured`], whatever the structure: the tool picks structures at run time
//! from [`raybatch::AccelKind`], and a per-ray query through it costs one indirect call, small
//! next to a traversal.
//!
//! A [`QueryRunner`] owns its output buffers and its thread pool, so that timing a pass
//! measures the queries and the writing of their answers, not allocation or thread start-up,
//! and so that every engine is timed doing the same work. Two engines: [`Engine::PerRay`]
//! (`cast_ray_with` / `occluded_with` on each ray) and [`Engine::Batched`] (`cast_ray_batch_with` /
//! `occluded_batch_with` on the whole slice).
//!
//! Threads ([`Query::threads`]): `Some(1)` runs everything on the calling thread; `Some(n)`
//! with `n > 1` runs the query inside a rayon pool of `n` threads (per-ray queries split the rays
//! with a parallel iterator, batched ones turn on parallel batching); `None` runs per-ray
//! queries on the calling thread and batched ones in rayon's default pool.

use raybatch::{
    BatchError, BatchOptions, BatchOrdering, BatchQueries, Footprint, Hit, Interleave, Kernel,
    PartitionKernel, Ray, RayQueries,
};
use rayon::prelude::*;
use rayon::{ThreadPool, ThreadPoolBuildError, ThreadPoolBuilder};

use crate::measure::Timed;

/// Any structure the command measures: a catalog kind, a scene, a quantized-vertex tree.
pub trait Measured: RayQueries + BatchQueries + Footprint + Sync {}

impl<T: RayQueries + BatchQueries + Footprint + Sync> Measured for T {}

/// Closest hit or any hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueryKind {
    /// `cast_ray`: the nearest hit, with triangle id and barycentrics.
    Closest,
    /// `occluded`: is anything hit at all.
    Any,
}

impl QueryKind {
    /// Both kinds, in the order the help lists them.
    pub const ALL: [QueryKind; 2] = [QueryKind::Closest, QueryKind::Any];

    pub fn name(self) -> &'static str {
        match self {
            QueryKind::Closest => "closest",
            QueryKind::Any => "any",
        }
    }
}

/// How the rays are traversed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// One ray at a time (`cast_ray_with`, `occluded_with`).
    PerRay,
    /// The whole slice at once (`cast_ray_batch_with`, `occluded_batch_with`).
    Batched {
        ordering: BatchOrdering,
        partition: PartitionKernel,
    },
}

impl Engine {
    /// The batched engine with `ordering` and the fastest partition kernel of this CPU.
    pub fn batched(ordering: BatchOrdering) -> Self {
        Engine::Batched {
            ordering,
            partition: PartitionKernel::detect(),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Engine::PerRay => "per-ray",
            Engine::Batched { .. } => "batched",
        }
    }
}

/// Everything that decides how a ray set is answered, except the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Query {
    pub kind: QueryKind,
    pub kernel: Kernel,
    pub engine: Engine,
    /// Threads to run on (see the module docs); `None`: the engine's default.
    pub threads: Option<usize>,
    /// Rays per call of the batched engine (`None`: all rays in one call).
    pub batch_size: Option<usize>,
    /// Whether the batched engine walks rays side by side ([`BatchOptions::interleave`]).
    pub interleave: Interleave,
    /// Largest chunk of the batched engine ([`BatchOptions::max_chunk`]; `None`: the
    /// structure's own).
    pub max_chunk: Option<usize>,
}

impl Query {
    /// A query with the engine's default threads.
    pub fn new(kind: QueryKind, kernel: Kernel, engine: Engine) -> Self {
        Self {
            kind,
            kernel,
            engine,
            threads: None,
            batch_size: None,
            interleave: Interleave::Auto,
            max_chunk: None,
        }
    }

    /// The same query with the batched engine called on `batch_size` rays at a time.
    pub fn with_batch_size(self, batch_size: usize) -> Self {
        Self {
            batch_size: Some(batch_size.max(1)),
            ..self
        }
    }

    /// The same query with [`BatchOptions::interleave`] set to `interleave`.
    pub fn with_interleave(self, interleave: Interleave) -> Self {
        Self { interleave, ..self }
    }

    /// The same query with [`BatchOptions::max_chunk`] set to `max_chunk` rays.
    pub fn with_max_chunk(self, max_chunk: usize) -> Self {
        Self {
            max_chunk: Some(max_chunk.max(1)),
            ..self
        }
    }

    /// Rays per call of the batched engine for a set of `n` rays.
    fn calls_of(&self, n: usize) -> usize {
        self.batch_size.unwrap_or(n).max(1)
    }

    /// The same query on `threads` threads (at least 1).
    pub fn with_threads(self, threads: usize) -> Self {
        Self {
            threads: Some(threads.max(1)),
            ..self
        }
    }

    /// How many threads the query runs on.
    pub fn thread_count(&self) -> usize {
        match (self.threads, self.engine) {
            (Some(n), _) => n,
            (None, Engine::PerRay) => 1,
            (None, Engine::Batched { .. }) => rayon::current_num_threads(),
        }
    }

    /// Whether the work is split over several threads.
    fn parallel(&self) -> bool {
        match self.threads {
            Some(n) => n > 1,
            None => matches!(self.engine, Engine::Batched { .. }),
        }
    }

    /// The options of the batched engine (the defaults for the per-ray one).
    fn batch_options(&self) -> BatchOptions {
        let mut options = BatchOptions::default()
            .with_kernel(self.kernel)
            .with_parallel(self.parallel())
            .with_interleave(self.interleave);
        options.max_chunk = self.max_chunk;
        match self.engine {
            Engine::PerRay => options,
            Engine::Batched {
                ordering,
                partition,
            } => options.with_ordering(ordering).with_partition(partition),
        }
    }

    /// A pool of its own if the query asks for several threads.
    fn pool(&self) -> Result<Option<ThreadPool>, ThreadPoolBuildError> {
        match self.threads {
            Some(n) if n > 1 => ThreadPoolBuilder::new().num_threads(n).build().map(Some),
            _ => Ok(None),
        }
    }
}

/// Answers ray sets with one tree and one [`Query`], into buffers it keeps between runs.
pub struct QueryRunner<'t> {
    tree: &'t dyn Measured,
    query: Query,
    /// The pool the query runs in (`None`: the current thread, or rayon's default pool).
    pool: Option<ThreadPool>,
    answers: Answers,
}

impl Timed for QueryRunner<'_> {
    fn answer(&mut self, rays: &[Ray]) {
        self.run(rays);
    }

    fn hits(&self) -> usize {
        match self.query.kind {
            QueryKind::Closest => self.answers.closest.iter().filter(|h| h.is_some()).count(),
            QueryKind::Any => self.answers.occluded.iter().filter(|&&o| o).count(),
        }
    }
}

impl<'t> QueryRunner<'t> {
    /// A runner whose buffers already hold room for `capacity` rays, with its thread pool
    /// started; fails only if the system refuses the threads.
    pub fn new(
        tree: &'t dyn Measured,
        query: Query,
        capacity: usize,
    ) -> Result<Self, ThreadPoolBuildError> {
        Ok(Self {
            tree,
            query,
            pool: query.pool()?,
            answers: Answers::with_capacity(query.kind, capacity),
        })
    }

    /// Answers `rays` (replacing the previous answers).
    pub fn run(&mut self, rays: &[Ray]) {
        let (tree, query, answers) = (self.tree, &self.query, &mut self.answers);
        match &self.pool {
            Some(pool) => pool.install(|| answers.fill(tree, query, rays)),
            None => answers.fill(tree, query, rays),
        }
    }

    /// The closest hit of each ray of the last run (closest-hit queries only).
    pub fn closest(&self) -> &[Option<Hit>] {
        &self.answers.closest
    }

    /// Whether each ray of the last run was occluded (any-hit queries only).
    pub fn occluded(&self) -> &[bool] {
        &self.answers.occluded
    }
}

/// The output buffers of a runner.
struct Answers {
    /// Closest-hit answers of the last run (empty for any-hit queries).
    closest: Vec<Option<Hit>>,
    /// Any-hit answers of the last run (empty for closest-hit queries).
    occluded: Vec<bool>,
}

impl Answers {
    fn with_capacity(kind: QueryKind, capacity: usize) -> Self {
        let (closest, occluded) = match kind {
            QueryKind::Closest => (Vec::with_capacity(capacity), Vec::new()),
            QueryKind::Any => (Vec::new(), Vec::with_capacity(capacity)),
        };
        Self { closest, occluded }
    }

    /// Answers `rays` on the current thread or pool.
    fn fill(&mut self, tree: &dyn Measured, query: &Query, rays: &[Ray]) {
        match query.kind {
            QueryKind::Closest => self.fill_closest(tree, query, rays),
            QueryKind::Any => self.fill_occluded(tree, query, rays),
        }
    }

    fn fill_closest(&mut self, tree: &dyn Measured, query: &Query, rays: &[Ray]) {
        let kernel = query.kernel;
        fill(
            &mut self.closest,
            None,
            query,
            rays,
            |r| tree.cast_ray_with(r, kernel),
            |r, out, options| tree.cast_ray_batch_with(r, out, options),
        );
    }

    fn fill_occluded(&mut self, tree: &dyn Measured, query: &Query, rays: &[Ray]) {
        let kernel = query.kernel;
        fill(
            &mut self.occluded,
            false,
            query,
            rays,
            |r| tree.occluded_with(r, kernel),
            |r, out, options| tree.occluded_batch_with(r, out, options),
        );
    }
}

/// Answers `rays` into `out` with the query's engine: `per_ray` on each ray (in parallel if the
/// query has threads), or `batch` on calls of the query's batch size.
fn fill<T: Clone + Send>(
    out: &mut Vec<T>,
    blank: T,
    query: &Query,
    rays: &[Ray],
    per_ray: impl Fn(&Ray) -> T + Sync + Send,
    batch: impl Fn(&[Ray], &mut [T], &BatchOptions) -> Result<(), BatchError>,
) {
    match query.engine {
        Engine::PerRay if query.parallel() => rays.par_iter().map(per_ray).collect_into_vec(out),
        Engine::PerRay => {
            out.clear();
            out.extend(rays.iter().map(per_ray));
        }
        Engine::Batched { .. } => {
            // Every call writes each of its answers: the buffer is only sized, not refilled.
            if out.len() != rays.len() {
                out.clear();
                out.resize(rays.len(), blank);
            }
            let (options, size) = (query.batch_options(), query.calls_of(rays.len()));
            for (rays, out) in rays.chunks(size).zip(out.chunks_mut(size)) {
                batch(rays, out, &options).expect("one answer slot per ray");
            }
        }
    }
}
