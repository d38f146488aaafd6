//! A batch at a time: [`BatchQueries`], for every [`Accel`].
//!
//! A call splits the batch into chunks (`crate::batch::chunks`, over rayon's current pool:
//! wrap a call in `ThreadPool::install` to choose the thread count). Each chunk runs with its
//! thread's workspace: its rays are validated, prepared and grouped by octant into lanes or
//! records, as the structure asks ([`crate::accel::StreamLayout`], `crate::batch::group`), and
//! each group goes to [`Accel::trace_stream`] as one
//! [`RayStream`]. Steady-state calls allocate nothing and threads share nothing. Batches smaller
//! than [`BatchOptions::min_batch`] go through the single-ray path.
//!
//! Answers equal the single-ray answers bit for bit (see [`crate::query`]): the structures
//! report the same hits with the same kernels, and the visitors ([`crate::hit`]) keep them by
//! the tie rule, so neither the visiting order nor the grouping can change an outcome.
//!
//! Batches with the Möller-Trumbore kernel also go ray by ray: it is a kernel for comparisons
//! (no faster than the watertight one, and not watertight: see `docs/benchmarks.md`), and
//! the stream engines are compiled for the watertight kernel only.

use crate::accel::{Accel, RayStream, Storage, StreamLayout};
use crate::batch::chunks::for_each_chunk;
use crate::batch::group::{self, Grouping, Groups};
use crate::batch::mixing::JudgedChunk;
use crate::batch::options::BatchOptions;
use crate::batch::partition::Partitioner;
use crate::batch::scratch::BatchScratch;
use crate::batch::slots::Slots;
use crate::geom::{Aabb, Kernel, Ray, Watertight};
use crate::hit::{Hit, Sink, Visitor};
use crate::query::single;
#[cfg(doc)]
use crate::query::single::RayQueries;
use crate::workspace::Workspace;

/// A batched call whose output slice does not match its input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchError {
    /// The output slice's length differs from the number of rays.
    LengthMismatch {
        /// Number of rays.
        rays: usize,
        /// Length of the output slice.
        outputs: usize,
    },
    /// A batch of per-ray filters ([`crate::scene::FilteredBatch`]) has a length other than
    /// the number of rays.
    FilterCount {
        /// Number of rays.
        rays: usize,
        /// Number of filters.
        filters: usize,
    },
}

impl std::fmt::Display for BatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BatchError::LengthMismatch { rays, outputs } => write!(
                f,
                "output slice has {outputs} entries for {rays} rays; they must be equal"
            ),
            BatchError::FilterCount { rays, filters } => {
                write!(f, "{filters} filters for {rays} rays; each ray needs one")
            }
        }
    }
}

impl std::error::Error for BatchError {}

/// Whether a batch goes through the single-ray path: too small to pay for a stream, or with
/// a kernel the stream engines are not compiled for (see the module docs).
pub(crate) fn ray_by_ray(rays: &[Ray], options: &BatchOptions) -> bool {
    rays.len() < options.min_batch || options.kernel != Kernel::Watertight
}

pub(crate) fn check_lengths(rays: usize, outputs: usize) -> Result<(), BatchError> {
    if rays == outputs {
        Ok(())
    } else {
        Err(BatchError::LengthMismatch { rays, outputs })
    }
}

/// The rays of one chunk, prepared into the thread's workspace: the groups, their rays (in the
/// structure's layout) and the structure's scratch, with the call's options.
struct Chunk<'w, S> {
    groups: Groups,
    storage: Storage<'w>,
    scratch: &'w mut S,
    options: &'w BatchOptions,
    partitioner: Partitioner,
    /// The preparation left out the rays that miss the structure's cull box.
    culled: bool,
    /// By slot (the streams' ray ids), the ray's position in the chunk, and the chunk's first
    /// ray in the batch: what [`RayStream::batch_index`] answers.
    positions: &'w [u32],
    offset: usize,
}

impl<S> Chunk<'_, S> {
    /// Hands each group to [`Accel::trace_stream`] with `visitor`.
    fn trace<A: Accel<Scratch = S>, V: Visitor>(&mut self, accel: &A, visitor: &mut V) {
        let options = self.options;
        for (start, end, octant_mask, dense) in self.groups.iter() {
            let partitioner = self.partitioner;
            let storage = self.storage.reborrow();
            let mut stream = RayStream::new(storage, start, end, octant_mask, partitioner, options)
                .culled(self.culled)
                .dense_octant(dense)
                .in_batch(self.positions, self.offset);
            // Rays of a group have different dominant axes, so the watertight kernel dispatches
            // per ray (`Watertight` calls the same `WatertightAxis` function as the single-ray
            // path). Other kernels never get here (`ray_by_ray`).
            accel.trace_stream::<Watertight, V>(&mut stream, self.scratch, visitor)
        }
    }
}

