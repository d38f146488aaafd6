//! One box against many rays, with move-to-front: the inner loop of batched traversal.
//!
//! `partition` tests the rays in lanes `start..end` against a box and leaves the ones that
//! touch it at the front of the range, in their original order, followed by the others, also in
//! order (a stable partition: every implementation below produces the same lane order, which
//! keeps them easy to compare). Rays that touch the box are written forward in place (the
//! write cursor never passes the read cursor); the others are parked in a spare buffer and
//! copied back behind them. There are no data-dependent branches: the outcome of a box test is
//! unpredictable for incoherent rays.
//!
//! Three implementations, picked at run time:
//! - `avx512`: 16 rays per step, compress-stores write the touching rays forward.
//! - `avx2`: 8 rays per step, the compress is a permute from a 256-entry lookup table.
//! - `portable`: one ray per step, safe code; used on other CPUs (and tested against the
//!   others).
//!
//! All use the same arithmetic as the single-ray slab test ([`crate::geom::aabb`]), in the same
//! order and without FMA, so they agree bit for bit; the range starts at 0 rather than the
//! ray's `tmin`, which only lets more boxes through (rays have `tmin >= 0`).

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
mod portable;

use super::lanes::Lanes;
use crate::geom::Aabb;

/// Same constant as the single-ray test (see [`crate::geom::aabb`]).
pub(crate) const EXIT_SCALE: f32 = 1.000_000_4;

/// Which implementation `partition` uses on this CPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartitionKernel {
    Avx512,
    Avx2,
    Portable,
}

impl PartitionKernel {
    /// The fastest implementation this CPU supports.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return PartitionKernel::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return PartitionKernel::Avx2;
            }
        }
        PartitionKernel::Portable
    }

    pub fn name(self) -> &'static str {
        match self {
            PartitionKernel::Avx512 => "avx512",
            PartitionKernel::Avx2 => "avx2",
            PartitionKernel::Portable => "portable",
        }
    }

    /// Runs this implementation. Falls back to the portable one if the CPU lacks the
    /// instructions, so it is safe to call with any value.
    pub(crate) fn run(self, lanes: &mut Lanes, bounds: &Aabb, start: usize, end: usize) -> usize {
        debug_assert!(start <= end && end <= lanes.len());
        match self {
            #[cfg(target_arch = "x86_64")]
            PartitionKernel::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
                avx512::partition(lanes, bounds, start, end)
            }
            #[cfg(target_arch = "x86_64")]
            PartitionKernel::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
                avx2::partition(lanes, bounds, start, end)
            }
            _ => portable::partition(lanes, bounds, start, end),
        }
    }
}

/// Tests lanes `start..end` against `bounds`, moves the rays that touch it to the front (stably)
/// and returns how many there are.
#[inline]
pub(crate) fn partition(
    kernel: PartitionKernel,
    lanes: &mut Lanes,
    bounds: &Aabb,
    start: usize,
    end: usize,
) -> usize {
    kernel.run(lanes, bounds, start, end)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{PreparedRay, Ray};
    use glam::Vec3;

    fn random_lanes(n: usize, seed: u32) -> (Lanes, Vec<PreparedRay>) {
        let mut lanes = Lanes::default();
        lanes.reset(n);
        let mut x = seed | 1;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32) * 4.0 - 2.0
        };
        let mut rays = Vec::new();
        for i in 0..n as u32 {
            let mut d = Vec3::new(rnd(), rnd(), rnd());
            // Zero components of both signs, grazing origins, retired rays.
            if i % 5 == 0 {
                d.x = if i % 10 == 0 { 0.0 } else { -0.0 };
            }
            let mut o = Vec3::new(rnd(), rnd(), rnd());
            if i % 7 == 0 {
                o.y = 0.5;
            }
            let tmax = if i % 11 == 0 {
                f32::INFINITY
            } else {
                rnd().abs() * 3.0
            };
            let ray = PreparedRay::new(&Ray::with_range(o, d, 0.0, tmax)).unwrap();
            lanes.set(i as usize, &ray, i);
            if i % 13 == 0 {
                lanes.set_tmax(i as usize, f32::NEG_INFINITY);
            }
            rays.push(ray);
        }
        (lanes, rays)
    }

    #[test]
    fn every_kernel_matches_the_single_ray_test_and_each_other() {
        let bounds = Aabb::new(Vec3::splat(-0.5), Vec3::new(0.5, 0.5, 0.7));
        for n in [0, 1, 7, 8, 15, 16, 17, 100, 1000] {
            let (reference, rays) = random_lanes(n, 0x9e37_79b9 ^ n as u32);
            let mut expected = reference.clone();
            let count = portable::partition(&mut expected, &bounds, 0, n);
            for k in [
                PartitionKernel::Avx512,
                PartitionKernel::Avx2,
                PartitionKernel::Portable,
            ] {
                let mut lanes = reference.clone();
                // A sub-range, to check that lanes outside it are left alone.
                let (s, e) = (n / 4, n - n / 4);
                let mut sub_expected = reference.clone();
                let sub = portable::partition(&mut sub_expected, &bounds, s, e);
                assert_eq!(k.run(&mut lanes, &bounds, s, e), sub, "{k:?} n={n}");
                assert_eq!(lanes.cols, sub_expected.cols, "{k:?} n={n}");
                let mut lanes = reference.clone();
                assert_eq!(k.run(&mut lanes, &bounds, 0, n), count, "{k:?} n={n}");
                assert_eq!(lanes.cols, expected.cols, "{k:?} n={n}");
            }
            for lane in 0..n {
                let id = expected.id(lane) as usize;
                let tmax = reference.tmax(id);
                let hit = bounds.hit_by(&rays[id], tmax);
                assert_eq!(lane < count, hit, "ray {id}");
            }
        }
    }
}
