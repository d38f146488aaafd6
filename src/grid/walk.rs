//! The 3D-DDA walk (the classic `t_exit` / `delta t` stepping), made exact: it visits every
//! cell the conservative box test would let a hit through, in order of entry distance.
//!
//! **Per axis.** Along one axis the ray crosses slabs `[p_i, p_(i+1)]` (the stored planes of
//! [`Planes`]). Slab `i` is *active* from its entry distance `enter = (near plane - o) * inv`
//! to its exit distance `leave = (far plane - o) * inv * EXIT_SCALE`: the very formulas, in the
//! same order and rounding, of the slab test in [`crate::geom::aabb`]. The classic walk steps
//! from one slab to the next at one `t_exit`; this one keeps a *range* of active slabs, which
//! is one slab except within a few ulps of a plane, where the next slab has been entered
//! (`enter`, unscaled) and the previous one not yet left (`leave`, scaled up). A cell is
//! visited when its last axis becomes active while the others still are: exactly the cells
//! whose conservative box test passes for some `t` in the ray's range.
//!
//! **Why no hit is missed.** The kernels report a hit on a triangle only if the slab test of
//! the triangle's own box passes, at a `t` no smaller than the box's entry distance `t*`
//! (`agree_with_bounds` in [`crate::geom::triangle`]). The triangle is stored in every cell
//! of a block whose planes enclose its box (`at(first) <= min`, `at(last + 1) >= max`). The
//! rounded distances are monotone in the plane coordinate, so along each axis the active
//! intervals of the block's slabs (which overlap, since `leave >= enter` for `t >= 0`) cover
//! the box's interval, which holds `t*`. So at `t*` some cell of the block has every axis
//! active: it is visited, at an entry distance `<= t* <= t`.
//!
//! **Early exit and the tie rule.** Cells are entered in order of entry distance, and the walk
//! stops when the next entry is *strictly* beyond the range end the visitor keeps (the best
//! `t` so far for a closest hit): a triangle hit at exactly the best `t`, with a lower id, has
//! its `t* <= t`, so its cell is entered at or before the best `t` and is still visited.
//!
//! **The lean loop.** Almost every step leaves a single new cell: the slab left behind is
//! gone before the next entry. `Walk::single_cells` walks those steps keeping only the
//! front slabs, the index, the next entries and the last scaled exit; the first entry at or
//! before that exit hands the walk back to the range bookkeeping, with the lag written out as
//! it would have kept it, so both visit the same cells in the same order.
//!
//! **Robustness.** An axis the ray runs parallel to (`inv_dir` infinite, where `0 * inf` would
//! be NaN) has no events: its active slabs are those holding the origin's coordinate (two
//! when the origin lies on a plane, which is the box test's "grazing counts as touching").
//! Distances that overflow are infinite and compare as such; a ray starting inside the grid,
//! outside it, at `tmin > 0` or ending at a finite `tmax` only changes where the walk starts
//! (the grid's own entry distance) and ends.

use glam::Vec3;

use crate::geom::aabb::{EXIT_SCALE, SlabRay};
use crate::geom::{Aabb, PreparedRay};
use crate::hit::RAY_DONE;

use super::planes::Planes;

/// The three axes' planes of a grid.
pub(crate) type GridPlanes = [Planes; 3];

/// The box the planes of a grid span.
pub(crate) fn bounds(planes: &GridPlanes) -> Aabb {
    let [x, y, z] = planes.each_ref().map(|p| {
        let at = p.planes();
        (at[0], at[at.len() - 1])
    });
    Aabb::new(Vec3::new(x.0, y.0, z.0), Vec3::new(x.1, y.1, z.1))
}

/// A cell the walk visits: its slab indices `[x, y, z]` and its linear index
/// `x + nx * (y + ny * z)` (kept up to date step by step, so visitors need not compute it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Cell {
    pub(crate) slabs: [u32; 3],
    pub(crate) index: u64,
}

/// The linear index of cell `slabs` of a grid of `planes`.
#[inline(always)]
pub(crate) fn linear_index(planes: &GridPlanes, slabs: [u32; 3]) -> u64 {
    let [x, y, z] = slabs.map(u64::from);
    let [nx, ny] = [0, 1].map(|a| u64::from(planes[a].slabs()));
    x + nx * (y + ny * z)
}

