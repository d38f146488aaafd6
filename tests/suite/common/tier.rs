//! How much of a heavy case a test runs: a deterministic sample in the default run (`cargo
//! test --release`), all of it in the ignored tier (`cargo test --release -- --ignored`, which
//! `.ci/run` also runs). A heavy test is written once, taking a [`Tier`], and called by two
//! tests: the sample, and the full case marked `#[ignore]`.

/// The sample or the whole case.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tier {
    Sample,
    Full,
}

impl Tier {
    /// `sample` in the default run, `full` in the ignored tier.
    pub fn pick<T>(self, sample: T, full: T) -> T {
        match self {
            Tier::Sample => sample,
            Tier::Full => full,
        }
    }
}
