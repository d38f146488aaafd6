//! Ray/triangle kernels: watertight (the default) and Möller-Trumbore (fast, for comparison).
//!
//! **Watertight** (Woop, Benthin, Wald, "Watertight Ray/Triangle Intersection", JCGT 2013):
//! the vertices are translated to the ray origin and sheared so that the ray becomes the +z
//! axis; the hit test is then three 2D edge functions `U, V, W` evaluated on the projected
//! vertices. Two triangles sharing an edge evaluate that edge function on the same two projected
//! points, so a ray through the edge sees the same value (with opposite sign) from both and
//! cannot slip between them. When an edge function is exactly zero the three are recomputed in
//! `f64`, where the products are exact, so the sign test on edges and vertices is exact too.
//! Edges are inclusive and both windings hit (no back-face culling).
//!
//! **Möller-Trumbore** (1997) computes barycentrics with two cross products and a division. It
//! is a few instructions shorter but rounds each triangle's edge test independently, so rays
//! aimed at shared edges and vertices can leak through a closed mesh. It exists so that the
//! speed/accuracy trade-off can be measured; do not use it where leaks matter.
//!
//! Both kernels return `t` and barycentrics `u, v` with `p = (1 - u - v) * v0 + u * v1 + v * v2`,
//! accept `tmin <= t <= tmax`, never report a hit on a zero-area triangle, and only report hits
//! that agree with the conservative box test of the triangle's bounds (see
//! `agree_with_bounds`), which is what lets every traversal order give the same answer.

use std::ops::{Mul, Sub};

use glam::{DVec3, Vec3};

use super::aabb::box_entry;
use super::ray::PreparedRay;

/// Where a ray meets one triangle: `p = (1 - u - v) * v0 + u * v1 + v * v2 = origin + t * dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Distance along the ray.
    pub t: f32,
    /// Barycentric weight of the second corner.
    pub u: f32,
    /// Barycentric weight of the third corner.
    pub v: f32,
}

/// A ray/triangle kernel, chosen at compile time inside the traversal loops.
pub trait TriangleTest: Copy + Send + Sync + 'static {
    /// The same kernel for rays of any dominant axis. The watertight kernel comes in per-axis
    /// variants ([`WatertightAxis`]) that require `ray.kz` to match; a structure that traces a
    /// ray of its own making (a scene's instance transforms the ray, and its dominant axis may
    /// change) must use `K::AnyAxis` for it. Both give identical answers.
    type AnyAxis: TriangleTest;

    /// True if the kernel is the watertight one, whose misses the batched engine may prove
    /// four rays at a time (the crate's `geom::sign_filter`) before calling it.
    const SIGN_FILTER: bool = false;

    /// The hit of `ray` with the triangle `tri` for `t` in `[ray.tmin, tmax]`, if any.
    fn intersect(ray: &PreparedRay, tri: &[Vec3; 3], tmax: f32) -> Option<TriangleHit>;
}

/// Which kernel a query uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Woop et al. 2013: exact on shared edges and vertices. The default.
    #[default]
    Watertight,
    /// Möller-Trumbore: slightly faster, may leak on shared edges.
    MollerTrumbore,
}

impl Kernel {
    /// Every kernel.
    pub const ALL: [Kernel; 2] = [Kernel::Watertight, Kernel::MollerTrumbore];

    /// Short name for tables and the command line.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Watertight => "watertight",
            Kernel::MollerTrumbore => "moller-trumbore",
        }
    }
}

/// Work to run with a kernel chosen at compile time (see [`Kernel::dispatch`]).
pub trait KernelTask {
    /// What the task returns.
    type Output;
    /// Runs the task with kernel `K`.
    fn run<K: TriangleTest>(self) -> Self::Output;
}

impl Kernel {
    /// Runs `task` monomorphized for this kernel and, for the watertight kernel, for the ray's
    /// dominant axis `kz` (so the axis permutation costs nothing in the inner loop).
    #[inline(always)]
    pub(crate) fn dispatch<T: KernelTask>(self, kz: usize, task: T) -> T::Output {
        match (self, kz) {
            (Kernel::Watertight, 0) => task.run::<WatertightAxis<0>>(),
            (Kernel::Watertight, 1) => task.run::<WatertightAxis<1>>(),
            (Kernel::Watertight, _) => task.run::<WatertightAxis<2>>(),
            (Kernel::MollerTrumbore, _) => task.run::<MollerTrumbore>(),
        }
    }

