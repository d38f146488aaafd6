//! The triangle tests of the shape queries, in `f64` on the mesh's `f32` corners.
//!
//! Every test is closed: touching counts (a sphere whose surface meets an edge overlaps it).
//! The inputs are `f32`, so every difference of two coordinates is exact in `f64` and each
//! test rounds only in its products and square roots: about 1e-15 of the scene's size, far
//! below the `f32` spacing of the inputs. Results may still differ from exact arithmetic by
//! that much where a contact is grazing: the tests hold sweep times to within 1e-7 of a
//! search over time on shapes and motions of unit size, and distances to within 1e-9.
//!
//! A sweep's first contact is that of a ray (the motion, from the origin) with the triangle
//! grown by the shape: the Minkowski sum of the triangle and the capsule's reversed segment
//! is the convex hull of six points, and growing it by the radius gives spheres at those
//! points, cylinders along the segments between them and slabs over its faces (both
//! triangles and the three parallelograms an edge sweeps). Testing every one of them, not
//! only the hull's, gives the same first time: each lies inside the grown hull, and the
//! hull's own features cover its boundary.

use glam::DVec3;

/// The point of triangle `[a, b, c]` nearest to `p` (Ericson, "Real-Time Collision Detection",
/// 5.1.5: the Voronoi regions of the corners, then of the edges, else the face).
pub(crate) fn closest_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let sum = va + vb + vc;
    if sum <= 0.0 {
        // A degenerate triangle (the trees hold none; brute force may): its nearest edge.
        return nearest_on_edges(p, [a, b, c]);
    }
    a + ab * (vb / sum) + ac * (vc / sum)
}

/// The nearest to `p` of the closest points of the three edges of a degenerate triangle.
fn nearest_on_edges(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    [(a, b), (b, c), (c, a)]
        .map(|(x, y)| closest_on_segment(p, x, y))
        .into_iter()
        .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
        .unwrap_or(a)
}

/// The point of segment `[x, y]` nearest to `p`.
fn closest_on_segment(p: DVec3, x: DVec3, y: DVec3) -> DVec3 {
    let e = y - x;
    let ee = e.dot(e);
    if ee == 0.0 {
        return x;
    }
    x + e * ((p - x).dot(e) / ee).clamp(0.0, 1.0)
}

