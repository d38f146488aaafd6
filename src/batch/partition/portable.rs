//! The portable partition: one ray per step, safe code, branch-free.

use super::EXIT_SCALE;
use crate::batch::lanes::{COLUMNS, IX, IY, IZ, Lanes, OX, OY, OZ, TMAX};
use crate::geom::Aabb;

/// The slab test of one ray (see [`crate::geom::aabb::box_entry`]); a NaN slab (an axis the
/// ray grazes) fails both comparisons and leaves the range alone.
#[inline(always)]
pub(crate) fn lane_hits_box(bounds: &Aabb, o: [f32; 3], inv: [f32; 3], tmax: f32) -> bool {
    let mut near = 0.0f32;
    let mut far = tmax.min(f32::MAX);
    for axis in 0..3 {
        let t0 = (bounds.min[axis] - o[axis]) * inv[axis];
        let t1 = (bounds.max[axis] - o[axis]) * inv[axis];
        let negative = inv[axis] < 0.0;
        let enter = if negative { t1 } else { t0 };
        let exit = (if negative { t0 } else { t1 }) * EXIT_SCALE;
        near = if enter > near { enter } else { near };
        far = if exit < far { exit } else { far };
    }
    near <= far
}

/// Write cursors of a partition in progress: the next front slot (absolute lane index) and the
/// number of rays parked in the spare columns.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cursors {
    pub front: usize,
    pub missed: usize,
}

/// Partitions lanes `from..to` one ray at a time, continuing from `cursors`.
pub(crate) fn partition_lanes(
    lanes: &mut Lanes,
    bounds: &Aabb,
    from: usize,
    to: usize,
    mut cursors: Cursors,
) -> Cursors {
    let f = |c: &Vec<u32>, i: usize| f32::from_bits(c[i]);
    for i in from..to {
        let c = &lanes.cols;
        let hit = lane_hits_box(
            bounds,
            [f(&c[OX], i), f(&c[OY], i), f(&c[OZ], i)],
            [f(&c[IX], i), f(&c[IY], i), f(&c[IZ], i)],
            f(&c[TMAX], i),
        ) as usize;
        for k in 0..COLUMNS {
            let v = lanes.cols[k][i];
            lanes.cols[k][cursors.front] = v;
            lanes.spare[k][cursors.missed] = v;
        }
        cursors.front += hit;
        cursors.missed += 1 - hit;
    }
    cursors
}

/// Copies the parked rays back behind the touching ones; returns how many touch the box.
pub(crate) fn finish(lanes: &mut Lanes, start: usize, end: usize, cursors: Cursors) -> usize {
    debug_assert_eq!(cursors.front + cursors.missed, end);
    for k in 0..COLUMNS {
        lanes.cols[k][cursors.front..end].copy_from_slice(&lanes.spare[k][..cursors.missed]);
    }
    cursors.front - start
}

pub(crate) fn partition(lanes: &mut Lanes, bounds: &Aabb, start: usize, end: usize) -> usize {
    let cursors = Cursors {
        front: start,
        missed: 0,
    };
    let cursors = partition_lanes(lanes, bounds, start, end, cursors);
    finish(lanes, start, end, cursors)
}
