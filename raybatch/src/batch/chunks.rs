//! Splitting a large batch into chunks, run on rayon's current pool (or the calling thread).
//!
//! A chunk is traversed as one batch: bigger chunks share each node fetch among more rays,
//! smaller ones keep the working set in cache and give every thread work.

use rayon::prelude::*;

use super::options::BatchOptions;
use crate::geom::Ray;
use crate::parallel;

/// Chunk length for `n` rays: at most `max_chunk`, and when parallel, small enough to give each
/// thread about four chunks (but not below `min_chunk`).
pub(crate) fn chunk_len(n: usize, options: &BatchOptions) -> usize {
    let mut chunk = n.min(options.max_chunk);
    if options.parallel {
        let per_thread = n.div_ceil(4 * parallel::thread_count(true));
        chunk = chunk.min(per_thread.max(options.min_chunk));
    }
    chunk.max(1)
}

/// Runs `f(offset, rays, out)` on matching chunks of `rays` and `out` (`offset`: the chunk's
/// first ray in the batch), in parallel when `options.parallel` and threads are available.
pub(crate) fn for_each_chunk<T: Send>(
    rays: &[Ray],
    out: &mut [T],
    options: &BatchOptions,
    f: impl Fn(usize, &[Ray], &mut [T]) + Sync,
) {
    let chunk = chunk_len(rays.len(), options);
    if parallel::enabled(options.parallel) {
        rays.par_chunks(chunk)
            .zip(out.par_chunks_mut(chunk))
            .enumerate()
            .for_each(|(c, (r, o))| f(c * chunk, r, o));
    } else {
        rays.chunks(chunk)
            .zip(out.chunks_mut(chunk))
            .enumerate()
            .for_each(|(c, (r, o))| f(c * chunk, r, o));
    }
}
