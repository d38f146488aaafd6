//! The batch's active rays as an array of [`PreparedRay`]s: the stream layout of structures that
//! walk rays by index ([`crate::accel::StreamLayout::Records`]).
//!
//! The lanes ([`super::lanes`]) pay for their structure-of-arrays form at every step of a
//! binary tree's move-to-front partition; a structure that never partitions (the 4-wide tree
//! keeps index lists, the grids and the kd-tree take one ray at a time) only needs each ray's
//! constants in one place. Here a ray is one 64-byte record, written once when the batch is
//! grouped and read in place by the traversal, with no copy to or from sixteen columns.

use crate::geom::sign_filter::RayQuad;
use crate::geom::{Aabb, PreparedRay, Ray};

/// Prepared rays and each one's position in the caller's batch (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct PreparedRays {
    pub(crate) rays: Vec<PreparedRay>,
    pub(crate) ids: Vec<u32>,
}

impl PreparedRays {
    /// Makes room for `n` rays. Only grows: the records past the batch's end are never read,
    /// so a steady stream of calls writes each record once and never clears them.
    pub(crate) fn reserve_slots(&mut self, n: usize) {
        if self.rays.len() < n {
            let placeholder = PreparedRay::from_valid(&Ray::new(glam::Vec3::ZERO, glam::Vec3::X));
            self.rays.resize(n, placeholder);
            self.ids.resize(n, 0);
        }
    }

    /// Puts `ray` (batch position `id`) in slot `slot`.
    #[inline(always)]
    pub(crate) fn set(&mut self, slot: usize, ray: PreparedRay, id: u32) {
        self.rays[slot] = ray;
        self.ids[slot] = id;
    }

    /// The sign-filter constants of the rays in slots `slot..slot + 4`.
    pub(crate) fn quad(&self, slot: usize) -> RayQuad {
        let rays: &[PreparedRay; 4] = self.rays[slot..slot + 4].try_into().unwrap();
        RayQuad::from_rays(rays.each_ref())
    }

    /// Moves the rays of slots `start..end` that touch `bounds` (the conservative slab test at
    /// each ray's current range end) to the front of the range, keeping their order, and
    /// returns how many there are.
    pub(crate) fn partition(&mut self, bounds: &Aabb, start: usize, end: usize) -> usize {
        let mut front = start;
        for slot in start..end {
            let ray = &self.rays[slot];
            if bounds.hit_by(ray, ray.tmax) {
                self.rays.swap(front, slot);
                self.ids.swap(front, slot);
                front += 1;
            }
        }
        front - start
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::batch::lanes::Lanes;
    use crate::batch::partition::portable;
    use crate::test_support::TestRng;
    use glam::Vec3;

    /// The same random rays (zero direction components of both signs, retired rays) in lanes
    /// and in records.
    fn both_layouts(n: usize, seed: u64) -> (Lanes, PreparedRays) {
        let (mut lanes, mut records) = (Lanes::default(), PreparedRays::default());
        lanes.reset(n);
        records.reserve_slots(n);
        let mut rng = TestRng::new(seed);
        for i in 0..n {
            let mut dir = rng.vec3(2.0);
            if i % 5 == 0 {
                dir.x = if i % 10 == 0 { 0.0 } else { -0.0 };
            }
            let tmax = if i % 11 == 0 {
                f32::INFINITY
            } else {
                rng.range(0.0, 6.0)
            };
            let mut ray = PreparedRay::new(&Ray::with_range(rng.vec3(2.0), dir, 0.0, tmax))
                .expect("a valid ray");
            if i % 13 == 0 {
                ray.tmax = f32::NEG_INFINITY;
            }
            lanes.set(i, &ray, i as u32);
            records.set(i, ray, i as u32);
        }
        (lanes, records)
    }

    /// Records partition like the lanes do: the same rays in front, in the same order.
    #[test]
    fn partition_matches_the_lanes() {
        let bounds = Aabb::new(Vec3::splat(-0.5), Vec3::new(0.5, 0.5, 0.7));
        for n in [0, 1, 7, 100, 1000] {
            let (mut lanes, mut records) = both_layouts(n, 7 + n as u64);
            let (start, end) = (n / 4, n - n / 4);
            let count = records.partition(&bounds, start, end);
            assert_eq!(count, portable::partition(&mut lanes, &bounds, start, end));
            for slot in start..start + count {
                assert_eq!(records.ids[slot], lanes.id(slot), "n={n}, slot {slot}");
            }
            // The rays outside the range stay where they were.
            for slot in (0..start).chain(end..n) {
                assert_eq!(records.ids[slot], slot as u32);
            }
        }
    }

    /// The sign-filter constants of four records are those of the same four lanes.
    #[test]
    fn quads_match_the_lanes() {
        let (lanes, records) = both_layouts(64, 3);
        for slot in 0..60 {
            let (a, b) = (records.quad(slot), lanes.quad(slot));
            assert_eq!(a.origin, b.origin);
            assert_eq!((a.shear_x, a.shear_y), (b.shear_x, b.shear_y));
            assert_eq!(a.kz_is_x.bitmask(), b.kz_is_x.bitmask());
            assert_eq!(a.kz_is_y.bitmask(), b.kz_is_y.bitmask());
        }
    }
}
