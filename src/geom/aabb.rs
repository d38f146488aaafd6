//! Axis-aligned boxes and the conservative ray/box slab test.
//!
//! The slab test follows Ize, "Robust BVH Ray Traversal" (JCGT 2013): the exit distance of each
//! slab is scaled up by `1 + 2 * gamma(3)` so that floating-point rounding can only make a box
//! look *bigger*, never smaller. A box the ray touches is therefore never culled, which is what
//! lets the traversal stay exact (watertight) and lets the tie rule survive any visiting order.
//!
//! Zero direction components need no special case: `1 / +-0 = +-inf`, so a slab the ray runs
//! parallel to gives `+-inf` (inside or outside), and the single ambiguous case, an origin exactly
//! on the slab plane, gives `0 * inf = NaN`. The near and far values are picked by the direction's
//! sign bit and folded with comparisons that drop a NaN operand, so that case means "no
//! constraint from this axis": the ray grazes the face, which counts as touching.

use glam::{Vec3, Vec3A};

use super::ray::PreparedRay;

/// `1 + 2 * gamma(3)` with `gamma(n) = n * eps / (1 - n * eps)`, `eps = 2^-24`, rounded up.
pub(crate) const EXIT_SCALE: f32 = 1.000_000_4;

/// An axis-aligned box. Empty boxes have `min > max` (see [`Aabb::EMPTY`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box: growing it by a point gives that point's box.
    pub const EMPTY: Self = Self {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box with corners `min` and `max`.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// The smallest box holding every point.
    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }

    /// This box grown to hold `p`.
    pub fn grow(self, p: Vec3) -> Self {
        Self::new(self.min.min(p), self.max.max(p))
    }

    /// The smallest box holding both.
    pub fn union(self, other: Self) -> Self {
        Self::new(self.min.min(other.min), self.max.max(other.max))
    }

    /// True if the box holds no point (`min > max` on some axis).
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// `max - min`.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// The 8 corners; corner `i` takes the max on x if bit 0 of `i` is set, on y for bit 1, on
    /// z for bit 2 (so corner 0 is `min` and corner 7 is `max`).
    pub fn corners(&self) -> [Vec3; 8] {
        let (lo, hi) = (self.min, self.max);
        std::array::from_fn(|i| {
            let pick = |bit: usize, lo: f32, hi: f32| if i >> bit & 1 == 0 { lo } else { hi };
            Vec3::new(
                pick(0, lo.x, hi.x),
                pick(1, lo.y, hi.y),
                pick(2, lo.z, hi.z),
            )
        })
    }

    /// The middle point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the surface area (the SAH only compares areas, so the factor 2 is dropped).
    /// Zero for empty boxes.
    pub(crate) fn half_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// True if `other` lies inside this box (boundaries included).
    pub fn contains(&self, other: &Aabb) -> bool {
        self.min.cmple(other.min).all() && self.max.cmpge(other.max).all()
    }

    /// Conservative slab test: true if the ray may touch the box for some `t` in
    /// `[ray.tmin, tmax]`. Never false for a box the exact ray touches.
    #[inline(always)]
    pub(crate) fn hit_by(&self, ray: &PreparedRay, tmax: f32) -> bool {
        self.entry(ray, tmax) < f32::INFINITY
    }

    /// The ray's (conservative) entry distance into the box within `[ray.tmin, tmax]`, or
    /// `+inf` if it misses. Comparing the result with a smaller `tmax` later gives the same
    /// answer as testing again: `entry(ray, t2) < inf` iff `entry(ray, t1) <= t2` for `t2 <= t1`.
    #[inline(always)]
    pub(crate) fn entry(&self, ray: &PreparedRay, tmax: f32) -> f32 {
        box_entry(self.min, self.max, ray, tmax)
    }
}

/// The slab test on raw bounds (see the module docs for the NaN and rounding reasoning):
/// the entry distance, or `+inf` on a miss.
///
/// The near and far planes are picked by the direction's sign bits, and each lane is folded
/// into the running range with an explicit compare-and-select, so a NaN lane (an axis the ray
/// grazes) leaves the range alone on every platform (SSE, NEON and scalar `max` disagree on
/// NaN, so `max`/`min` are not used for the fold).
#[inline(always)]
pub fn box_entry(min: Vec3, max: Vec3, ray: &PreparedRay, tmax: f32) -> f32 {
    SlabRay::new(ray).entry(Vec3A::from(min), Vec3A::from(max), tmax)
}