/// Walks `ray` through the cells of `planes` in order of entry distance, calling
/// `visit(cell, tmax)` once for every cell ([`Cell`]) that may hold a hit in
/// `[ray.tmin, *tmax]` (see the module docs). `visit` may shrink `*tmax` (the walk then stops
/// earlier) or set it to [`RAY_DONE`] (the walk stops at once).
#[inline(always)]
pub(crate) fn walk(
    planes: &GridPlanes,
    ray: &PreparedRay,
    tmax: &mut f32,
    mut visit: impl FnMut(Cell, &mut f32),
) {
    // (Built in place and started, rather than returned as an `Option`: the state is a few
    // hundred bytes, and moving it out of the option cost two copies per ray.)
    let mut w = Walk::new(planes, ray);
    if !w.start(planes, ray, *tmax) {
        return;
    }
    // The axis whose slab was just entered: only the cells in that slab are new (3: none, at
    // the start, where every active cell is new).
    let mut entered = 3;
    loop {
        // (A visitor that ends the ray sets `tmax` to RAY_DONE, -inf: the steps stop.)
        if w.lagging & !(1u32 << entered) == 0 {
            // One new cell: the usual case, walked by the lean loop until it is not.
            if !w.single_cells(entered, tmax, &mut visit) {
                return;
            }
        } else {
            w.visit_range(entered, tmax, &mut visit);
        }
        let a = w.next_axis();
        let te = w.next_enter[a];
        if te > w.end(*tmax) {
            return;
        }
        if te > w.lag_until {
            // Every slab left behind is left before `te` (the usual case, unless two planes
            // are crossed within a few ulps of each other; nothing to do if none lags).
            w.back = w.front;
            w.lagging = 0;
        } else {
            w.leave_before(te);
        }
        w.enter_next(a, te);
        entered = a;
    }
}

/// The axis whose next entry distance `next[axis]` comes first, and that distance (the lowest
/// axis on ties, so that the order of visits is deterministic).
#[inline(always)]
fn first_entry(next: [f32; 3]) -> (usize, f32) {
    let [x, y, z] = next;
    if x <= y && x <= z {
        (0, x)
    } else if y <= z {
        (1, y)
    } else {
        (2, z)
    }
}

/// The walk's state, axis by axis (arrays indexed by axis, so that a step is a few loads and
/// compares). Slabs are slab indices; the ray meets them in the order `s, s + step, ...`, and
/// the plane between slab `s` and the next one it meets is `at[s + fwd]`: it is where the ray
/// leaves `s` and enters the next. Slabs from `back` to `front` (in the ray's order) are
/// active.
struct Walk<'a> {
    at: [&'a [f32]; 3],
    origin: [f32; 3],
    inv: [f32; 3],
    /// 1 if the ray goes up the axis (or runs parallel to it), 0 if it goes down.
    fwd: [u32; 3],
    /// `+1` going up, `-1` (wrapping) going down.
    step: [u32; 3],
    /// The last slab the ray meets along the axis.
    last: [u32; 3],
    back: [u32; 3],
    front: [u32; 3],
    /// The linear index of the cell of the `front` slabs ([`linear_index`]), what one slab
    /// along each axis adds to it, and how it changes when `front` moves by `step` (wrapping:
    /// a negative change is added as its two's complement).
    index: u64,
    stride: [u64; 3],
    index_step: [u64; 3],
    /// Entry distance of the slab after `front` (`+inf` if none, or if the ray is parallel).
    next_enter: [f32; 3],
    /// Exit distance of slab `back`, while `back != front` (see `lagging`).
    next_leave: [f32; 3],
    /// Bit `i` set if axis `i` has more than one active slab (`back != front`): the slab just
    /// left stays active for a few ulps after the next one is entered (the box test scales
    /// exit distances up), so after each step the axis stepped on lags until the next step.
    lagging: u32,
    /// Per axis, the exit distance of the slab before `front` (`+inf` on a parallel axis that
    /// keeps two slabs); only read for lagging axes.
    lag_end: [f32; 3],
    /// The largest `lag_end` of the lagging axes: once a slab is entered beyond it, no axis
    /// keeps more than its front slab. When none lags, no more than the next entry distance
    /// (`-inf` at the start; after the lags are dropped at `te`, the old value, below `te`),
    /// so that the next step's `lag_end` takes its place.
    lag_until: f32,
    /// Where the ray leaves the grid (capped to `f32::MAX`: hits have finite `t`, as in the
    /// box test, so `+inf` entries end the walk).
    far: f32,
}

