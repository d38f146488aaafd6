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

/// A query timed over a ray set: [`Timed::answer`] is what the clock measures; the hit count
/// is read from its answers after the clock stops (counting a million answers, and refilling
/// the output buffer before each pass, took 3-4 ms that no library call spends: on two threads
/// they were a serial tail worth a tenth of the time).
pub trait Timed {
    /// Answers every ray of `rays`.
    fn answer(&mut self, rays: &[Ray]);
    /// Rays that hit something in the last [`Timed::answer`].
    fn hits(&self) -> usize;
}

/// Runs `timed` over `rays` `passes` times (at least once) and keeps the fastest run.
pub fn measure(rays: &[Ray], passes: usize, timed: &mut impl Timed) -> Measurement {
    let mut best = Measurement {
        seconds: f64::INFINITY,
        rays: rays.len(),
        hits: 0,
    };
    for _ in 0..passes.max(1) {
        let seconds = time_pass(rays, timed);
        if seconds < best.seconds {
            best.seconds = seconds;
            best.hits = timed.hits();
        }
    }
    best
}

/// Seconds of one [`Timed::answer`] over `rays`.
fn time_pass(rays: &[Ray], timed: &mut impl Timed) -> f64 {
    let start = Instant::now();
    timed.answer(black_box(rays));
    start.elapsed().as_secs_f64()
}

/// Every timed pass of [`measure_passes`].
#[derive(Clone, Debug)]
pub struct Passes {
    /// Wall-clock seconds of each timed pass, in order.
    pub seconds: Vec<f64>,
    /// The median pass (seconds) with the set's size and hits.
    pub median: Measurement,
}

/// Runs `timed` over `rays` once to warm up (caches, page faults, the thread's workspace), then
/// `passes` more times (at least once), timing each; reports every pass and the median.
pub fn measure_passes(rays: &[Ray], passes: usize, timed: &mut impl Timed) -> Passes {
    timed.answer(black_box(rays));
    let seconds: Vec<f64> = (0..passes.max(1)).map(|_| time_pass(rays, timed)).collect();
    let hits = timed.hits();
    let mut sorted = seconds.clone();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    let median = if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        (sorted[mid - 1] + sorted[mid]) / 2.0
    };
    Passes {
        seconds,
        median: Measurement {
            seconds: median,
            rays: rays.len(),
            hits,
        },
    }
}

/// Milliseconds taken by `f`, and its result.
pub fn time_ms<R>(f: impl FnOnce() -> R) -> (R, f64) {
    let start = Instant::now();
    let result = f();
    (result, start.elapsed().as_secs_f64() * 1e3)
}