    /// Runs `task` monomorphized for this kernel only, the watertight kernel choosing the
    /// axis permutation per test ([`Watertight`]): for queries off the hot path, compiled once
    /// per kernel instead of once per axis.
    #[inline(always)]
    pub(crate) fn dispatch_any_axis<T: KernelTask>(self, task: T) -> T::Output {
        match self {
            Kernel::Watertight => task.run::<Watertight>(),
            Kernel::MollerTrumbore => task.run::<MollerTrumbore>(),
        }
    }
}

/// The watertight kernel (see the module docs).
#[derive(Clone, Copy, Debug, Default)]
pub struct Watertight;

/// The Möller-Trumbore kernel (see the module docs).
#[derive(Clone, Copy, Debug, Default)]
pub struct MollerTrumbore;

impl TriangleTest for Watertight {
    type AnyAxis = Watertight;
    const SIGN_FILTER: bool = true;

    /// Dispatches on the ray's dominant axis; traversal loops call [`WatertightAxis`] directly
    /// so that the axis permutation is resolved at compile time.
    #[inline(always)]
    fn intersect(ray: &PreparedRay, tri: &[Vec3; 3], tmax: f32) -> Option<TriangleHit> {
        match ray.kz {
            0 => WatertightAxis::<0>::intersect(ray, tri, tmax),
            1 => WatertightAxis::<1>::intersect(ray, tri, tmax),
            _ => WatertightAxis::<2>::intersect(ray, tri, tmax),
        }
    }
}

/// The watertight kernel for rays whose dominant axis is `KZ` (`ray.kz` must equal `KZ`).
#[derive(Clone, Copy, Debug, Default)]
pub struct WatertightAxis<const KZ: usize>;

impl<const KZ: usize> TriangleTest for WatertightAxis<KZ> {
    type AnyAxis = Watertight;
    const SIGN_FILTER: bool = true;

    #[inline(always)]
    fn intersect(ray: &PreparedRay, tri: &[Vec3; 3], tmax: f32) -> Option<TriangleHit> {
        debug_assert_eq!(ray.kz as usize, KZ);
        let (xy, z) = project::<KZ>(ray, tri);
        let [u, v, w] = edge_functions(xy);
        // Signs taken beyond the subnormal range: where all three edge functions are normal,
        // these are their signs, and the same compares tell whether one is not. Non-short-
        // circuit `|` and `&`: one branch each instead of a chain, since whether a ray passes
        // a triangle is unpredictable (the same values, so the same answers).
        let m = f32::MIN_POSITIVE;
        let (neg, pos) = ([u < -m, v < -m, w < -m], [u > m, v > m, w > m]);
        if !((neg[0] | pos[0]) & (neg[1] | pos[1]) & (neg[2] | pos[2])) {
            return exact_edges::<KZ>(ray, tri, tmax);
        }
        if (neg[0] | neg[1] | neg[2]) & (pos[0] | pos[1] | pos[2]) {
            return None;
        }
        hit_distance::<KZ>(ray, tri, tmax, [u, v, w], z)
    }
}

/// The corners relative to the ray's origin, sheared and projected onto the plane
/// perpendicular to the ray (`[ax, ay, bx, by, cx, cy]`), and their distances along the
/// dominant axis `KZ`.
#[inline(always)]
fn project<const KZ: usize>(ray: &PreparedRay, tri: &[Vec3; 3]) -> ([f32; 6], [f32; 3]) {
    let (kx, ky, kz) = ((KZ + 1) % 3, (KZ + 2) % 3, KZ);
    let a = (tri[0] - ray.origin).to_array();
    let b = (tri[1] - ray.origin).to_array();
    let c = (tri[2] - ray.origin).to_array();
    let (sx, sy) = (ray.shear.x, ray.shear.y);
    let xy = [
        a[kx] - sx * a[kz],
        a[ky] - sy * a[kz],
        b[kx] - sx * b[kz],
        b[ky] - sy * b[kz],
        c[kx] - sx * c[kz],
        c[ky] - sy * c[kz],
    ];
    (xy, [a[kz], b[kz], c[kz]])
}