impl<'a> Walk<'a> {
    /// The state before [`Walk::start`]: every axis forward, one slab, nothing lagging.
    #[inline(always)]
    fn new(planes: &'a GridPlanes, ray: &PreparedRay) -> Self {
        Walk {
            at: [0, 1, 2].map(|i| planes[i].planes()),
            origin: ray.origin.to_array(),
            inv: ray.inv_dir.to_array(),
            fwd: [1; 3],
            step: [1; 3],
            last: [0; 3],
            back: [0; 3],
            front: [0; 3],
            index: 0,
            stride: [0; 3],
            index_step: [0; 3],
            next_enter: [f32::INFINITY; 3],
            next_leave: [f32::INFINITY; 3],
            lagging: 0,
            lag_end: [f32::INFINITY; 3],
            lag_until: f32::NEG_INFINITY,
            far: f32::MAX,
        }
    }

    /// Sets the state to the grid's entry distance; false if the ray misses the grid in
    /// `[ray.tmin, tmax]`.
    #[inline(always)]
    fn start(&mut self, planes: &GridPlanes, ray: &PreparedRay, tmax: f32) -> bool {
        let w = self;
        // The grid's own slab test, three axes at once. On an axis the ray runs parallel to,
        // the distances are `-inf` or NaN (left out) when the origin is within the planes and
        // `+inf` entering when it is outside (a miss, as `holding` below finds too); on the
        // others they are the very `enter` of the first slab and `leave` of the last.
        let grid = bounds(planes);
        let (t0, exit) = SlabRay::new(ray).range(grid.min.into(), grid.max.into(), f32::MAX);
        w.far = exit;
        // (Plain comparisons: `tmax` is never NaN.)
        let far = if tmax < exit { tmax } else { exit };
        if t0 > far {
            return false;
        }
        for (i, axis) in planes.iter().enumerate() {
            let n = axis.slabs();
            if w.inv[i].is_infinite() {
                // Parallel: the slabs holding the origin stay active for the whole ray (two
                // if it lies on a plane: they lag with a leave distance of +inf).
                let Some(holding) = axis.holding(w.origin[i]) else {
                    return false;
                };
                (w.back[i], w.front[i]) = holding;
                if w.back[i] != w.front[i] {
                    w.lagging |= 1 << i;
                    w.lag_until = f32::INFINITY;
                }
                continue;
            }
            let forward = w.inv[i] >= 0.0;
            w.fwd[i] = u32::from(forward);
            w.step[i] = if forward { 1 } else { u32::MAX };
            w.last[i] = if forward { n - 1 } else { 0 };
        }
        for (i, axis) in planes.iter().enumerate() {
            if !w.inv[i].is_infinite() {
                w.place(i, axis, ray.dir[i], t0);
            }
        }
        let [nx, ny] = [0, 1].map(|a| u64::from(planes[a].slabs()));
        w.stride = [1, nx, nx * ny];
        w.index = w.index_of(w.front);
        w.index_step = [0, 1, 2].map(|i| {
            if w.step[i] == 1 {
                w.stride[i]
            } else {
                w.stride[i].wrapping_neg()
            }
        });
        true
    }

    /// The linear index of the cell of slabs `slabs` ([`linear_index`]).
    #[inline(always)]
    fn index_of(&self, slabs: [u32; 3]) -> u64 {
        let [x, y, z] = slabs.map(u64::from);
        x * self.stride[0] + y * self.stride[1] + z * self.stride[2]
    }

    /// Entry distance of slab `s` on axis `i` (the box test's `enter`).
    #[inline(always)]
    fn enter(&self, i: usize, s: u32) -> f32 {
        (self.at[i][(s + 1 - self.fwd[i]) as usize] - self.origin[i]) * self.inv[i]
    }

    /// Exit distance of slab `s` on axis `i` (the box test's `exit`, scaled up the same way).
    #[inline(always)]
    fn leave(&self, i: usize, s: u32) -> f32 {
        (self.at[i][(s + self.fwd[i]) as usize] - self.origin[i]) * self.inv[i] * EXIT_SCALE
    }

    /// Entry distance of the slab after `front` on axis `i`, `+inf` past the last slab.
    #[inline(always)]
    fn enter_after_front(&self, i: usize) -> f32 {
        self.enter_after(i, self.front[i])
    }

