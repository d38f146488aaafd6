//! The batch's active rays, and the one-box-many-rays test with move-to-front partitioning.
//!
//! Each lane holds only what the box test reads (origin, inverse direction, current range end
//! and the ray's index in the batch) in 32 bytes, so moving a ray during the partition is one
//! 32-byte copy. The partition moves the ray data itself rather than indices into it, so the
//! next box test streams through contiguous memory. The triangle kernels, which run far less
//! often, read the full per-ray constants (`PreparedRay`) by index, which keeps them the very
//! functions the single-ray path runs.

use glam::Vec3A;

use crate::geom::Aabb;
use crate::geom::PreparedRay;

/// Same constant as the single-ray test (see [`crate::geom::aabb`]).
const EXIT_SCALE: f32 = 1.000_000_4;

/// One active ray, as the box test sees it.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub(crate) struct Lane {
    pub origin: [f32; 3],
    /// Current upper end of the range: the best hit so far for closest-hit queries, `-inf`
    /// once an any-hit ray is answered (so every later box test drops it).
    pub tmax: f32,
    pub inv_dir: [f32; 3],
    /// Index of the ray in the batch.
    pub id: u32,
}

/// The active rays of one batch chunk.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lanes {
    pub lanes: Vec<Lane>,
    /// Scratch: where the partition writes before copying back.
    spare: Vec<Lane>,
}

impl Lanes {
    pub fn clear(&mut self) {
        self.lanes.clear();
        self.spare.clear();
    }

    pub fn push(&mut self, ray: &PreparedRay, id: u32) {
        self.lanes.push(Lane {
            origin: ray.origin.to_array(),
            tmax: ray.tmax,
            inv_dir: ray.inv_dir.to_array(),
            id,
        });
        self.spare.push(Lane::default());
    }

    /// Tests lanes `start..end` against `bounds` and moves the rays that touch it to the front
    /// of the range (the seed's move-to-front); returns how many touch it. The set of rays in
    /// the range is unchanged, only their order.
    ///
    /// The move is branch-free (the box test's outcome is unpredictable for incoherent rays):
    /// every lane is written both at the next front slot and at the next back slot of a spare
    /// buffer, and only one of the two cursors advances; the spare is then copied back.
    pub fn partition(&mut self, bounds: &Aabb, start: usize, end: usize) -> usize {
        let lanes = &mut self.lanes[start..end];
        let spare = &mut self.spare[..lanes.len()];
        let (min, max) = (Vec3A::from(bounds.min), Vec3A::from(bounds.max));
        let (mut front, mut back) = (0, lanes.len());
        for lane in lanes.iter() {
            let hit = lane_hits_box(min, max, lane) as usize;
            spare[front] = *lane;
            spare[back - 1] = *lane;
            front += hit;
            back -= 1 - hit;
        }
        lanes.copy_from_slice(spare);
        front
    }
}

/// The conservative slab test of one lane: same arithmetic and NaN handling as
/// [`crate::geom::aabb::box_entry`], except that the range starts at 0 rather than the ray's
/// `tmin`. Rays have `tmin >= 0`, so this only lets a few more boxes through (conservative)
/// and keeps the lane at 32 bytes.
#[inline(always)]
pub(crate) fn lane_hits_box(min: Vec3A, max: Vec3A, lane: &Lane) -> bool {
    let origin = Vec3A::from_array(lane.origin);
    let inv = Vec3A::from_array(lane.inv_dir);
    let negative = inv.cmplt(Vec3A::ZERO);
    let near_plane = Vec3A::select(negative, max, min);
    let far_plane = Vec3A::select(negative, min, max);
    let enter = (near_plane - origin) * inv;
    let exit = (far_plane - origin) * inv * EXIT_SCALE;
    let lo = Vec3A::ZERO;
    let hi = Vec3A::splat(lane.tmax.min(f32::MAX));
    let near = Vec3A::select(enter.cmpgt(lo), enter, lo).max_element();
    let far = Vec3A::select(exit.cmplt(hi), exit, hi).min_element();
    near <= far
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{PreparedRay, Ray};
    use glam::Vec3;

    #[test]
    fn lane_test_matches_single_ray_test_and_partition_keeps_the_set() {
        let mut lanes = Lanes::default();
        let mut x = 0x9e37_79b9u32;
        let mut rnd = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32) * 4.0 - 2.0
        };
        let mut rays = Vec::new();
        for i in 0..1000u32 {
            let mut d = Vec3::new(rnd(), rnd(), rnd());
            // Zero components of both signs and grazing origins.
            if i % 5 == 0 {
                d.x = if i % 10 == 0 { 0.0 } else { -0.0 };
            }
            let mut o = Vec3::new(rnd(), rnd(), rnd());
            if i % 7 == 0 {
                o.y = 0.5;
            }
            let ray = PreparedRay::new(&Ray::with_range(o, d, 0.0, rnd().abs() * 3.0)).unwrap();
            lanes.push(&ray, i);
            rays.push(ray);
        }
        let bounds = Aabb::new(Vec3::splat(-0.5), Vec3::splat(0.5));
        let hits = lanes.partition(&bounds, 0, rays.len());
        let expected: Vec<bool> = rays.iter().map(|r| bounds.hit_by(r, r.tmax)).collect();
        assert_eq!(hits, expected.iter().filter(|&&h| h).count());
        let mut ids: Vec<u32> = lanes.lanes.iter().map(|l| l.id).collect();
        for (k, &id) in ids.iter().enumerate() {
            assert_eq!(k < hits, expected[id as usize], "ray {id}");
        }
        ids.sort_unstable();
        assert!(ids.iter().copied().eq(0..rays.len() as u32));
    }
}