/// The edge functions `u, v, w` of the projected corners, in `f32` or (exactly) in `f64`.
#[inline(always)]
fn edge_functions<T>([ax, ay, bx, by, cx, cy]: [T; 6]) -> [T; 3]
where
    T: Copy + Mul<Output = T> + Sub<Output = T>,
{
    [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax]
}

/// The rest of the test once the edge functions `uvw` have one sign: the distance, its range
/// and the barycentrics.
#[inline(always)]
fn hit_distance<const KZ: usize>(
    ray: &PreparedRay,
    tri: &[Vec3; 3],
    tmax: f32,
    [u, v, w]: [f32; 3],
    z: [f32; 3],
) -> Option<TriangleHit> {
    // Never zero: three normal values of one sign (or, from `exact_edges`, not all zero).
    let det = u + v + w;
    // The paper scales the z coordinates by `sz = 1 / dir[kz]` before combining them; for a
    // short direction `sz` is huge and that product overflows although `t` itself is finite,
    // so the scale is applied last, to the distance along z.
    let terms = [u * z[0], v * z[1], w * z[2]];
    let sum = terms[0] + terms[1] + terms[2];
    // A term that underflowed is off by less than 2^-149; against a sum of at least 2^-100 that
    // is far below the sum's own rounding, so only smaller sums look at the terms.
    if (sum.abs() < TINY_SUM)
        && (underflows(terms[0], u, z[0])
            | underflows(terms[1], v, z[1])
            | underflows(terms[2], w, z[2]))
    {
        return in_f64::<KZ>(ray, tri, tmax);
    }
    let z_along = sum / det;
    let t = z_along * ray.shear.z;
    if !in_range(t, ray.tmin, tmax) {
        return None;
    }
    agree_with_bounds(
        ray,
        tri,
        tmax,
        TriangleHit {
            t,
            u: v / det,
            v: w / det,
        },
    )
}

/// An edge function is zero or subnormal: zero ones (the ray on an edge or vertex) get their
/// exact signs in `f64`; where one is too small for `f32` (a triangle and ray near the origin
/// at a tiny scale) the whole test runs in `f64` ([`exact_test`]). It recomputes the projection
/// (the same `f32` operations, so the same values) instead of taking it from the caller, and
/// it is inlined: as a call inside the stream engines' loops it cost them 6-10%
/// (every vector register is the caller's to save).
#[inline(always)]
fn exact_edges<const KZ: usize>(
    ray: &PreparedRay,
    tri: &[Vec3; 3],
    tmax: f32,
) -> Option<TriangleHit> {
    let (xy, z) = project::<KZ>(ray, tri);
    let exact = edge_functions_f64(xy);
    if exact.iter().any(|e| below_normal(*e as f32) && *e != 0.0) {
        return exact_test(ray, tri, tmax, exact, z);
    }
    let uvw = exact.map(|e| e as f32);
    if mixed_signs(uvw) || uvw == [0.0; 3] {
        return None;
    }
    hit_distance::<KZ>(ray, tri, tmax, uvw, z)
}

/// The whole test in `f64`, for triangles whose `f32` edge functions or distance terms
/// underflow: products of `f32` values are exact in `f64`, and its range holds them at every
/// scale a mesh may have, so tiny meshes are as exact as any other.
#[inline(always)]
fn in_f64<const KZ: usize>(ray: &PreparedRay, tri: &[Vec3; 3], tmax: f32) -> Option<TriangleHit> {
    let (xy, z) = project::<KZ>(ray, tri);
    exact_test(ray, tri, tmax, edge_functions_f64(xy), z)
}

/// [`in_f64`] from the exact edge functions and the corners' distances along the dominant axis.
#[inline(always)]
fn exact_test(
    ray: &PreparedRay,
    tri: &[Vec3; 3],
    tmax: f32,
    [u, v, w]: [f64; 3],
    z: [f32; 3],
) -> Option<TriangleHit> {
    if mixed_signs([u, v, w]) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let [za, zb, zc] = z.map(f64::from);
    let t = ((u * za + v * zb + w * zc) / det * f64::from(ray.shear.z)) as f32;
    if !in_range(t, ray.tmin, tmax) {
        return None;
    }
    let hit = TriangleHit {
        t,
        u: (v / det) as f32,
        v: (w / det) as f32,
    };
    agree_with_bounds(ray, tri, tmax, hit)
}