/// The closest points of segments `[p1, q1]` and `[p2, q2]` (Ericson 5.1.9).
fn closest_segment_segment(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> (DVec3, DVec3) {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    if a == 0.0 && e == 0.0 {
        return (p1, p2);
    }
    let (s, t) = if a == 0.0 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e == 0.0 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    (p1 + d1 * s, p2 + d2 * t)
}

/// Whether segment `[p, q]` meets triangle `[a, b, c]` (boundaries included): it spans the
/// triangle's plane and its line passes inside all three edges.
fn segment_meets_triangle(p: DVec3, q: DVec3, [a, b, c]: [DVec3; 3]) -> Option<DVec3> {
    let n = (b - a).cross(c - a);
    let (dp, dq) = (n.dot(p - a), n.dot(q - a));
    if dp * dq > 0.0 || (dp == 0.0 && dq == 0.0) {
        return None;
    }
    let line = q - p;
    let side = |x: DVec3, y: DVec3| line.dot((x - p).cross(y - p));
    let (u, v, w) = (side(a, b), side(b, c), side(c, a));
    let inside = (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
    inside.then(|| p + line * (dp / (dp - dq)))
}

/// The closest points of segment `[p, q]` and triangle `t`: `(on the segment, on the
/// triangle)`.
pub(crate) fn closest_segment_triangle(p: DVec3, q: DVec3, t: [DVec3; 3]) -> (DVec3, DVec3) {
    if let Some(x) = segment_meets_triangle(p, q, t) {
        return (x, x);
    }
    let mut best = (p, closest_on_triangle(p, t));
    let mut consider = |pair: (DVec3, DVec3)| {
        if pair.0.distance_squared(pair.1) < best.0.distance_squared(best.1) {
            best = pair;
        }
    };
    if q != p {
        consider((q, closest_on_triangle(q, t)));
        for (x, y) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            consider(closest_segment_segment(p, q, x, y));
        }
    }
    best
}

/// Whether the closed box of centre `centre` and half sizes `half` overlaps triangle `t`
/// (the separating-axis test of Akenine-Möller: the box's axes, the triangle's normal and the
/// nine cross products of their edges; an axis that separates nothing, such as a zero cross
/// product, never separates).
pub(crate) fn box_overlaps_triangle(centre: DVec3, half: DVec3, t: [DVec3; 3]) -> bool {
    let v = t.map(|x| x - centre);
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let separates = |axis: DVec3| {
        let p = v.map(|x| axis.dot(x));
        let radius = half.dot(axis.abs());
        let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
        lo > radius || hi < -radius
    };
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    if axes.iter().any(|&a| separates(a)) || separates(edges[0].cross(edges[1])) {
        return false;
    }
    !axes
        .iter()
        .any(|&a| edges.iter().any(|&e| separates(a.cross(e))))
}

/// The first time `t >= 0` at which the point `t * d` comes within `r` of `x`.
fn ray_sphere(d: DVec3, x: DVec3, r: f64) -> Option<f64> {
    let (a, b, c) = (d.dot(d), d.dot(x), x.dot(x) - r * r);
    let disc = b * b - a * c;
    if a == 0.0 || disc < 0.0 {
        return None;
    }
    let t = (b - disc.sqrt()) / a;
    (t >= 0.0).then_some(t)
}

/// The first time `t >= 0` at which the point `t * d` comes within `r` of segment `[x, y]`
/// with its nearest point strictly between the ends (the ends are [`ray_sphere`]'s).
fn ray_cylinder(d: DVec3, x: DVec3, y: DVec3, r: f64) -> Option<f64> {
    let (e, m) = (y - x, -x);
    let (ee, md, nd) = (e.dot(e), m.dot(e), d.dot(e));
    let a = ee * d.dot(d) - nd * nd;
    let b = ee * m.dot(d) - nd * md;
    let c = ee * (m.dot(m) - r * r) - md * md;
    let disc = b * b - a * c;
    if ee == 0.0 || a <= 0.0 || disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / a;
    let s = (md + t * nd) / ee;
    (t >= 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
}

/// The first time `t >= 0` at which the point `t * d` comes within `r` of the plane of the
/// convex polygon `corners` (in order) at a point over the polygon, coming from outside the
/// slab; `None` for a polygon of no area.
fn ray_slab(d: DVec3, corners: &[DVec3], r: f64) -> Option<f64> {
    let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
    let length = n.length();
    if length == 0.0 {
        return None;
    }
    let n = n / length;
    let s0 = -n.dot(corners[0]);
    let nd = n.dot(d);
    let side = s0.signum();
    if s0.abs() <= r || side * nd >= 0.0 {
        return None;
    }
    let t = (side * r - s0) / nd;
    let x = d * t - n * (side * r);
    let k = corners.len();
    let inside = (0..k).all(|i| {
        let (p, q) = (corners[i], corners[(i + 1) % k]);
        n.dot((q - p).cross(x - p)) >= 0.0
    });
    inside.then_some(t)
}

/// Whether the capsule of segment `[a, b]` and radius `r` overlaps triangle `tri` (touching
/// counts): the triangle's plane first, then the closest points.
pub(crate) fn capsule_overlaps_triangle(a: DVec3, b: DVec3, r: f64, tri: [DVec3; 3]) -> bool {
    if plane_separates(a, b, r, DVec3::ZERO, tri) {
        return false;
    }
    let (on_shape, on_triangle) = closest_segment_triangle(a, b, tri);
    on_shape.distance_squared(on_triangle) <= r * r
}

/// Whether the triangle's plane keeps the capsule of segment `[a, b]` and radius `r` clear of
/// it over the whole motion `d`: the four ends of the swept segment lie farther than `r` from
/// the plane, on one side. Most triangles near a sweep fail this cheap test, which needs no
/// closest points; its margin (`1e-9` of the distances involved, far above the rounding of
/// either test) leaves a grazing contact to the exact test.
fn plane_separates(a: DVec3, b: DVec3, r: f64, d: DVec3, [p, q, s]: [DVec3; 3]) -> bool {
    let n = (q - p).cross(s - p);
    let length = n.length();
    if length == 0.0 {
        return false;
    }
    let scale = (a - p).abs().max((b - p).abs()).max_element() + d.abs().max_element() + r;
    let reach = (r + 1e-9 * scale) * length;
    let side = |x: DVec3| n.dot(x - p);
    let (da, db) = (side(a), side(b));
    let (ea, eb) = (da + n.dot(d), db + n.dot(d));
    let (lo, hi) = (da.min(db).min(ea.min(eb)), da.max(db).max(ea.max(eb)));
    lo > reach || hi < -reach
}

/// The first time in `[0, 1]` at which the capsule of segment `[a, b]` and radius `r`, moved
/// by `t * d`, touches triangle `tri` (0 if it touches at the start); a sphere is `a == b`.
pub(crate) fn sweep_time(a: DVec3, b: DVec3, r: f64, d: DVec3, tri: [DVec3; 3]) -> Option<f64> {
    if plane_separates(a, b, r, d, tri) {
        return None;
    }
    if capsule_overlaps_triangle(a, b, r, tri) {
        return Some(0.0);
    }
    // The grown hull's generators: the triangle's corners minus each end of the segment.
    let ends = if a == b { 1 } else { 2 };
    let points: [DVec3; 6] = std::array::from_fn(|k| tri[k % 3] - if k < 3 { a } else { b });
    let points = &points[..3 * ends];
    let mut first = f64::INFINITY;
    let mut keep = |t: Option<f64>| {
        if let Some(t) = t {
            first = first.min(t);
        }
    };
    for (i, &x) in points.iter().enumerate() {
        keep(ray_sphere(d, x, r));
        for &y in &points[i + 1..] {
            keep(ray_cylinder(d, x, y, r));
        }
    }
    for face in points.chunks(3) {
        keep(ray_slab(d, face, r));
    }
    if ends == 2 {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            keep(ray_slab(
                d,
                &[points[i], points[j], points[3 + j], points[3 + i]],
                r,
            ));
        }
    }
    (first <= 1.0).then_some(first)
}
