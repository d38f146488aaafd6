//! The planes that cut a grid's bounds into slabs along one axis, stored as exact `f32` values.
//!
//! The build (which cells a triangle's box covers) and the walk (when a ray enters and leaves a
//! slab) must agree on where every plane is, to the bit: the walk's exactness argument
//! (`super::walk`) compares the ray's distances to these very numbers with the box test's
//! rounding. So the planes are computed once, forced to be non-decreasing and to enclose the
//! bounds exactly, and stored; nobody recomputes them.

/// The `n + 1` planes of one axis: slab `i` is `[at(i), at(i + 1)]`.
#[derive(Clone, Debug)]
pub(crate) struct Planes {
    at: Vec<f32>,
    /// `at[0]` and `n / (max - min)`: a first guess of the slab holding a coordinate.
    origin: f32,
    inv_width: f32,
}

impl Planes {
    /// `slabs` equal slabs over `[min, max]` (rounded to `f32`, then made monotone, with the
    /// first plane exactly `min` and the last exactly `max`). `slabs >= 1`, `min <= max`.
    pub(crate) fn new(min: f32, max: f32, slabs: u32) -> Self {
        debug_assert!(slabs >= 1 && min <= max);
        let width = (max - min) / slabs as f32;
        let mut at: Vec<f32> = (0..=slabs)
            .map(|i| (min + width * i as f32).clamp(min, max))
            .collect();
        at[slabs as usize] = max;
        for i in 1..at.len() {
            at[i] = at[i].max(at[i - 1]);
        }
        let extent = max - min;
        let inv_width = if extent > 0.0 {
            slabs as f32 / extent
        } else {
            0.0
        };
        Self {
            at,
            origin: min,
            inv_width,
        }
    }

    /// Number of slabs.
    #[inline(always)]
    pub(crate) fn slabs(&self) -> u32 {
        (self.at.len() - 1) as u32
    }

    /// Plane `i` (`0..=slabs()`).
    #[cfg(test)]
    pub(crate) fn at(&self, i: u32) -> f32 {
        self.at[i as usize]
    }

    /// Every plane, `at(0)` to `at(slabs())`.
    #[inline(always)]
    pub(crate) fn planes(&self) -> &[f32] {
        &self.at
    }

    /// A guess of the slab holding `x`, clamped to the slabs (exact answers come from the
    /// callers' own checks against [`Planes::at`]).
    #[inline(always)]
    pub(crate) fn guess(&self, x: f32) -> u32 {
        // `as` saturates and maps NaN to 0.
        let i = ((x - self.origin) * self.inv_width) as i64;
        i.clamp(0, self.slabs() as i64 - 1) as u32
    }

    /// The slabs `(first, last)` whose union holds `[lo, hi]` (a box inside the bounds):
    /// `at(first) <= lo` and `at(last + 1) >= hi`.
    pub(crate) fn covering(&self, lo: f32, hi: f32) -> (u32, u32) {
        let n = self.slabs() as usize;
        // Largest i with at[i] <= lo, and smallest i with at[i + 1] >= hi.
        let first = self.at[..n].partition_point(|&p| p <= lo).saturating_sub(1);
        let last = self.at[1..].partition_point(|&p| p < hi).min(n - 1);
        (first.min(last) as u32, first.max(last) as u32)
    }

    /// The slabs `(first, last)` that hold the point `x` (two when it lies on a plane
    /// between them); `None` if `x` is outside the bounds. From [`Planes::guess`], corrected
    /// against the planes (a step or two, not a binary search: the walk calls this for every
    /// ray parallel to an axis, such as a height field's vertical rays).
    #[inline(always)]
    pub(crate) fn holding(&self, x: f32) -> Option<(u32, u32)> {
        let n = self.slabs() as usize;
        if !(self.at[0] <= x && x <= self.at[n]) {
            return None;
        }
        let guess = self.guess(x) as usize;
        // The lowest slab whose top plane is at or above x.
        let mut first = guess;
        while first > 0 && self.at[first] >= x {
            first -= 1;
        }
        while first + 1 < n && self.at[first + 1] < x {
            first += 1;
        }
        // The highest slab whose bottom plane is at or below x.
        let mut last = guess;
        while last + 1 < n && self.at[last + 1] <= x {
            last += 1;
        }
        while last > 0 && self.at[last] > x {
            last -= 1;
        }
        Some((first as u32, last.max(first) as u32))
    }

    /// Bytes on the heap.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.at.len() * size_of::<f32>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_enclose_the_bounds_exactly() {
        let p = Planes::new(0.1, 0.7, 3);
        assert_eq!(p.slabs(), 3);
        assert_eq!((p.at(0), p.at(3)), (0.1, 0.7));
        assert!((0..3).all(|i| p.at(i) <= p.at(i + 1)));
        let flat = Planes::new(2.0, 2.0, 1);
        assert_eq!((flat.at(0), flat.at(1)), (2.0, 2.0));
        assert_eq!(flat.covering(2.0, 2.0), (0, 0));
    }

    #[test]
    fn covering_holds_the_interval() {
        let p = Planes::new(0.0, 4.0, 4);
        assert_eq!(p.covering(0.0, 4.0), (0, 3));
        assert_eq!(p.covering(1.5, 1.7), (1, 1));
        // A box touching a plane from above starts in the slab above it.
        assert_eq!(p.covering(1.0, 1.5), (1, 1));
        assert_eq!(p.covering(0.5, 2.0), (0, 1));
        assert_eq!(p.covering(2.0, 2.0), (1, 2));
        for (lo, hi) in [(0.3, 3.9), (1.0, 1.0), (3.0, 4.0), (0.0, 0.0)] {
            let (a, b) = p.covering(lo, hi);
            assert!(p.at(a) <= lo && p.at(b + 1) >= hi && a <= b, "{lo} {hi}");
        }
    }

    #[test]
    fn holding_names_both_slabs_on_a_plane() {
        let p = Planes::new(0.0, 4.0, 4);
        assert_eq!(p.holding(2.0), Some((1, 2)));
        assert_eq!(p.holding(2.5), Some((2, 2)));
        assert_eq!(p.holding(0.0), Some((0, 0)));
        assert_eq!(p.holding(4.0), Some((3, 3)));
        assert_eq!(p.holding(4.5), None);
        assert_eq!(p.guess(2.5), 2);
        assert_eq!(p.guess(-9.0), 0);
        assert_eq!(p.guess(f32::NAN), 0);
    }

    #[test]
    fn holding_agrees_with_a_scan_of_the_planes() {
        let mut rng = crate::test_support::TestRng::new(5);
        for (min, max, n) in [(0.1f32, 0.7f32, 3u32), (-3.3, 1e4, 707), (5.0, 5.0, 1)] {
            let p = Planes::new(min, max, n);
            let at = p.planes();
            let planes_and_randoms = (0..=n)
                .map(|i| p.at(i))
                .chain((0..300).map(|_| rng.range(min - 1.0, max + 1.0)));
            for x in planes_and_randoms {
                let slabs = (0..n).filter(|&i| at[i as usize] <= x && x <= at[i as usize + 1]);
                let want = slabs.clone().min().zip(slabs.max());
                assert_eq!(p.holding(x), want, "{x} in {min}..{max} / {n}");
            }
        }
    }
}