/// What [`box_entry`] needs of a ray, in vector registers: a walk that tests many boxes
/// against one ray (the grids' cull boxes) loads and selects it once, not once per box.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SlabRay {
    origin: Vec3A,
    inv_dir: Vec3A,
    /// Lanes whose direction is negative: the near plane is the box's `max` there.
    negative: glam::BVec3A,
    tmin: f32,
}

impl SlabRay {
    /// The ray's slab-test constants.
    #[inline(always)]
    pub(crate) fn new(ray: &PreparedRay) -> Self {
        let inv_dir = Vec3A::from(ray.inv_dir);
        Self {
            origin: Vec3A::from(ray.origin),
            inv_dir,
            // 1/+-0 = +-inf, so the sign of `inv_dir` is the sign bit of the direction.
            negative: inv_dir.cmplt(Vec3A::ZERO),
            tmin: ray.tmin,
        }
    }

    /// [`box_entry`] of the box `[min, max]`.
    #[inline(always)]
    pub(crate) fn entry(&self, min: Vec3A, max: Vec3A, tmax: f32) -> f32 {
        let (near, far) = self.range(min, max, tmax);
        if near <= far { near } else { f32::INFINITY }
    }

    /// The slab test's range before the miss test: the largest entry distance (at least
    /// `tmin`) and the smallest scaled exit distance (at most `tmax`, and `f32::MAX`), NaN
    /// lanes left out. The ray may touch the box iff `near <= far`.
    #[inline(always)]
    pub(crate) fn range(&self, min: Vec3A, max: Vec3A, tmax: f32) -> (f32, f32) {
        let near_plane = Vec3A::select(self.negative, max, min);
        let far_plane = Vec3A::select(self.negative, min, max);
        let enter = (near_plane - self.origin) * self.inv_dir;
        let exit = (far_plane - self.origin) * self.inv_dir * EXIT_SCALE;
        let lo = Vec3A::splat(self.tmin);
        // Hits have finite `t`, so an infinite entry (a parallel ray below a slab) is a miss.
        let hi = Vec3A::splat(tmax.min(f32::MAX));
        let near = Vec3A::select(enter.cmpgt(lo), enter, lo).max_element();
        let far = Vec3A::select(exit.cmplt(hi), exit, hi).min_element();
        (near, far)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Ray;

    fn prepared(o: Vec3, d: Vec3) -> PreparedRay {
        PreparedRay::new(&Ray::new(o, d)).unwrap()
    }

    #[test]
    fn zero_components_of_both_signs() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        for zero in [0.0f32, -0.0] {
            // Parallel to x, inside the y and z slabs.
            let r = prepared(Vec3::new(-1.0, 0.5, 0.5), Vec3::new(1.0, zero, zero));
            assert!(b.hit_by(&r, f32::INFINITY));
            // Parallel, outside the y slab.
            let r = prepared(Vec3::new(-1.0, 1.5, 0.5), Vec3::new(1.0, zero, zero));
            assert!(!b.hit_by(&r, f32::INFINITY));
            let r = prepared(Vec3::new(-1.0, -0.5, 0.5), Vec3::new(1.0, zero, zero));
            assert!(!b.hit_by(&r, f32::INFINITY));
            // Grazing: exactly on the y = 1 and z = 0 faces (0 * inf = NaN on those axes).
            let r = prepared(Vec3::new(-1.0, 1.0, 0.0), Vec3::new(1.0, zero, zero));
            assert!(b.hit_by(&r, f32::INFINITY));
        }
    }

    #[test]
    fn range_limits_are_inclusive() {
        let b = Aabb::new(Vec3::new(1.0, -1.0, -1.0), Vec3::new(2.0, 1.0, 1.0));
        let r = prepared(Vec3::ZERO, Vec3::X);
        assert!(b.hit_by(&r, 1.0));
        assert!(!b.hit_by(&r, 0.99));
        let behind = prepared(Vec3::new(3.0, 0.0, 0.0), Vec3::X);
        assert!(!b.hit_by(&behind, f32::INFINITY));
    }

    #[test]
    fn flat_box_is_hit() {
        let b = Aabb::new(Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 1.0, 1.0));
        let r = prepared(Vec3::new(0.5, 0.5, 0.0), Vec3::Z);
        assert!(b.hit_by(&r, f32::INFINITY));
        let r = prepared(Vec3::new(0.5, 0.5, 0.0), Vec3::new(1e-30, 0.0, 1.0));
        assert!(b.hit_by(&r, f32::INFINITY));
    }

    #[test]
    fn empty_box_is_never_hit() {
        let r = prepared(Vec3::ZERO, Vec3::ONE);
        assert!(!Aabb::EMPTY.hit_by(&r, f32::INFINITY));
        assert_eq!(Aabb::EMPTY.half_area(), 0.0);
    }
}