    /// Entry distance of the slab after slab `s` on axis `i`, `+inf` past the last slab.
    #[inline(always)]
    fn enter_after(&self, i: usize, s: u32) -> f32 {
        if s == self.last[i] {
            return f32::INFINITY;
        }
        (self.at[i][(s + self.fwd[i]) as usize] - self.origin[i]) * self.inv[i]
    }

    /// Sets axis `i`'s active slabs to those active at `t0` (the grid's entry distance): the
    /// last entered at or before it and the first not left before it. Starts from the slab
    /// holding the ray's point at `t0`, which is almost always the answer: two plane
    /// distances confirm it (the distance to a plane is both the entry of the slab after it
    /// and, scaled, the exit of the slab before it, with the same rounding). Otherwise (within
    /// a few ulps of a plane) the guess is corrected with the exact distances.
    #[inline(always)]
    fn place(&mut self, i: usize, planes: &Planes, dir: f32, t0: f32) {
        let s = planes.guess(self.origin[i] + t0 * dir);
        let first = planes.slabs() - 1 - self.last[i];
        let enter_s = self.enter(i, s);
        // Entry distance of the next slab; `* EXIT_SCALE`, the exit distance of `s`.
        let enter_next = (self.at[i][(s + self.fwd[i]) as usize] - self.origin[i]) * self.inv[i];
        let leave_s = enter_next * EXIT_SCALE;
        let only_s = enter_s <= t0
            && leave_s >= t0
            && (s == self.last[i] || enter_next > t0)
            && (s == first || enter_s * EXIT_SCALE < t0);
        if only_s {
            (self.back[i], self.front[i]) = (s, s);
            self.next_enter[i] = if s == self.last[i] {
                f32::INFINITY
            } else {
                enter_next
            };
            return;
        }
        self.place_near_a_plane(i, planes, s, t0);
    }

    /// [`Walk::place`] when the slab holding the point is not the only active one, or not
    /// active (`k` counts slabs in the ray's order).
    #[cold]
    fn place_near_a_plane(&mut self, i: usize, planes: &Planes, s: u32, t0: f32) {
        let n = planes.slabs();
        let forward = self.fwd[i] == 1;
        let slab = |k: u32| if forward { k } else { n - 1 - k };
        let enter = |k: u32| self.enter(i, slab(k));
        let leave = |k: u32| self.leave(i, slab(k));
        let guess = slab(s);
        let mut front = guess;
        while front + 1 < n && enter(front + 1) <= t0 {
            front += 1;
        }
        while front > 0 && enter(front) > t0 {
            front -= 1;
        }
        let mut back = guess;
        while back > 0 && leave(back - 1) >= t0 {
            back -= 1;
        }
        while back + 1 < n && leave(back) < t0 {
            back += 1;
        }
        (self.back[i], self.front[i]) = (slab(back.min(front)), slab(back.max(front)));
        self.next_enter[i] = self.enter_after_front(i);
        self.next_leave[i] = self.leave(i, self.back[i]);
        if self.back[i] != self.front[i] {
            self.lagging |= 1 << i;
            self.lag_end[i] = self.leave(i, self.front[i].wrapping_sub(self.step[i]));
            if self.lag_end[i] > self.lag_until {
                self.lag_until = self.lag_end[i];
            }
        }
    }

    /// The axis whose next slab is entered first ([`first_entry`]).
    #[inline(always)]
    fn next_axis(&self) -> usize {
        first_entry(self.next_enter).0
    }

    /// Drops the slabs left strictly before `t` on the lagging axes (keeping at least the
    /// front one: a slab is only left once the next is entered, which keeps the range
    /// non-empty).
    #[inline(always)]
    #[cold]
    fn leave_before(&mut self, t: f32) {
        self.lag_until = f32::NEG_INFINITY;
        for i in 0..3 {
            if self.lagging & (1 << i) == 0 {
                continue;
            }
            while self.next_leave[i] < t {
                self.back[i] = self.back[i].wrapping_add(self.step[i]);
                if self.back[i] == self.front[i] {
                    self.lagging &= !(1 << i);
                    break;
                }
                self.next_leave[i] = self.leave(i, self.back[i]);
            }
            if self.lagging & (1 << i) != 0 && self.lag_end[i] > self.lag_until {
                self.lag_until = self.lag_end[i];
            }
        }
    }

