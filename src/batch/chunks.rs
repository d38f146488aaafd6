//! Splitting a large batch into chunks, run on rayon's current pool (or the calling thread).
//!
//! A chunk is traversed as one batch: bigger chunks share each node fetch among more rays,
//! smaller ones keep the working set in cache and give every thread work.
//!
//! On one thread the batch is cut into chunks of [`BatchOptions::max_chunk`] rays (or the
//! structure's own, [`crate::accel::Accel::max_chunk`]). On several,
//! chunks shrink as the batch runs out (guided scheduling): each is a share of the rays still
//! waiting, so the threads start on large chunks and finish on small ones, and none sits idle
//! while another works through a large last chunk. Threads take the chunks in order from one
//! queue. Uniform chunks (about four per thread) finish unevenly on camera rays, whose chunks
//! cost more where the image shows the mesh: on 1M camera rays the fandisk's two-thread
//! speedup went from 1.68x with uniform chunks to 1.87x with guided ones (docs/benchmarks.md).

use crossbeam::queue::ArrayQueue;

use super::options::BatchOptions;
use crate::geom::Ray;
use crate::parallel;

/// The smallest share of a batch a thread is given when the batch holds less than
/// [`BatchOptions::min_chunk`] rays per thread: a game frame's 2,000 sightlines then run on
/// two threads, while a task still holds far more work than it costs to start one.
pub(crate) const SMALLEST_SHARE: usize = 512;

/// The chunks of a batch of `n` rays for `threads` threads, in order, as ray ranges: each
/// takes `1 / (2 * threads)` of the rays not yet handed out, within `[smallest, largest]`
/// ([`BatchOptions::chunk_bounds`]; the last one takes whatever is left). A batch too small
/// to give each thread `smallest` rays is cut evenly over the threads instead, in chunks of
/// at least [`SMALLEST_SHARE`] rays.
pub(crate) fn plan(
    n: usize,
    threads: usize,
    (smallest, largest): (usize, usize),
) -> Vec<std::ops::Range<usize>> {
    let threads = threads.max(1);
    let smallest = smallest.min(n.div_ceil(threads).max(SMALLEST_SHARE));
    let mut chunks = Vec::new();
    let mut start = 0;
    while start < n {
        let share = (n - start).div_ceil(2 * threads);
        let end = n.min(start + share.clamp(smallest, largest));
        chunks.push(start..end);
        start = end;
    }
    chunks
}

/// Runs `f(offset, rays, out)` on matching chunks of `rays` and `out` (`offset`: the chunk's
/// first ray in the batch) for a structure whose own largest chunk is `default_largest`
/// ([`crate::accel::Accel::max_chunk`]), in parallel when `options.parallel` and
/// threads are available.
pub(crate) fn for_each_chunk<T: Send>(
    rays: &[Ray],
    out: &mut [T],
    (options, default_largest): (&BatchOptions, usize),
    f: impl Fn(usize, &[Ray], &mut [T]) + Sync,
) {
    let threads = parallel::thread_count(options.parallel);
    let bounds = options.chunk_bounds(default_largest);
    if threads <= 1 {
        let chunk = bounds.1;
        rays.chunks(chunk)
            .zip(out.chunks_mut(chunk))
            .enumerate()
            .for_each(|(c, (r, o))| f(c * chunk, r, o));
        return;
    }
    let plan = plan(rays.len(), threads, bounds);
    if plan.len() <= 1 {
        // One chunk (a game frame's call of a few thousand rays): no tasks to spawn.
        return f(0, rays, out);
    }
    let workers = threads.min(plan.len());
    let queue = ArrayQueue::new(plan.len());
    let mut rest = out;
    for range in plan {
        let (chunk, after) = rest.split_at_mut(range.len());
        rest = after;
        let item = (range.start, &rays[range], chunk);
        // The queue holds one item per chunk of the plan.
        assert!(queue.push(item).is_ok(), "the chunk queue is full");
    }
    parallel::workers(workers, || {
        while let Some((offset, rays, out)) = queue.pop() {
            f(offset, rays, out);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::StreamLayout;

    /// The plan covers the batch in order with no gap, its chunks within the bounds (the last
    /// one possibly smaller) and never growing.
    #[test]
    fn plans_cover_the_batch_with_shrinking_chunks() {
        let options = BatchOptions::default()
            .with_min_chunk(4096)
            .with_max_chunk(1 << 17);
        let bounds = options.chunk_bounds(StreamLayout::Records.default_max_chunk());
        for n in [0, 1, 4095, 4096, 10_000, 131_072, 1_000_000, 3_333_333] {
            for threads in [1, 2, 3, 8] {
                let plan = plan(n, threads, bounds);
                let mut start = 0;
                for (k, range) in plan.iter().enumerate() {
                    assert_eq!(range.start, start, "n {n}, threads {threads}");
                    assert!(range.len() <= 1 << 17 && !range.is_empty());
                    let smallest = n.div_ceil(threads).clamp(SMALLEST_SHARE, 4096);
                    assert!(range.len() >= smallest || k + 1 == plan.len());
                    if let Some(next) = plan.get(k + 1) {
                        assert!(next.len() <= range.len(), "n {n}, threads {threads}");
                    }
                    start = range.end;
                }
                assert_eq!(start, n);
            }
        }
        // A million rays on two threads: full chunks first, then shrinking ones.
        let plan = plan(1_000_000, 2, bounds);
        assert_eq!(plan[0].len(), 1 << 17);
        assert!(plan.len() > 10 && plan.last().unwrap().len() <= 4096);
        // A frame's few thousand sightlines: one chunk per thread.
        let lens = |n, threads| {
            super::plan(n, threads, bounds)
                .iter()
                .map(|r| r.len())
                .collect::<Vec<_>>()
        };
        assert_eq!(lens(2000, 2), vec![1000, 1000]);
        assert_eq!(lens(6000, 2), vec![3000, 3000]);
        assert_eq!(lens(700, 2), vec![512, 188]);
        assert_eq!(lens(1500, 8), vec![512, 512, 476]);
    }
}
