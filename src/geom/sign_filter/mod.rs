//! The watertight kernel's sign test for four rays at once: a filter that proves misses.
//!
//! Most ray/triangle pairs a batched leaf test sees are misses, and the watertight kernel
//! rejects them at its first decision: the three edge functions `U, V, W` of the sheared,
//! projected triangle have mixed signs. [`RayQuad::may_hit`] computes `U, V, W` for four rays
//! against one triangle in 4-lane SIMD (glam's `Vec4`: SSE2 or NEON, scalar elsewhere) with,
//! lane by lane, the very `f32` operations of [`super::WatertightAxis::intersect`] in the same
//! order (no fused multiply-add: Rust never contracts `a * b - c`), so each lane's values are
//! the kernel's values bit for bit. A lane is cleared only where the kernel would return `None`
//! at that test without its `f64` recomputation: no edge function is zero or subnormal, and
//! the signs are mixed. Every other lane runs the scalar kernel, which alone decides hits; so a
//! filtered leaf test reports exactly the hits of an unfiltered one, in the same order.
//!
//! Lanes hold rays of any dominant axis: the axis permutation the scalar kernel resolves at
//! compile time is a per-lane select here.

use glam::{BVec4A, Vec3, Vec4};

#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod octet;
#[cfg(target_arch = "x86_64")]
pub(crate) use octet::RayOctet;

use super::PreparedRay;

/// The constants of four rays the sign test reads (lane `k` is ray `k`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayQuad {
    /// Origins, one vector per axis.
    pub(crate) origin: [Vec4; 3],
    /// Shear constants `shear.x`, `shear.y` of each ray.
    pub(crate) shear_x: Vec4,
    pub(crate) shear_y: Vec4,
    /// Lanes whose dominant axis is x, and y (the rest: z).
    pub(crate) kz_is_x: BVec4A,
    pub(crate) kz_is_y: BVec4A,
}

impl RayQuad {
    /// The constants of four prepared rays (they need not be next to each other in memory:
    /// the 4-wide stream engine's lists hold ray indices).
    #[inline(always)]
    pub(crate) fn from_rays(rays: [&PreparedRay; 4]) -> Self {
        let lanes = |f: &dyn Fn(&PreparedRay) -> f32| Vec4::from_array(rays.map(f));
        RayQuad {
            origin: [
                lanes(&|r| r.origin.x),
                lanes(&|r| r.origin.y),
                lanes(&|r| r.origin.z),
            ],
            shear_x: lanes(&|r| r.shear.x),
            shear_y: lanes(&|r| r.shear.y),
            kz_is_x: BVec4A::from(rays.map(|r| r.kz == 0)),
            kz_is_y: BVec4A::from(rays.map(|r| r.kz == 1)),
        }
    }

    /// Bit `k` is set unless ray `k` certainly misses `tri` (see the module docs).
    #[inline(always)]
    pub(crate) fn may_hit(&self, tri: &[Vec3; 3]) -> u32 {
        let (ax, ay) = self.project(tri[0]);
        let (bx, by) = self.project(tri[1]);
        let (cx, cy) = self.project(tri[2]);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        // The kernel's compares: signs beyond the subnormal range.
        let m = Vec4::splat(f32::MIN_POSITIVE);
        let (un, vn, wn) = (u.cmplt(-m), v.cmplt(-m), w.cmplt(-m));
        let (up, vp, wp) = (u.cmpgt(m), v.cmpgt(m), w.cmpgt(m));
        let all_normal = (un | up) & (vn | vp) & (wn | wp);
        let certain_miss = all_normal & (un | vn | wn) & (up | vp | wp);
        !certain_miss.bitmask() & 0b1111
    }

    /// Corner `p` relative to each origin, permuted to `(kx, ky, kz)` and sheared:
    /// `(p[kx] - sx * p[kz], p[ky] - sy * p[kz])`, as the scalar kernel computes it.
    #[inline(always)]
    fn project(&self, p: Vec3) -> (Vec4, Vec4) {
        let rel = [
            Vec4::splat(p.x) - self.origin[0],
            Vec4::splat(p.y) - self.origin[1],
            Vec4::splat(p.z) - self.origin[2],
        ];
        // kz = x: (kx, ky) = (y, z); kz = y: (z, x); kz = z: (x, y).
        let pick = |if_x: usize, if_y: usize, if_z: usize| {
            Vec4::select(
                self.kz_is_x,
                rel[if_x],
                Vec4::select(self.kz_is_y, rel[if_y], rel[if_z]),
            )
        };
        let (x, y, z) = (pick(1, 2, 0), pick(2, 0, 1), pick(0, 1, 2));
        (x - self.shear_x * z, y - self.shear_y * z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{PreparedRay, Ray, TriangleTest, Watertight};
    use crate::test_support::TestRng;

    fn quad(rays: &[PreparedRay; 4]) -> RayQuad {
        RayQuad::from_rays(rays.each_ref())
    }

    /// The filter never clears a lane the scalar kernel hits, over random rays of every axis
    /// against random triangles, triangles through the origins (zero edge functions) and
    /// rays aimed at corners and edges; and it does clear most misses.
    #[test]
    fn never_drops_a_hit_and_drops_most_misses() {
        let mut rng = TestRng::new(11);
        let (mut hits, mut misses, mut dropped) = (0, 0, 0);
        for round in 0..20_000 {
            let rays: [PreparedRay; 4] = std::array::from_fn(|_| {
                let origin = rng.vec3(2.0);
                let dir = rng.vec3(1.0);
                PreparedRay::new(&Ray::new(origin, dir))
                    .unwrap_or_else(|| PreparedRay::new(&Ray::new(origin, Vec3::X)).unwrap())
            });
            let mut tri = [rng.vec3(3.0), rng.vec3(3.0), rng.vec3(3.0)];
            match round % 4 {
                // A corner on the first ray: its edge functions through that corner are zero.
                1 => tri[0] = rays[0].origin + rays[0].dir * 1.5,
                // Aimed at the middle of an edge.
                2 => tri[1] = 2.0 * (rays[0].origin + rays[0].dir) - tri[0],
                _ => {}
            }
            let mask = quad(&rays).may_hit(&tri);
            for (k, ray) in rays.iter().enumerate() {
                let hit = Watertight::intersect(ray, &tri, f32::INFINITY).is_some();
                let kept = mask & (1 << k) != 0;
                assert!(kept || !hit, "dropped a hit: {ray:?} {tri:?}");
                if hit {
                    hits += 1;
                } else {
                    misses += 1;
                    dropped += !kept as u32;
                }
            }
        }
        assert!(hits > 1000, "{hits} hits: the test must see hits");
        assert!(
            dropped * 10 > misses * 7,
            "only {dropped} of {misses} misses dropped"
        );
    }
}
