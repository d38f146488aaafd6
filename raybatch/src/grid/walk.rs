//! The 3D-DDA walk (seed 004's `t_exit` / `delta t` stepping), made exact: it visits every
//! cell the conservative box test would let a hit through, in order of entry distance.
//!
//! **Per axis.** Along one axis the ray crosses slabs `[p_i, p_(i+1)]` (the stored planes of
//! [`Planes`]). Slab `i` is *active* from its entry distance `enter = (near plane - o) * inv`
//! to its exit distance `leave = (far plane - o) * inv * EXIT_SCALE`: the very formulas, in the
//! same order and rounding, of the slab test in [`crate::geom::aabb`]. The seed's walk steps
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
//! **Robustness.** An axis the ray runs parallel to (`inv_dir` infinite, where `0 * inf` would
//! be NaN) has no events: its active slabs are those holding the origin's coordinate (two
//! when the origin lies on a plane, which is the box test's "grazing counts as touching").
//! Distances that overflow are infinite and compare as such; a ray starting inside the grid,
//! outside it, at `tmin > 0` or ending at a finite `tmax` only changes where the walk starts
//! (the grid's own entry distance) and ends.

use crate::geom::PreparedRay;
use crate::geom::aabb::EXIT_SCALE;
use crate::hit::RAY_DONE;

use super::planes::Planes;

/// The three axes' planes of a grid.
pub(crate) type GridPlanes = [Planes; 3];

/// Walks `ray` through the cells of `planes` in order of entry distance, calling
/// `visit(cell, tmax)` once for every cell (slab indices `[x, y, z]`) that may hold a hit in
/// `[ray.tmin, *tmax]` (see the module docs). `visit` may shrink `*tmax` (the walk then stops
/// earlier) or set it to [`RAY_DONE`] (the walk stops at once).
#[inline(always)]
pub(crate) fn walk(
    planes: &GridPlanes,
    ray: &PreparedRay,
    tmax: &mut f32,
    mut visit: impl FnMut([u32; 3], &mut f32),
) {
    let Some(mut axes) = start(planes, ray, *tmax) else {
        return;
    };
    // Hits have finite `t` (as in the box test): `+inf` entries end the walk.
    let far = axes.iter().map(|a| a.exit).fold(f32::MAX, f32::min);
    if !visit_block(&axes, None, tmax, &mut visit) {
        return;
    }
    loop {
        let a = next_axis(&axes);
        let te = axes[a].next_enter;
        // Stops on +inf (no slab left), beyond the grid, beyond the best hit, or RAY_DONE
        // (distances are never NaN: the axes that would give one have no events).
        if te > tmax.min(far) {
            return;
        }
        for axis in axes.iter_mut() {
            axis.leave_before(te);
        }
        axes[a].enter_next();
        if !visit_block(&axes, Some(a), tmax, &mut visit) {
            return;
        }
    }
}

/// The axis whose next slab is entered first (the lowest index on ties, so that the order of
/// visits is deterministic).
#[inline(always)]
fn next_axis(axes: &[AxisWalk; 3]) -> usize {
    let [x, y, z] = [0, 1, 2].map(|i| axes[i].next_enter);
    if x <= y && x <= z {
        0
    } else if y <= z {
        1
    } else {
        2
    }
}

/// Visits the cells of the active block; when `entered` names an axis, only those in the slab
/// just entered on it (the others were visited before). False if the visitor ended the ray.
#[inline(always)]
fn visit_block(
    axes: &[AxisWalk; 3],
    entered: Option<usize>,
    tmax: &mut f32,
    visit: &mut impl FnMut([u32; 3], &mut f32),
) -> bool {
    let range = |i: usize| {
        let axis = &axes[i];
        if entered == Some(i) {
            let s = axis.slab(axis.front);
            (s, s)
        } else {
            axis.slab_range()
        }
    };
    let [(x0, x1), (y0, y1), (z0, z1)] = [range(0), range(1), range(2)];
    for z in z0..=z1 {
        for y in y0..=y1 {
            for x in x0..=x1 {
                visit([x, y, z], tmax);
                if *tmax == RAY_DONE {
                    return false;
                }
            }
        }
    }
    true
}

/// The walk's state on every axis at the grid's entry distance, or `None` if the ray misses
/// the grid in `[ray.tmin, tmax]`.
#[inline(always)]
fn start<'a>(planes: &'a GridPlanes, ray: &PreparedRay, tmax: f32) -> Option<[AxisWalk<'a>; 3]> {
    let [x, y, z] = [0, 1, 2].map(|i| AxisWalk::new(&planes[i], ray, i));
    let mut axes = [x?, y?, z?];
    let t0 = axes.iter().map(|a| a.enter_grid).fold(ray.tmin, f32::max);
    let far = axes
        .iter()
        .map(|a| a.exit)
        .fold(tmax.min(f32::MAX), f32::min);
    if t0 > far {
        return None;
    }
    for axis in &mut axes {
        axis.place(ray, t0);
    }
    Some(axes)
}

