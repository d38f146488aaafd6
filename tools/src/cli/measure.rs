//! Timing a pass over a ray set: wall clock with `Instant`, best of a few passes.

use std::hint::black_box;
use std::time::Instant;

use raybatch::Ray;

/// The best pass over a ray set.
#[derive(Clone, Copy, Debug)]
pub struct Measurement {
    /// Wall-clock seconds of the fastest pass.
    pub seconds: f64,
    /// Rays in the set.
    pub rays: usize,
    /// Rays that hit something (the same on every pass).
    pub hits: usize,
}

impl Measurement {
    /// Millions of rays per second (0 for an empty set).
    pub fn mrays_per_s(&self) -> f64 {
        if self.rays == 0 || self.seconds <= 0.0 {
            return 0.0;
        }
        self.rays as f64 / self.seconds / 1e6
    }
}

/// Runs `pass` over `rays` `passes` times (at least once) and keeps the fastest run. `pass`
/// answers the whole slice and returns its hit count.
pub fn measure(rays: &[Ray], passes: usize, mut pass: impl FnMut(&[Ray]) -> usize) -> Measurement {
    let mut best = Measurement {
        seconds: f64::INFINITY,
        rays: rays.len(),
        hits: 0,
    };
    for _ in 0..passes.max(1) {
        let start = Instant::now();
        let hits = black_box(pass(black_box(rays)));
        let seconds = start.elapsed().as_secs_f64();
        if seconds < best.seconds {
            best.seconds = seconds;
            best.hits = hits;
        }
    }
    best
}

/// Milliseconds taken by `f`, and its result.
pub fn time_ms<R>(f: impl FnOnce() -> R) -> (R, f64) {
    let start = Instant::now();
    let result = f();
    (result, start.elapsed().as_secs_f64() * 1e3)
}