/// The workspace's answer arrays for one chunk, by prepared slot (the streams' ray ids), where
/// each ray went, and the thread's choice of grouping if it made one for the chunk.
struct Answers<'w> {
    slots: &'w Slots,
    best: &'w mut Vec<Hit>,
    occluded: &'w mut Vec<bool>,
    /// The thread's choice of mixing, when it grouped this chunk (`crate::batch::mixing`).
    judged: Option<JudgedChunk<'w>>,
}

/// Which query a chunk answers: only closest hit lets the thread's choice group its chunks
/// (`crate::batch::mixing`).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Query {
    /// The order in which a ray meets surfaces decides how many hits its walk reports, and
    /// the walk counts them.
    Closest,
    /// Any hit (faster mixed on every set measured, docs/benchmarks.md) and all hits (every
    /// hit is reported whatever the order): always the default grouping.
    Other,
}

/// Prepares `rays` in this thread's workspace and runs `f` on them and on the workspace's
/// answer arrays.
fn with_chunk<A: Accel, R>(
    (rays, offset, cull): (&[Ray], usize, Option<Aabb>),
    (options, query): (&BatchOptions, Query),
    partitioner: Partitioner,
    f: impl FnOnce(Chunk<'_, A::Scratch>, Answers<'_>) -> R,
) -> R {
    Workspace::with_local(|workspace| {
        let (batch, scratch) = workspace.parts::<A::Scratch>();
        let BatchScratch {
            lanes,
            rays: records,
            slots,
            best,
            occluded,
            keys,
            mixing,
        } = batch;
        let sorting = (&mut *keys, &mut *slots);
        let grouping = Grouping::new(options.ordering, A::GROUP_BY_OCTANT, A::MIXES_SMALL_OCTANTS);
        let asks = query == Query::Closest && grouping.asks_judge(options.ordering);
        let judged = asks.then(|| JudgedChunk {
            mixed: mixing.choose(rays.len()),
            judge: mixing,
        });
        // The choice only ever keeps apart what the grouping would mix.
        let grouping = match &judged {
            Some(chunk) if !chunk.mixed => Grouping::ByOctant,
            _ => grouping,
        };
        let (groups, storage) = match A::STREAM_LAYOUT {
            StreamLayout::Lanes => (
                group::prepare(rays, (grouping, cull), lanes, sorting),
                Storage::Lanes(lanes),
            ),
            StreamLayout::Records => (
                group::prepare_records(rays, (grouping, cull), records, sorting),
                Storage::Records(records),
            ),
        };
        let slots = &*slots;
        let answers = Answers {
            slots,
            best,
            occluded,
            judged,
        };
        let chunk = Chunk {
            groups,
            storage,
            scratch,
            options,
            partitioner,
            culled: cull.is_some(),
            positions: &slots.positions,
            offset,
        };
        f(chunk, answers)
    })
}

/// Runs `f(offset, out, chunk, answers)` on each chunk of `rays` (`offset`: its first ray in
/// the batch; `out`: its part of `out`), prepared for `accel` in the running thread's
/// workspace, with chunks as long as `options` and `accel`'s layout allow.
fn for_each_prepared_chunk<A: Accel, T: Send>(
    accel: &A,
    (rays, out): (&[Ray], &mut [T]),
    (options, query): (&BatchOptions, Query),
    f: impl Fn(usize, &mut [T], Chunk<'_, A::Scratch>, Answers<'_>) + Sync,
) {
    let partitioner = options.partition.checked();
    let cull = accel.cull_bounds();
    let chunking = (options, accel.max_chunk(rays));
    for_each_chunk(rays, out, chunking, |offset, rays, out| {
        with_chunk::<A, _>(
            (rays, offset, cull),
            (options, query),
            partitioner,
            |chunk, answers| f(offset, out, chunk, answers),
        )
    });
}

/// Runs `f(i, ray, out)` on each ray `rays[i]` and its output, one ray at a time, the batch cut into
/// chunks over the threads as a streamed batch would be: the path of batches too small for a
/// stream (or with a kernel the streams do not run).
pub(crate) fn each_ray<A: Accel, T: Send>(
    accel: &A,
    (rays, out): (&[Ray], &mut [T]),
    options: &BatchOptions,
    f: impl Fn(usize, &Ray, &mut T) + Sync,
) {
    let largest = accel.max_chunk(rays);
    for_each_chunk(rays, out, (options, largest), |offset, rays, out| {
        for (k, (ray, out)) in rays.iter().zip(out).enumerate() {
            f(offset + k, ray, out);
        }
    });
}

/// Writes each ray's closest hit from the chunk's answers by slot, in position order
/// (sequential writes; invalid rays have no slot: a miss); returns how many rays have one.
fn write_closest(hits: &mut [Option<Hit>], slots: &Slots, best: &[Hit]) -> u64 {
    let mut hitting = 0;
    for (out, &slot) in hits.iter_mut().zip(&slots.of_position) {
        *out = best.get(slot as usize).and_then(|hit| hit.found());
        hitting += u64::from(out.is_some());
    }
    hitting
}