/// One axis of the walk. Slabs are numbered in walk order `k` (`k = slab` for a ray going
/// up the axis, `k = n - 1 - slab` going down), so that both directions step `k` upwards.
/// Slabs `back..=front` are active.
#[derive(Clone, Copy, Debug)]
struct AxisWalk<'a> {
    planes: &'a Planes,
    axis: usize,
    n: u32,
    forward: bool,
    origin: f32,
    inv: f32,
    back: u32,
    front: u32,
    /// Entry distance of slab `front + 1` (`+inf` if none, or if the ray is parallel).
    next_enter: f32,
    /// Exit distance of slab `back`.
    next_leave: f32,
    /// Entry distance of the first slab (`-inf` when parallel).
    enter_grid: f32,
    /// Exit distance of the last slab (`+inf` when parallel).
    exit: f32,
}

impl<'a> AxisWalk<'a> {
    /// The axis `axis` of the walk of `ray`, before [`AxisWalk::place`]; `None` if the ray
    /// runs parallel to it outside the grid.
    #[inline(always)]
    fn new(planes: &'a Planes, ray: &PreparedRay, axis: usize) -> Option<Self> {
        let (origin, inv) = (ray.origin[axis], ray.inv_dir[axis]);
        let n = planes.slabs();
        let mut walk = Self {
            planes,
            axis,
            n,
            forward: inv >= 0.0,
            origin,
            inv,
            back: 0,
            front: 0,
            next_enter: f32::INFINITY,
            next_leave: f32::INFINITY,
            enter_grid: f32::NEG_INFINITY,
            exit: f32::INFINITY,
        };
        if inv.is_infinite() {
            // Parallel: the slabs holding the origin stay active for the whole ray.
            let (first, last) = planes.holding(origin)?;
            (walk.forward, walk.back, walk.front) = (true, first, last);
        } else {
            walk.enter_grid = walk.enter(0);
            walk.exit = walk.leave(n - 1);
        }
        Some(walk)
    }

    /// The slab of walk index `k`.
    #[inline(always)]
    fn slab(&self, k: u32) -> u32 {
        if self.forward { k } else { self.n - 1 - k }
    }

    /// The active slabs as `(lowest, highest)` slab index.
    #[inline(always)]
    fn slab_range(&self) -> (u32, u32) {
        let (a, b) = (self.slab(self.back), self.slab(self.front));
        (a.min(b), a.max(b))
    }

    /// Entry distance of slab `k` (the box test's `enter`).
    #[inline(always)]
    fn enter(&self, k: u32) -> f32 {
        let plane = if self.forward { k } else { self.n - k };
        (self.planes.at(plane) - self.origin) * self.inv
    }

    /// Exit distance of slab `k` (the box test's `exit`, scaled up the same way).
    #[inline(always)]
    fn leave(&self, k: u32) -> f32 {
        let plane = if self.forward { k + 1 } else { self.n - 1 - k };
        (self.planes.at(plane) - self.origin) * self.inv * EXIT_SCALE
    }

    /// Sets the active slabs to those active at `t0` (the grid's entry distance): the last
    /// entered at or before it and the first not left before it. Starts from the slab
    /// holding the ray's point at `t0` and corrects the guess with the exact distances.
    #[inline(always)]
    fn place(&mut self, ray: &PreparedRay, t0: f32) {
        if self.inv.is_infinite() {
            return;
        }
        let n = self.n;
        let x = self.origin + t0 * ray.dir[self.axis];
        let guess = self.slab(self.planes.guess(x));
        let mut front = guess;
        while front + 1 < n && self.enter(front + 1) <= t0 {
            front += 1;
        }
        while front > 0 && self.enter(front) > t0 {
            front -= 1;
        }
        let mut back = guess;
        while back > 0 && self.leave(back - 1) >= t0 {
            back -= 1;
        }
        while back + 1 < n && self.leave(back) < t0 {
            back += 1;
        }
        (self.back, self.front) = (back.min(front), back.max(front));
        self.next_enter = self.enter_after_front();
        self.next_leave = self.leave(self.back);
    }

    /// Entry distance of slab `front + 1`, `+inf` past the last slab.
    #[inline(always)]
    fn enter_after_front(&self) -> f32 {
        if self.front + 1 < self.n {
            self.enter(self.front + 1)
        } else {
            f32::INFINITY
        }
    }

    /// Makes slab `front + 1` active.
    #[inline(always)]
    fn enter_next(&mut self) {
        self.front += 1;
        self.next_enter = self.enter_after_front();
    }

    /// Drops the slabs left strictly before `t` (keeping at least the front one: a slab is
    /// only left once the next is entered, which keeps the active range non-empty).
    #[inline(always)]
    fn leave_before(&mut self, t: f32) {
        while self.back < self.front && self.next_leave < t {
            self.back += 1;
            self.next_leave = self.leave(self.back);
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
        walk(planes, &ray, &mut tmax, |c, _| cells.push(c));
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
    fn a_shrinking_range_stops_the_walk() {
        let planes = grid4();
        let ray = PreparedRay::new(&Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X)).unwrap();
        let mut seen = Vec::new();
        let mut tmax = ray.tmax;
        walk(&planes, &ray, &mut tmax, |c, t| {
            seen.push(c[0]);
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
