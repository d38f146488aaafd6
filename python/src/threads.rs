//! Thread counts as Open3D takes them: 0 for rayon's global pool (every core), N for a pool of
//! N threads, made once per N and kept, so repeated calls start no threads.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use pyo3::PyResult;
use pyo3::exceptions::PyValueError;
use rayon::ThreadPool;

/// Threads per core a call may ask for: queries are CPU-bound, so more only take turns on the
/// cores (the command line's `--threads` has the same cap).
const PER_CORE: usize = 4;

/// The cores, asked once.
fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Checks `nthreads` (0, or at most [`PER_CORE`] per core).
pub fn check(nthreads: usize) -> PyResult<()> {
    let cap = PER_CORE * cores();
    if nthreads > cap {
        return Err(PyValueError::new_err(format!(
            "nthreads {nthreads} is more than {PER_CORE} per core ({cap} on this machine)"
        )));
    }
    Ok(())
}

/// The pool of `nthreads` threads, made on first use.
fn pool(nthreads: usize) -> PyResult<Arc<ThreadPool>> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<ThreadPool>>>> = OnceLock::new();
    let mut pools = POOLS
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(pool) = pools.get(&nthreads) {
        return Ok(pool.clone());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(nthreads)
        .build()
        .map_err(|e| PyValueError::new_err(format!("cannot start {nthreads} threads: {e}")))?;
    Ok(pools.entry(nthreads).or_insert(Arc::new(pool)).clone())
}

/// Runs `f` on rayon's global pool (`nthreads == 0`) or on the pool of `nthreads` threads.
pub fn run<R: Send>(nthreads: usize, f: impl FnOnce() -> R + Send) -> PyResult<R> {
    check(nthreads)?;
    if nthreads == 0 {
        return Ok(f());
    }
    Ok(pool(nthreads)?.install(f))
}
