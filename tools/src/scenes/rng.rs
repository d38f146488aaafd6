//! SplitMix64, the tiny generator behind every procedural scene and ray set.
//!
//! Our own generator instead of the `rand` crate so that a seed gives the same scene and rays
//! across `rand` versions, platforms and compilers: benchmark numbers stay comparable. Only
//! integer arithmetic, `+`, `*`, `/` and `sqrt` are used (all exactly rounded by IEEE 754), never
//! `sin`/`cos`/`exp`, whose results may differ by an ulp between math libraries.

use raybatch::glam::{Vec2, Vec3};

/// The SplitMix64 generator (Steele, Lea, Flood 2014; the seeder of `xoshiro`): 64 bits of state,
/// full period, statistically good enough for scenes and rays, reproducible everywhere.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SplitMix64 {
    state: u64,
}

/// The golden-ratio increment of SplitMix64.
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

impl SplitMix64 {
    /// A generator starting from `seed` (any value, zero included).
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The generator of item `index` of a stream: items (rays, say) drawing from their own
    /// generators can be produced in parallel and in any order, and still come out the same.
    /// The index is hashed, so neighbouring items get unrelated states.
    pub fn for_item(seed: u64, index: u64) -> Self {
        Self::new(seed ^ mix64(index.wrapping_add(GAMMA)))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GAMMA);
        mix64(self.state)
    }

    /// Uniform in `[0, 1)`: the top 24 bits, so every value is exactly representable.
    pub fn next_f32(&mut self) -> f32 {
        bits_to_unit_f32(self.next_u64())
    }

    /// Uniform in `[lo, hi]` (`hi` itself only through rounding).
    pub fn range_f32(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    /// Uniform in `0..n` (`n > 0`), by multiply-shift: the bias is below `n / 2^64`, negligible.
    pub fn below(&mut self, n: u64) -> u64 {
        ((u128::from(self.next_u64()) * u128::from(n)) >> 64) as u64
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f32) -> bool {
        self.next_f32() < p
    }

    /// A unit vector uniform on the sphere. Rejection sampling in the cube rather than the
    /// trigonometric formula keeps it free of `sin`/`cos` (see the module docs).
    pub fn unit_vector(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range_f32(-1.0, 1.0),
                self.range_f32(-1.0, 1.0),
                self.range_f32(-1.0, 1.0),
            );
            let len2 = v.length_squared();
            // The lower bound keeps the normalisation far from dividing by (almost) zero.
            if (1e-6..=1.0).contains(&len2) {
                return v / len2.sqrt();
            }
        }
    }

    /// A unit vector uniform on the circle, by the same rejection as [`Self::unit_vector`].
    pub fn unit_vector_2d(&mut self) -> Vec2 {
        loop {
            let v = Vec2::new(self.range_f32(-1.0, 1.0), self.range_f32(-1.0, 1.0));
            let len2 = v.length_squared();
            if (1e-6..=1.0).contains(&len2) {
                return v / len2.sqrt();
            }
        }
    }

    /// A point uniform in the box `[min, max]`.
    pub fn point_in(&mut self, min: Vec3, max: Vec3) -> Vec3 {
        Vec3::new(
            self.range_f32(min.x, max.x),
            self.range_f32(min.y, max.y),
            self.range_f32(min.z, max.z),
        )
    }
}

/// The SplitMix64 output function: a strong 64-bit mixer, also used as a stateless hash.
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The top 24 bits of `bits` as a float in `[0, 1)`.
pub(crate) fn bits_to_unit_f32(bits: u64) -> f32 {
    (bits >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream() {
        let mut a = SplitMix64::new(42);
        let mut b = SplitMix64::new(42);
        for _ in 0..100 {
            assert_eq!(a.next_u64(), b.next_u64());
        }
        assert_ne!(SplitMix64::new(1).next_u64(), SplitMix64::new(2).next_u64());
    }

    #[test]
    fn matches_the_reference_splitmix64() {
        // First outputs for seed 1234567 of the reference C implementation (Vigna).
        let mut r = SplitMix64::new(1234567);
        assert_eq!(r.next_u64(), 6457827717110365317);
        assert_eq!(r.next_u64(), 3203168211198807973);
    }

    #[test]
    fn item_streams_are_distinct() {
        let firsts: std::collections::HashSet<u64> = (0..1000)
            .map(|i| SplitMix64::for_item(5, i).next_u64())
            .collect();
        assert_eq!(firsts.len(), 1000);
        assert_eq!(SplitMix64::for_item(5, 3), SplitMix64::for_item(5, 3));
    }

    #[test]
    fn floats_stay_in_range() {
        let mut r = SplitMix64::new(7);
        for _ in 0..10_000 {
            let f = r.next_f32();
            assert!((0.0..1.0).contains(&f));
            let g = r.range_f32(-3.0, 5.0);
            assert!((-3.0..=5.0).contains(&g));
            assert!(r.below(10) < 10);
        }
    }

    #[test]
    fn unit_vectors_are_unit_and_cover_the_sphere() {
        let mut r = SplitMix64::new(9);
        let mut sum = Vec3::ZERO;
        let n = 20_000;
        for _ in 0..n {
            let v = r.unit_vector();
            assert!((v.length() - 1.0).abs() < 1e-5, "{v}");
            sum += v;
        }
        // The mean of uniform unit vectors tends to zero (std of each component ~ 1/sqrt(3n)).
        assert!((sum / n as f32).length() < 0.03, "{sum}");
    }

    #[test]
    fn unit_vectors_2d_are_unit_and_cover_the_circle() {
        let mut r = SplitMix64::new(9);
        let (n, mut sum) = (20_000, Vec2::ZERO);
        // Uniform in angle: half the vectors lie within 22.5 degrees of an axis (normalising a
        // point of the square instead would put only about 41% there).
        let mut near_axis = 0;
        for _ in 0..n {
            let v = r.unit_vector_2d();
            assert!((v.length() - 1.0).abs() < 1e-5, "{v}");
            sum += v;
            near_axis += usize::from(v.abs().max_element() > 0.923_879_5);
        }
        assert!((sum / n as f32).length() < 0.03, "{sum}");
        let share = near_axis as f32 / n as f32;
        assert!((0.48..0.52).contains(&share), "{share}");
    }
}
