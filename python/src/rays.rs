//! Rays as NumPy gives them, `(N, 6)` float32 rows of origin and direction read in place, with
//! the range `[tnear, tfar]` for all rays or per ray, turned into the library's [`Ray`] a
//! block at a time and checked: a ray that can hit nothing is refused by its index instead of
//! missing (Python callers asked for `ValueError` on NaN input).

use std::sync::atomic::{AtomicUsize, Ordering};

use raybatch::Ray;
use raybatch::glam::Vec3;
use rayon::prelude::*;

/// Rays converted at once: 32 MiB of [`Ray`]s, whatever the input's size.
const BLOCK: usize = 1 << 20;
/// Rays per task of a block's conversion.
const CHUNK: usize = 4096;

/// One end of the rays' range: one value for all, or one per ray.
#[derive(Clone, Copy)]
pub enum Limit<'a> {
    /// The same for every ray.
    All(f32),
    /// `values[i]` for ray `i`.
    PerRay(&'a [f32]),
}

impl Limit<'_> {
    fn at(self, i: usize) -> f32 {
        match self {
            Limit::All(t) => t,
            Limit::PerRay(values) => values[i],
        }
    }
}

/// A batch of rays: `flat` holds six floats per ray.
pub struct Rays<'a> {
    flat: &'a [f32],
    tnear: Limit<'a>,
    tfar: Limit<'a>,
}

impl<'a> Rays<'a> {
    /// The rays of `flat` (origin and direction, six floats each) over `[tnear, tfar]`;
    /// an error if the lengths disagree.
    pub fn new(flat: &'a [f32], tnear: Limit<'a>, tfar: Limit<'a>) -> Result<Self, String> {
        if !flat.len().is_multiple_of(6) {
            return Err(format!("{} floats are not rows of 6", flat.len()));
        }
        let count = flat.len() / 6;
        for (name, limit) in [("tnear", tnear), ("tfar", tfar)] {
            if let Limit::PerRay(values) = limit
                && values.len() != count
            {
                let given = values.len();
                return Err(format!("{name} has {given} values for {count} rays"));
            }
        }
        Ok(Self { flat, tnear, tfar })
    }

    /// The number of rays.
    pub fn len(&self) -> usize {
        self.flat.len() / 6
    }

    /// Ray `i`.
    fn ray(&self, i: usize) -> Ray {
        let f = &self.flat[6 * i..6 * i + 6];
        let origin = Vec3::new(f[0], f[1], f[2]);
        let dir = Vec3::new(f[3], f[4], f[5]);
        Ray::with_range(origin, dir, self.tnear.at(i), self.tfar.at(i))
    }

    /// Calls `f(start, rays)` on consecutive blocks of the rays (`rays[k]` is ray `start + k`),
    /// each converted into `block` on the current pool and checked first: the first ray that
    /// can hit nothing stops the walk with its index and reason (`Ray::validate`).
    pub fn for_each_block(
        &self,
        block: &mut Vec<Ray>,
        mut f: impl FnMut(usize, &[Ray]),
    ) -> Result<(), String> {
        for start in (0..self.len()).step_by(BLOCK) {
            let end = (start + BLOCK).min(self.len());
            block.clear();
            // Written in place by the pool's threads, each ray checked as it is made (one
            // pass over the block, none by one thread alone); the lowest bad index wins.
            let first_bad = AtomicUsize::new(usize::MAX);
            let rays = (start..end).into_par_iter().with_min_len(CHUNK);
            block.par_extend(rays.map(|i| {
                let ray = self.ray(i);
                if !ray.is_valid() {
                    first_bad.fetch_min(i, Ordering::Relaxed);
                }
                ray
            }));
            let first_bad = first_bad.into_inner();
            if first_bad != usize::MAX
                && let Err(why) = block[first_bad - start].validate()
            {
                return Err(format!("ray {first_bad}: {why}"));
            }
            f(start, block);
        }
        Ok(())
    }
}
