//! rayon, with a fallback to the calling thread when no thread can be started.
//!
//! rayon starts its global pool on first use and panics if the system refuses the threads (a
//! process limit, a sandbox). The library must not panic on a machine that merely has fewer
//! resources, so before the first parallel operation outside a pool it starts the global pool
//! itself (with rayon's default settings, exactly what rayon would do) and remembers whether
//! that worked; if not, every "parallel" operation runs on the calling thread. Answers never
//! depend on the thread count, so nothing but speed changes.
//!
//! This is the one module that calls rayon: the rest of the crate asks it for parallel work
//! ([`join`], [`workers`]), so none of it can start rayon's global pool behind the fallback's
//! back.

use std::error::Error;
use std::sync::OnceLock;

/// True if parallel work can run: the caller is inside a rayon pool, or the global pool is (or
/// could be) started.
pub(crate) fn threads_available() -> bool {
    if rayon::current_thread_index().is_some() {
        return true;
    }
    static GLOBAL_POOL: OnceLock<bool> = OnceLock::new();
    *GLOBAL_POOL.get_or_init(|| match rayon::ThreadPoolBuilder::new().build_global() {
        Ok(()) => true,
        // Without an I/O cause the error says the pool already exists (started by the user or
        // by an earlier rayon call); with one, the threads could not be started.
        Err(e) => e.source().is_none(),
    })
}

/// Whether work asked to run in parallel can: `wanted` and threads are available.
pub(crate) fn enabled(wanted: bool) -> bool {
    wanted && threads_available()
}

/// Threads of the pool parallel work would run on (1 when it would run on the caller).
pub(crate) fn thread_count(parallel: bool) -> usize {
    if enabled(parallel) {
        rayon::current_num_threads()
    } else {
        1
    }
}

/// `(a(), b())`, the two in parallel when `parallel` and threads are available.
pub(crate) fn join<A, B, RA, RB>(parallel: bool, a: A, b: B) -> (RA, RB)
where
    A: FnOnce() -> RA + Send,
    B: FnOnce() -> RB + Send,
    RA: Send,
    RB: Send,
{
    if enabled(parallel) {
        rayon::join(a, b)
    } else {
        (a(), b())
    }
}

/// `items.into_iter().map(item)` collected in order (items: a range of indices, or owned
/// values), computed on rayon's pool when `parallel` and threads are available.
pub(crate) fn map<I, U>(
    parallel: bool,
    items: I,
    item: impl Fn(<I as IntoIterator>::Item) -> U + Sync + Send,
) -> Vec<U>
where
    I: IntoIterator + rayon::iter::IntoParallelIterator<Item = <I as IntoIterator>::Item>,
    U: Send,
{
    use rayon::prelude::*;
    if enabled(parallel) {
        items.into_par_iter().map(item).collect()
    } else {
        items.into_iter().map(item).collect()
    }
}

/// Runs `worker` as `count` tasks at once in the current pool (each runs until it finds no
/// more work), or once on the calling thread when `count` is 1 or threads are not available.
pub(crate) fn workers(count: usize, worker: impl Fn() + Sync) {
    if count <= 1 || !threads_available() {
        return worker();
    }
    let worker = &worker;
    rayon::scope(|scope| {
        for _ in 0..count {
            scope.spawn(move |_| worker());
        }
    });
}