/// The batched queries. Every structure of the crate implements them (each compiled once, in
/// this crate). Output slices must be as long as `rays`. Usable as a trait object but for
/// [`BatchQueries::for_each_hit_batch`].
pub trait BatchQueries {
    /// Closest hit of every ray (`hits[i]` for `rays[i]`), identical to
    /// [`RayQueries::cast_ray`] on each ray.
    fn cast_ray_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) -> Result<(), BatchError> {
        self.cast_ray_batch_with(rays, hits, &BatchOptions::default())
    }

    /// [`BatchQueries::cast_ray_batch`] with options.
    fn cast_ray_batch_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError>;

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
    ) -> Result<(), BatchError>;

    /// Calls `f(i, hit)` for every hit of every ray `rays[i]`, in no particular order and
    /// possibly from several threads at once; the set of calls equals
    /// [`RayQueries::for_each_hit`] on each ray.
    fn for_each_hit_batch(&self, rays: &[Ray], f: impl Fn(usize, Hit) + Sync)
    where
        Self: Sized,
    {
        self.for_each_hit_batch_with(rays, &BatchOptions::default(), &f)
    }

    /// [`BatchQueries::for_each_hit_batch`] with options.
    fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: &(dyn Fn(usize, Hit) + Sync),
    );
}

/// [`BatchQueries::cast_ray_batch_with`] on `accel`.
pub(crate) fn cast_ray_batch_with<A: Accel>(
    accel: &A,
    rays: &[Ray],
    hits: &mut [Option<Hit>],
    options: &BatchOptions,
) -> Result<(), BatchError> {
    check_lengths(rays.len(), hits.len())?;
    if ray_by_ray(rays, options) {
        each_ray(accel, (rays, hits), options, |_, ray, hit| {
            *hit = single::cast_ray_with(accel, ray, options.kernel)
        });
        return Ok(());
    }
    for_each_prepared_chunk(
        accel,
        (rays, hits),
        (options, Query::Closest),
        |_, hits, mut chunk, answers| {
            let Answers {
                slots,
                best,
                judged,
                ..
            } = answers;
            // "No hit before +inf": a hit at the ray's own `tmax` still wins (`Closest`
            // compares it with the record's `tmax`, then by the tie rule with this), so the
            // answers equal those of `Hit::none_before(ray.tmax)`, without a gather.
            best.clear();
            best.resize(slots.dead() + 1, Hit::none_before(f32::INFINITY));
            // Every chunk counts its hits (one add per hit, one visitor type to compile); only
            // a chunk the thread's choice grouped reports them (never the chunks of a
            // structure that does not mix octants).
            let mut visitor = Sink::closest(best);
            chunk.trace(accel, &mut visitor);
            let reported = visitor.reported();
            let hitting = write_closest(hits, slots, best);
            if let Some(judged) = judged {
                judged.record(reported, hitting);
            }
        },
    );
    Ok(())
}

/// [`BatchQueries::occluded_batch_with`] on `accel`.
pub(crate) fn occluded_batch_with<A: Accel>(
    accel: &A,
    rays: &[Ray],
    occluded: &mut [bool],
    options: &BatchOptions,
) -> Result<(), BatchError> {
    check_lengths(rays.len(), occluded.len())?;
    if ray_by_ray(rays, options) {
        each_ray(accel, (rays, occluded), options, |_, ray, out| {
            *out = single::occluded_with(accel, ray, options.kernel)
        });
        return Ok(());
    }
    for_each_prepared_chunk(
        accel,
        (rays, occluded),
        (options, Query::Other),
        |_, out, mut chunk, answers| {
            let Answers {
                slots, occluded, ..
            } = answers;
            occluded.clear();
            occluded.resize(slots.dead() + 1, false);
            chunk.trace(accel, &mut Sink::any(occluded));
            for (out, &slot) in out.iter_mut().zip(&slots.of_position) {
                // An invalid ray has no slot and is blocked, as one at a time.
                *out = slot == Slots::NONE || occluded[slot as usize];
            }
        },
    );
    Ok(())
}

/// [`BatchQueries::for_each_hit_batch_with`] on `accel`.
pub(crate) fn for_each_hit_batch_with<A: Accel>(
    accel: &A,
    rays: &[Ray],
    options: &BatchOptions,
    f: &(dyn Fn(usize, Hit) + Sync),
) {
    // No output slice: chunks are matched with zero-sized slots.
    let mut slots = vec![(); rays.len()];
    if ray_by_ray(rays, options) {
        each_ray(accel, (rays, &mut slots), options, |i, ray, _| {
            single::for_each_hit_with(accel, ray, options.kernel, &mut |h| f(i, h))
        });
        return;
    }
    for_each_prepared_chunk(
        accel,
        (rays, &mut slots),
        (options, Query::Other),
        |offset, _, mut chunk, answers| {
            let positions = &answers.slots.positions;
            chunk.trace(accel, &mut Sink::every(offset, positions, f));
        },
    );
}