/// Some edge function negative and another positive: the ray passes outside the triangle.
#[inline(always)]
fn mixed_signs<T: PartialOrd + Default>([u, v, w]: [T; 3]) -> bool {
    let zero = T::default();
    ((u < zero) | (v < zero) | (w < zero)) & ((u > zero) | (v > zero) | (w > zero))
}

/// The edge functions recomputed in `f64`, where the products of `f32` values are exact, so
/// their signs are exact on edges and vertices.
#[inline(always)]
fn edge_functions_f64(p: [f32; 6]) -> [f64; 3] {
    edge_functions(p.map(f64::from))
}

/// Below this, a distance's sum of terms is checked for terms that underflowed (2^-100).
const TINY_SUM: f32 = f32::from_bits((127 - 100) << 23);

/// Zero or subnormal: an `f32` that may have lost its sign or its precision to underflow.
#[inline(always)]
fn below_normal(x: f32) -> bool {
    x.abs() < f32::MIN_POSITIVE
}

/// Whether `product = x * y` lost precision to underflow (a tiny triangle seen from close by).
#[inline(always)]
fn underflows(product: f32, x: f32, y: f32) -> bool {
    below_normal(product) & (x != 0.0) & (y != 0.0)
}

/// `tmin <= t <= tmax` with a finite `t`; written so that a NaN `t` is out of range.
#[inline(always)]
fn in_range(t: f32, tmin: f32, tmax: f32) -> bool {
    t >= tmin && t <= tmax && t < f32::INFINITY
}

impl TriangleTest for MollerTrumbore {
    type AnyAxis = MollerTrumbore;

    #[inline(always)]
    fn intersect(ray: &PreparedRay, tri: &[Vec3; 3], tmax: f32) -> Option<TriangleHit> {
        let e1 = tri[1] - tri[0];
        let e2 = tri[2] - tri[0];
        let p = ray.dir.cross(e2);
        let det = e1.dot(p);
        if det == 0.0 {
            return None;
        }
        let inv_det = 1.0 / det;
        let s = ray.origin - tri[0];
        let u = s.dot(p) * inv_det;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = ray.dir.dot(q) * inv_det;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv_det;
        if !in_range(t, ray.tmin, tmax) {
            return None;
        }
        agree_with_bounds(ray, tri, tmax, TriangleHit { t, u, v })
    }
}

/// Makes a kernel hit consistent with the conservative box test, so that traversal can never
/// cull a box holding a hit the kernel would report (which would make answers depend on the
/// visiting order, and break the tie rule).
///
/// A kernel rounds its `t` and its edge tests on its own; the box test rounds differently. So a
/// hit is kept only if the ray passes the slab test of the triangle's own bounding box, and its
/// `t` is raised to at least the box's entry distance. The slab test is monotone in the box,
/// and every tree box contains its triangles' boxes, so any box holding a reported hit passes
/// the box test for every `tmax >= t`. Nothing the exact ray really hits is lost: the slab test
/// never rejects a box the exact ray touches. The extra work runs on hits only.
#[inline(always)]
fn agree_with_bounds(
    ray: &PreparedRay,
    tri: &[Vec3; 3],
    tmax: f32,
    hit: TriangleHit,
) -> Option<TriangleHit> {
    let min = tri[0].min(tri[1]).min(tri[2]);
    let max = tri[0].max(tri[1]).max(tri[2]);
    let entry = box_entry(min, max, ray, tmax);
    if entry == f32::INFINITY {
        return None;
    }
    Some(TriangleHit {
        // `+ 0.0` turns a -0 into +0, so that sorting by `t` agrees with the tie rule.
        t: hit.t.max(entry) + 0.0,
        ..hit
    })
}