    /// Enters the next slab on axis `a`, whose entry distance `te` comes first. The slab left
    /// behind stays active until its exit distance, which is `te` scaled: the plane between
    /// the two slabs is both its exit plane and the new slab's entry plane, and the two
    /// distances are computed by the same formula (`leave` is `enter * EXIT_SCALE`).
    #[inline(always)]
    fn enter_next(&mut self, a: usize, te: f32) {
        let left = te * EXIT_SCALE;
        if self.back[a] == self.front[a] {
            self.next_leave[a] = left;
        }
        self.lagging |= 1 << a;
        self.lag_end[a] = left;
        if left > self.lag_until {
            self.lag_until = left;
        }
        self.advance(a);
    }

    /// Moves axis `a`'s front slab one step on, with the cell index and the next entry.
    #[inline(always)]
    fn advance(&mut self, a: usize) {
        self.front[a] = self.front[a].wrapping_add(self.step[a]);
        self.index = self.index.wrapping_add(self.index_step[a]);
        self.next_enter[a] = self.enter_after_front(a);
    }

    /// Where the walk stops: the grid's far end or the visitor's range end, whichever is
    /// nearer (`tmax` is never NaN, so a plain comparison picks it; RAY_DONE, `-inf`, stops).
    #[inline(always)]
    fn end(&self, tmax: f32) -> f32 {
        if tmax < self.far { tmax } else { self.far }
    }

    /// The walk while a single cell is new at each step: no axis but `entered` (the one just
    /// stepped on, 3 if none) keeps more than its front slab, and that one only until
    /// `lag_until`, its left slab's exit distance. Then each step visits the front cell, and
    /// the next step is an entry strictly beyond `lag_until`: the slab left behind is gone by
    /// then, so the general step would drop it (`back = front`) and keep only the new lag.
    /// This loop keeps `front`, `index`, `next_enter` and `lag_until` and nothing else; once
    /// the next entry comes at or before `lag_until` (two planes within a few ulps), it writes
    /// the lag out as the general step would have ([`Walk::lag_behind`]) and returns true for
    /// the general step to take over. False if the walk is over.
    #[inline(always)]
    fn single_cells(
        &mut self,
        mut entered: usize,
        tmax: &mut f32,
        visit: &mut impl FnMut(Cell, &mut f32),
    ) -> bool {
        // The loop's state in locals, stepped axis by axis through `step_front::<A>` (constant
        // axes), so that it stays in registers: indexed by a run-time axis it lived in memory,
        // and the step cost about twice the instructions (callgrind, terrain short rays).
        let (mut front, mut index, mut next) = (self.front, self.index, self.next_enter);
        let mut lag_until = self.lag_until;
        // Until this loop steps, the lag state is the general walk's own, still valid.
        let mut stepped = false;
        let handed_over = loop {
            visit(
                Cell {
                    slabs: front,
                    index,
                },
                tmax,
            );
            let (a, te) = first_entry(next);
            if te > self.end(*tmax) {
                break false;
            }
            if te <= lag_until {
                break true;
            }
            lag_until = te * EXIT_SCALE;
            match a {
                0 => self.step_front::<0>(&mut front, &mut index, &mut next),
                1 => self.step_front::<1>(&mut front, &mut index, &mut next),
                _ => self.step_front::<2>(&mut front, &mut index, &mut next),
            }
            entered = a;
            stepped = true;
        };
        (self.front, self.index, self.next_enter) = (front, index, next);
        self.lag_until = lag_until;
        if handed_over && stepped {
            self.lag_behind(entered);
        }
        handed_over
    }

    /// [`Walk::advance`] on the lean loop's copies of the state, for a constant axis `A`.
    #[inline(always)]
    fn step_front<const A: usize>(
        &self,
        front: &mut [u32; 3],
        index: &mut u64,
        next: &mut [f32; 3],
    ) {
        front[A] = front[A].wrapping_add(self.step[A]);
        *index = index.wrapping_add(self.index_step[A]);
        next[A] = self.enter_after(A, front[A]);
    }

    /// The lag state after a step on axis `a` from a single active cell, the left slab
    /// active until `lag_until` ([`Walk::single_cells`] keeps no more than that).
    #[cold]
    fn lag_behind(&mut self, a: usize) {
        self.back = self.front;
        self.back[a] = self.front[a].wrapping_sub(self.step[a]);
        self.next_leave[a] = self.lag_until;
        self.lag_end[a] = self.lag_until;
        self.lagging = 1 << a;
    }

