//! The one random generator of the integration tests.
//!
//! Every random number a test draws (outside proptest's own generator) comes from [`seeded`],
//! so a test is reproducible from the seed written in it. The helpers below draw `x`, `y`, `z`
//! in that order, one `random_range` each, exactly as
//! `Vec3::new(rng.random_range(..), rng.random_range(..), rng.random_range(..))` does, so a
//! seed gives the same numbers either way.

use glam::Vec3;
pub use rand::rngs::StdRng;
pub use rand::seq::SliceRandom;
pub use rand::{RngExt, SeedableRng};

/// The seeded generator (`StdRng` from `seed`).
pub fn seeded(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// A point uniform in the cube `[-r, r)^3`.
pub fn in_cube(rng: &mut StdRng, r: f32) -> Vec3 {
    Vec3::new(
        rng.random_range(-r..r),
        rng.random_range(-r..r),
        rng.random_range(-r..r),
    )
}

/// A point uniform in the box `[min, max)`.
pub fn in_box(rng: &mut StdRng, min: Vec3, max: Vec3) -> Vec3 {
    Vec3::new(
        rng.random_range(min.x..max.x),
        rng.random_range(min.y..max.y),
        rng.random_range(min.z..max.z),
    )
}

/// A random permutation of `0..n` (a shuffle with [`seeded`]`(seed)`).
pub fn permutation(n: usize, seed: u64) -> Vec<usize> {
    let mut perm: Vec<usize> = (0..n).collect();
    perm.shuffle(&mut seeded(seed));
    perm
}