/// True if the triangle has zero area as computed in `f64`: no kernel reports hits on it, and
/// the trees leave it out.
pub fn is_degenerate(tri: &[Vec3; 3]) -> bool {
    let a = tri[0].as_dvec3();
    let e1: DVec3 = tri[1].as_dvec3() - a;
    let e2: DVec3 = tri[2].as_dvec3() - a;
    e1.cross(e2) == DVec3::ZERO
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Ray;

    const TRI: [Vec3; 3] = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];

    fn both(o: Vec3, d: Vec3, tri: &[Vec3; 3]) -> [Option<TriangleHit>; 2] {
        let r = PreparedRay::new(&Ray::new(o, d)).unwrap();
        [
            Watertight::intersect(&r, tri, r.tmax),
            MollerTrumbore::intersect(&r, tri, r.tmax),
        ]
    }

    #[test]
    fn hit_reports_t_and_barycentrics() {
        for hit in both(Vec3::new(0.25, 0.5, 0.0), Vec3::Z, &TRI) {
            let h = hit.unwrap();
            assert_eq!(h.t, 1.0);
            assert!(
                (h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6,
                "{h:?}"
            );
        }
    }

    #[test]
    fn both_windings_hit_and_misses_miss() {
        let flipped = [TRI[0], TRI[2], TRI[1]];
        for hit in both(Vec3::new(0.25, 0.25, 3.0), -Vec3::Z, &flipped) {
            assert_eq!(hit.unwrap().t, 2.0);
        }
        for hit in both(Vec3::new(0.75, 0.75, 0.0), Vec3::Z, &TRI) {
            assert!(hit.is_none());
        }
    }

    #[test]
    fn watertight_includes_edges_and_vertices() {
        let r = |o: Vec3| PreparedRay::new(&Ray::new(o, Vec3::Z)).unwrap();
        for p in [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.5, 0.5, 0.0)] {
            let ray = r(p);
            assert!(
                Watertight::intersect(&ray, &TRI, f32::INFINITY).is_some(),
                "{p}"
            );
        }
    }

    #[test]
    fn degenerate_triangles_never_hit() {
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(is_degenerate(&line));
        assert!(!is_degenerate(&TRI));
        for hit in both(Vec3::new(0.5, 0.0, -1.0), Vec3::Z, &line) {
            assert!(hit.is_none());
        }
    }

    #[test]
    fn parallel_ray_misses() {
        for hit in both(Vec3::new(-1.0, 0.25, 1.0), Vec3::X, &TRI) {
            assert!(hit.is_none());
        }
    }

    /// A triangle of side `s` near the origin, tilted, and a ray through its middle from
    /// `1.5 s` away: hit at every scale, `t` and the barycentrics as at scale 1 (the `f32`
    /// products underflow from about 1e-13: the test then runs in `f64`).
    #[test]
    fn tiny_triangles_are_exact() {
        let unit = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.25),
            Vec3::new(0.0, 1.0, 0.75),
        ];
        let middle = (unit[0] + unit[1] + unit[2]) / 3.0;
        let origin = Vec3::new(middle.x, middle.y, middle.z - 1.5);
        let at_one = Watertight::intersect(
            &PreparedRay::new(&Ray::new(origin, Vec3::Z)).unwrap(),
            &unit,
            f32::INFINITY,
        )
        .unwrap();
        for exponent in [-10, -13, -15, -18, -22, -23, -26, -30, -34, -37] {
            let s = 10f32.powi(exponent);
            let tri = unit.map(|p| p * s);
            let ray = PreparedRay::new(&Ray::new(origin * s, Vec3::Z)).unwrap();
            let hit = Watertight::intersect(&ray, &tri, f32::INFINITY)
                .unwrap_or_else(|| panic!("missed at scale {s}"));
            assert!(
                ((hit.t / s) / at_one.t - 1.0).abs() < 1e-5,
                "{s}: t/s {}",
                hit.t / s
            );
            assert!((hit.u - at_one.u).abs() < 1e-5 && (hit.v - at_one.v).abs() < 1e-5);
            // The sign filter keeps every lane the kernel hits.
            let quad = crate::geom::sign_filter::RayQuad::from_rays([&ray; 4]);
            assert_eq!(quad.may_hit(&tri), 0b1111, "{s}");
        }
    }
}
