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
#[allow(unsafe_code)]
mod avx2;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod avx512;
pub(crate) mod portable;

use super::lanes::Lanes;
use crate::geom::Aabb;
pub(crate) use crate::geom::aabb::EXIT_SCALE;

/// An implementation of the partition; all give identical results.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartitionKernel {
    /// 16 rays per step with AVX-512F compress (x86-64 CPUs with AVX-512F).
    Avx512,
    /// 8 rays per step with an AVX2 permute table (x86-64 CPUs with AVX2).
    Avx2,
    /// One ray per step, safe code (every CPU).
    Portable,
}

impl PartitionKernel {
    /// Every implementation, fastest first.
    pub const ALL: [PartitionKernel; 3] = [
        PartitionKernel::Avx512,
        PartitionKernel::Avx2,
        PartitionKernel::Portable,
    ];

    /// The fastest implementation this CPU supports.
    pub fn detect() -> Self {
        Self::ALL
            .into_iter()
            .find(|k| k.is_supported())
            .unwrap_or(PartitionKernel::Portable)
    }

    /// True if this CPU has the instructions the implementation needs.
    pub fn is_supported(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            PartitionKernel::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(target_arch = "x86_64")]
            PartitionKernel::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            PartitionKernel::Portable => true,
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }

    /// Short name for tables.
    pub fn name(self) -> &'static str {
        match self {
            PartitionKernel::Avx512 => "avx512",
            PartitionKernel::Avx2 => "avx2",
            PartitionKernel::Portable => "portable",
        }
    }

    /// This implementation if the CPU supports it, else the portable one: the check is made
    /// here, once per batched call, and never in the partition loop.
    pub(crate) fn checked(self) -> Partitioner {
        if self.is_supported() {
            Partitioner(self)
        } else {
            Partitioner(PartitionKernel::Portable)
        }
    }
}

/// A partition implementation this CPU is known to support (made by
/// [`PartitionKernel::checked`], the only constructor).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Partitioner(PartitionKernel);

impl Partitioner {
    /// Tests lanes `start..end` against `bounds`, moves the rays that touch it to the front
    /// (stably) and returns how many there are.
    #[inline]
    #[allow(unsafe_code)]
    pub(crate) fn run(self, lanes: &mut Lanes, bounds: &Aabb, start: usize, end: usize) -> usize {
        match self.0 {
            // SAFETY: a `Partitioner` holds a vector kernel only if the CPU supports it.
            #[cfg(target_arch = "x86_64")]
            PartitionKernel::Avx512 => unsafe { avx512::partition(lanes, bounds, start, end) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            PartitionKernel::Avx2 => unsafe { avx2::partition(lanes, bounds, start, end) },
            _ => portable::partition(lanes, bounds, start, end),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{PreparedRay, Ray};
    use crate::test_support::TestRng;
    use glam::Vec3;
    use std::io::Write;

    fn random_lanes(n: usize, seed: u32) -> (Lanes, Vec<PreparedRay>) {
        let mut lanes = Lanes::default();
        lanes.reset(n);
        let mut rng = TestRng::new(seed as u64);
        let mut rnd = || rng.range(-2.0, 2.0);
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
        for k in PartitionKernel::ALL {
            if !k.is_supported() {
                // Written to stderr directly so the test harness shows it even on success.
                let _ = writeln!(
                    std::io::stderr(),
                    "note: this CPU lacks {}: its test compares the portable kernel with itself",
                    k.name()
                );
            }
        }
        let bounds = Aabb::new(Vec3::splat(-0.5), Vec3::new(0.5, 0.5, 0.7));
        for n in [0, 1, 7, 8, 15, 16, 17, 100, 1000] {
            let (reference, rays) = random_lanes(n, 0x9e37_79b9 ^ n as u32);
            let mut expected = reference.clone();
            let count = portable::partition(&mut expected, &bounds, 0, n);
            for k in PartitionKernel::ALL.map(PartitionKernel::checked) {
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
