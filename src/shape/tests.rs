//! The triangle tests against references built another way: the box test against clipping
//! the triangle by the box's planes, the distances against a search along the segment, the
//! sweep times against a search over time of the distance (convex in time, so its first
//! crossing of the radius is found by a minimum search, then bisection).

use glam::{DVec3, Vec3};

use super::exact::{box_overlaps_triangle, closest_segment_triangle, sweep_time};
use super::{Shape, exact};
use crate::test_support::TestRng;

fn d3(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

fn random_triangle(rng: &mut TestRng) -> [DVec3; 3] {
    [(); 3].map(|_| d3(rng.vec3(1.0)))
}

/// Whether the triangle keeps any area or point inside the closed box: the polygon clipped by
/// the six half-spaces (Sutherland-Hodgman) is not empty.
fn clipped_is_nonempty(min: DVec3, max: DVec3, t: [DVec3; 3]) -> bool {
    let mut polygon = t.to_vec();
    for axis in 0..3 {
        for (bound, keep_below) in [(max[axis], true), (min[axis], false)] {
            let inside = |p: &DVec3| {
                if keep_below {
                    p[axis] <= bound
                } else {
                    p[axis] >= bound
                }
            };
            let mut out = Vec::new();
            for i in 0..polygon.len() {
                let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
                if inside(&p) {
                    out.push(p);
                }
                if inside(&p) != inside(&q) {
                    let s = (bound - p[axis]) / (q[axis] - p[axis]);
                    let mut x = p + (q - p) * s;
                    x[axis] = bound;
                    out.push(x);
                }
            }
            polygon = out;
            if polygon.is_empty() {
                return false;
            }
        }
    }
    true
}

#[test]
fn the_box_test_agrees_with_clipping() {
    let mut rng = TestRng::new(11);
    let mut overlapping = 0;
    for _ in 0..20_000 {
        let t = random_triangle(&mut rng);
        let centre = d3(rng.vec3(1.0));
        let half = d3(Vec3::new(
            rng.range(0.01, 0.6),
            rng.range(0.01, 0.6),
            rng.range(0.01, 0.6),
        ));
        let expected = clipped_is_nonempty(centre - half, centre + half, t);
        assert_eq!(
            box_overlaps_triangle(centre, half, t),
            expected,
            "{t:?} {centre} {half}"
        );
        overlapping += usize::from(expected);
    }
    assert!((2_000..18_000).contains(&overlapping), "{overlapping}");
}

/// The distance from segment `[p, q]` to triangle `t` by a golden-section search along the
/// segment (the distance to a convex set is convex along a segment), the point's distance by
/// the closest point.
fn searched_distance(p: DVec3, q: DVec3, t: [DVec3; 3]) -> f64 {
    let at = |s: f64| {
        let x = p + (q - p) * s;
        x.distance(exact::closest_on_triangle(x, t))
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..200 {
        let (a, b) = (lo + (hi - lo) * 0.382, lo + (hi - lo) * 0.618);
        if at(a) <= at(b) { hi = b } else { lo = a }
    }
    at((lo + hi) / 2.0).min(at(0.0)).min(at(1.0))
}

#[test]
fn segment_distances_agree_with_a_search() {
    let mut rng = TestRng::new(12);
    for _ in 0..20_000 {
        let t = random_triangle(&mut rng);
        let (p, q) = (d3(rng.vec3(1.5)), d3(rng.vec3(1.5)));
        let (a, b) = closest_segment_triangle(p, q, t);
        let expected = searched_distance(p, q, t);
        assert!(
            (a.distance(b) - expected).abs() <= 1e-9,
            "{} {expected}",
            a.distance(b)
        );
    }
}

#[test]
fn a_sphere_touching_an_edge_at_its_radius_overlaps() {
    let corners = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let touching = Shape::Sphere {
        centre: Vec3::new(0.5, -1.0, 0.0),
        radius: 1.0,
    };
    assert!(touching.overlaps_triangle(&corners));
    let short = Shape::Sphere {
        centre: Vec3::new(0.5, -1.0, 0.0),
        radius: 0.999_999,
    };
    assert!(!short.overlaps_triangle(&corners));
    let on_corner = Shape::Sphere {
        centre: Vec3::new(-3.0, -4.0, 0.0),
        radius: 5.0,
    };
    assert!(on_corner.overlaps_triangle(&corners));
    let a_box_on_a_face = Shape::Box(crate::Aabb::new(Vec3::new(0.1, 0.1, 0.0), Vec3::ONE));
    assert!(a_box_on_a_face.overlaps_triangle(&corners));
}

/// The first time the capsule `[a, b]` of radius `r` moved by `t * d` comes within `r` of
/// `t`, by search: the distance is convex in time.
fn searched_time(a: DVec3, b: DVec3, r: f64, d: DVec3, t: [DVec3; 3]) -> Option<f64> {
    let gap = |s: f64| {
        let (x, y) = closest_segment_triangle(a + d * s, b + d * s, t);
        x.distance(y) - r
    };
    if gap(0.0) <= 0.0 {
        return Some(0.0);
    }
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..200 {
        let (x, y) = (lo + (hi - lo) * 0.382, lo + (hi - lo) * 0.618);
        if gap(x) <= gap(y) { hi = y } else { lo = x }
    }
    let lowest = (lo + hi) / 2.0;
    if gap(lowest) > 0.0 {
        return None;
    }
    let (mut lo, mut hi) = (0.0, lowest);
    for _ in 0..200 {
        let mid = (lo + hi) / 2.0;
        if gap(mid) <= 0.0 { hi = mid } else { lo = mid }
    }
    Some(hi)
}

#[test]
fn sweep_times_agree_with_a_search() {
    let mut rng = TestRng::new(13);
    let (mut hits, mut misses) = (0, 0);
    for case in 0..20_000 {
        let t = random_triangle(&mut rng);
        let a = d3(rng.vec3(2.0));
        let b = if case % 2 == 0 {
            a
        } else {
            a + d3(rng.vec3(0.5))
        };
        let r = f64::from(rng.range(0.0, 0.4));
        // Half the motions aim at a point near the triangle, half anywhere.
        let aim = t[0]
            + (t[1] - t[0]) * f64::from(rng.range(0.0, 0.6))
            + (t[2] - t[0]) * f64::from(rng.range(0.0, 0.4));
        let d = if case % 4 < 2 {
            (aim - a) * f64::from(rng.range(0.5, 1.5)) + d3(rng.vec3(0.2))
        } else {
            d3(rng.vec3(3.0))
        };
        let found = sweep_time(a, b, r, d, t);
        let expected = searched_time(a, b, r, d, t);
        match (found, expected) {
            (Some(x), Some(y)) => {
                hits += 1;
                assert!((x - y).abs() <= 1e-7, "case {case}: {x} against {y}");
            }
            (None, None) => misses += 1,
            // A contact exactly at the end of the motion, or a graze, within the search's
            // tolerance.
            (x, y) => {
                let gap = |s: f64| {
                    let (p, q) = closest_segment_triangle(a + d * s, b + d * s, t);
                    p.distance(q) - r
                };
                let near = [x, y]
                    .into_iter()
                    .flatten()
                    .map(gap)
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    near.abs() <= 1e-7,
                    "case {case}: {x:?} against {y:?} ({near})"
                );
            }
        }
    }
    assert!(hits > 4_000 && misses > 4_000, "{hits} {misses}");
}

#[test]
fn a_sphere_resting_on_a_floor_touches_it_at_the_start_and_one_above_it_slides_clear() {
    let floor = [
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0),
    ]
    .map(d3);
    let (at, over) = (
        DVec3::new(0.5, 0.25, 0.5),
        DVec3::new(0.5, 0.25 + 1e-6, 0.5),
    );
    let slide = DVec3::new(1.0, 0.0, 0.0);
    assert_eq!(sweep_time(at, at, 0.25, slide, floor), Some(0.0));
    assert_eq!(sweep_time(over, over, 0.25, slide, floor), None);
}