    /// Visits the cells of the active block when an axis other than `entered` has several
    /// active slabs: only those in the slab just entered on `entered` (if `< 3`; all of them
    /// at the start). Stops early if the visitor ends the ray.
    #[inline(never)]
    fn visit_range(&self, entered: usize, tmax: &mut f32, visit: &mut impl FnMut(Cell, &mut f32)) {
        let range = |i: usize| {
            let (b, f) = (self.back[i], self.front[i]);
            if i == entered {
                (f, f)
            } else {
                (b.min(f), b.max(f))
            }
        };
        let [(x0, x1), (y0, y1), (z0, z1)] = [range(0), range(1), range(2)];
        for z in z0..=z1 {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let slabs = [x, y, z];
                    let index = self.index_of(slabs);
                    visit(Cell { slabs, index }, tmax);
                    if *tmax == RAY_DONE {
                        return;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::geom::{Aabb, Ray};

    /// A 4 x 4 x 4 grid over `[0, 4]^3`.
    fn grid4() -> GridPlanes {
        [0, 1, 2].map(|_| Planes::new(0.0, 4.0, 4))
    }

    fn cells_of(planes: &GridPlanes, ray: &Ray) -> Vec<[u32; 3]> {
        let ray = PreparedRay::new(ray).unwrap();
        let mut cells = Vec::new();
        let mut tmax = ray.tmax;
        walk(planes, &ray, &mut tmax, |c, _| {
            assert_eq!(c.index, linear_index(planes, c.slabs));
            cells.push(c.slabs)
        });
        cells
    }

    /// Every cell whose conservative box test passes, by brute force.
    fn touched(planes: &GridPlanes, ray: &Ray) -> Vec<[u32; 3]> {
        let ray = PreparedRay::new(ray).unwrap();
        let mut cells = Vec::new();
        for z in 0..planes[2].slabs() {
            for y in 0..planes[1].slabs() {
                for x in 0..planes[0].slabs() {
                    let c = [x, y, z];
                    let min = Vec3::from_array([0, 1, 2].map(|i| planes[i].at(c[i])));
                    let max = Vec3::from_array([0, 1, 2].map(|i| planes[i].at(c[i] + 1)));
                    if Aabb::new(min, max).hit_by(&ray, ray.tmax) {
                        cells.push(c);
                    }
                }
            }
        }
        cells
    }

    fn assert_visits_touched(ray: Ray) {
        let planes = grid4();
        let mut walked = cells_of(&planes, &ray);
        let n = walked.len();
        walked.sort_unstable();
        walked.dedup();
        assert_eq!(walked.len(), n, "a cell visited twice: {ray:?}");
        let mut expected = touched(&planes, &ray);
        expected.sort_unstable();
        assert_eq!(walked, expected, "{ray:?}");
    }

    #[test]
    fn diagonal_ray_steps_one_axis_at_a_time() {
        let cells = cells_of(
            &grid4(),
            &Ray::new(Vec3::new(0.5, 0.2, 0.5), Vec3::X + Vec3::Y * 0.5),
        );
        assert_eq!(
            cells,
            [[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [3, 1, 0]]
        );
    }

    #[test]
    fn ray_along_a_cell_boundary_visits_both_sides() {
        // In the plane y = 2 and the plane z = 1: four cells per x slab.
        let ray = Ray::new(Vec3::new(-1.0, 2.0, 1.0), Vec3::X);
        let cells = cells_of(&grid4(), &ray);
        assert_eq!(cells.len(), 16);
        assert_visits_touched(ray);
        assert_visits_touched(Ray::new(Vec3::new(2.0, 2.0, 5.0), -Vec3::Z));
        assert_visits_touched(Ray::new(
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::new(1.0, -0.0, 0.0),
        ));
    }

    #[test]
    fn ray_through_cell_corners_visits_every_touching_cell() {
        assert_visits_touched(Ray::new(Vec3::ZERO, Vec3::ONE));
        assert_visits_touched(Ray::new(Vec3::splat(4.5), -Vec3::ONE));
        assert_visits_touched(Ray::new(
            Vec3::new(-1.0, 0.0, 2.0),
            Vec3::new(1.0, 1.0, 0.0),
        ));
        assert_visits_touched(Ray::new(
            Vec3::new(1.0, 3.0, 0.5),
            Vec3::new(1.0, -1.0, 0.0),
        ));
    }

    #[test]
    fn axis_parallel_rays_and_ranges() {
        for d in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Z] {
            assert_visits_touched(Ray::new(Vec3::splat(2.5) - d * 5.0, d));
            assert_visits_touched(Ray::with_range(Vec3::splat(1.5), d, 1.0, 1.7));
        }
        // Parallel outside the grid: nothing.
        assert!(cells_of(&grid4(), &Ray::new(Vec3::new(-1.0, 5.0, 1.0), Vec3::X)).is_empty());
        // Behind the origin or beyond tmax: nothing.
        assert!(cells_of(&grid4(), &Ray::new(Vec3::splat(5.0), Vec3::ONE)).is_empty());
        let short = Ray::with_range(Vec3::splat(-3.0), Vec3::ONE, 0.0, 2.9);
        assert!(cells_of(&grid4(), &short).is_empty());
    }

    #[test]
    fn random_rays_visit_exactly_the_touched_cells() {
        let mut rng = crate::test_support::TestRng::new(11);
        for _ in 0..300 {
            // Origins and directions on a coarse lattice hit planes, edges and corners often.
            let o = (rng.vec3(6.0) * 2.0).round() * 0.5 + Vec3::splat(2.0);
            let d = (rng.vec3(2.0) * 2.0).round() * 0.5;
            let ray = Ray::with_range(o, d, rng.range(0.0, 0.5), rng.range(0.5, 8.0));
            if ray.is_valid() {
                assert_visits_touched(ray);
            }
        }
    }

    #[test]
    fn crossings_a_few_ulps_apart_visit_the_touched_cells() {
        // Rays through cell corners nudged by an ulp or two: two planes are crossed within
        // the exit scaling of each other, where the lean single-cell loop must hand over to
        // the general step (and a shortcut there loses the corner cells).
        let mut rng = crate::test_support::TestRng::new(23);
        let nudge = |x: f32, k: i32| f32::from_bits((x.to_bits() as i32 + k) as u32);
        for _ in 0..600 {
            let o = (rng.vec3(6.0) * 2.0).round() * 0.5 + Vec3::splat(2.0);
            let o = Vec3::from_array(o.to_array().map(|c| {
                let k = (rng.range(-3.0, 3.0)) as i32;
                if c == 0.0 { c } else { nudge(c, k) }
            }));
            let d = (rng.vec3(2.0) * 2.0).round() * 0.5;
            let ray = Ray::with_range(o, d, 0.0, rng.range(0.5, 8.0));
            if ray.is_valid() {
                assert_visits_touched(ray);
            }
        }
    }

    #[test]
    fn an_entry_exactly_at_the_last_exit_keeps_the_slab_left_behind() {
        // The ray crosses x = 1 at `t1`, then y = 1 at exactly `t1 * EXIT_SCALE`, the scaled
        // exit of the x slab it just left: the cell of the old x slab and the new y slab is
        // touched at that one `t` (the lean loop must hand over on `<=`, not `<`).
        let mut exact = 0;
        for t1 in [0.5f32, 0.25, 0.75, 0.375, 0.625] {
            let t2 = t1 * EXIT_SCALE;
            let oy = 1.0 - t2;
            if 1.0 - oy != t2 {
                continue;
            }
            exact += 1;
            for (o, d) in [
                (Vec3::new(1.0 - t1, oy, 0.5), Vec3::new(1.0, 1.0, 0.0)),
                (Vec3::new(oy, 1.0 - t1, 2.5), Vec3::new(1.0, 1.0, 0.0)),
                (Vec3::new(1.0 - t1, 0.5, oy), Vec3::new(1.0, 0.0, 1.0)),
            ] {
                let ray = Ray::new(o, d);
                assert!(cells_of(&grid4(), &ray).len() > 7, "{ray:?}");
                assert_visits_touched(ray);
            }
        }
        assert!(exact >= 3, "only {exact} exact cases");
    }

    #[test]
    fn a_shrinking_range_stops_the_walk() {
        let planes = grid4();
        let ray = PreparedRay::new(&Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X)).unwrap();
        let mut seen = Vec::new();
        let mut tmax = ray.tmax;
        walk(&planes, &ray, &mut tmax, |c, t| {
            seen.push(c.slabs[0]);
            *t = 2.0; // a hit at x = 1: cells entered after t = 2 are skipped
        });
        assert_eq!(seen, [0, 1]);
        let mut count = 0;
        walk(&planes, &ray, &mut ray.tmax.clone(), |_, t| {
            count += 1;
            *t = RAY_DONE;
        });
        assert_eq!(count, 1);
    }
}
