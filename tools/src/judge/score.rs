//! Scoring a mode's answers against the judge's.

use raybatch::{Hit, Ray};

use super::reference::{JudgeHit, Reference, plane_hit};

/// Tolerance of a true tie: a mode's triangle other than the judge's counts as a tie (not a
/// wrong triangle) if, in `f64`, the ray meets it with barycentrics all `>= -TIE_EPS` (on it,
/// up to rounding at its edges) at a distance within `TIE_EPS * max(|t|, |origin|)` of the
/// judge's (the same point, up to rounding of the origin): a neighbour sharing the edge or
/// vertex hit, or a coplanar duplicate.
pub const TIE_EPS: f64 = 1e-9;

/// How wrong one mode is on one ray set (see the module docs of [`crate::judge`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Score {
    /// Rays judged.
    pub rays: usize,
    /// The judge hits, the mode misses (on rays that must hit: leaks).
    pub missed: usize,
    /// The mode hits, the judge misses.
    pub extra: usize,
    /// Both hit, on different triangles that are not a true tie.
    pub wrong_triangle: usize,
    /// Both hit different triangles that are a true tie (not counted as wrong).
    pub ties: usize,
    /// Largest `|t - t_judge| / max(|t_judge|, |origin|)` over rays both hit.
    pub max_t_error: f64,
    /// Its mean over rays both hit.
    pub mean_t_error: f64,
}

impl Score {
    /// Rays on which the mode and the judge disagree on hit or miss, as a fraction.
    pub fn hit_miss_rate(&self) -> f64 {
        rate(self.missed + self.extra, self.rays)
    }

    /// Rays the mode missed although the judge hits, as a fraction.
    pub fn missed_rate(&self) -> f64 {
        rate(self.missed, self.rays)
    }

    /// Wrong triangles (true ties excluded), as a fraction of the rays.
    pub fn wrong_triangle_rate(&self) -> f64 {
        rate(self.wrong_triangle, self.rays)
    }
}

fn rate(count: usize, of: usize) -> f64 {
    if of == 0 {
        0.0
    } else {
        count as f64 / of as f64
    }
}

/// The distance scale of a ray's errors: `t` cannot be located better than the origin's own
/// rounding, so errors are relative to the larger of the two (and to 1e-30 at worst).
fn scale(ray: &Ray, t: f64) -> f64 {
    let origin = ray.origin.as_dvec3().abs().max_element();
    t.abs().max(origin).max(1e-30)
}

/// Scores `answers` (a mode's closest hits, one per ray) against `judged` (the judge's).
pub fn score(
    judge: &Reference,
    rays: &[Ray],
    judged: &[Option<JudgeHit>],
    answers: &[Option<Hit>],
) -> Score {
    assert!(rays.len() == judged.len() && rays.len() == answers.len());
    let mut s = Score {
        rays: rays.len(),
        ..Score::default()
    };
    let mut both = 0usize;
    let mut sum = 0.0;
    for ((ray, judged), answer) in rays.iter().zip(judged).zip(answers) {
        match (judged, answer) {
            (None, None) => {}
            (Some(_), None) => s.missed += 1,
            (None, Some(_)) => s.extra += 1,
            (Some(j), Some(a)) => {
                let scale = scale(ray, j.t);
                let err = (f64::from(a.t) - j.t).abs() / scale;
                s.max_t_error = s.max_t_error.max(err);
                sum += err;
                both += 1;
                if a.triangle != j.triangle {
                    if is_tie(judge, ray, j, a.triangle, scale) {
                        s.ties += 1;
                    } else {
                        s.wrong_triangle += 1;
                    }
                }
            }
        }
    }
    s.mean_t_error = if both == 0 { 0.0 } else { sum / both as f64 };
    s
}

/// True if `triangle` is met by `ray` at the judge's hit point, up to [`TIE_EPS`].
fn is_tie(judge: &Reference, ray: &Ray, j: &JudgeHit, triangle: u32, scale: f64) -> bool {
    plane_hit(ray, judge.triangle(triangle)).is_some_and(|(t, b)| {
        b.iter().all(|&x| x >= -TIE_EPS) && (t - j.t).abs() <= TIE_EPS * scale
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::judge::reference::test_mesh;
    use raybatch::glam::Vec3;

    fn hit(triangle: u32, t: f32) -> Option<Hit> {
        Some(Hit {
            triangle,
            t,
            u: 0.0,
            v: 0.0,
        })
    }

    #[test]
    fn counts_each_kind_of_disagreement() {
        // Triangles 0 and 1 share the edge x = 0 at z = 2; triangle 2 is at z = 5.
        let judge = Reference::new(&test_mesh());
        let down = |x: f32| Ray::new(Vec3::new(x, 0.0, 0.0), Vec3::Z);
        let rays = [
            down(-0.5),
            down(0.0),
            down(-0.5),
            down(1.5),
            down(9.0),
            down(0.5),
        ];
        let judged = judge.closest_all(&rays);
        let answers = [
            hit(0, 2.0),       // right
            hit(1, 2.0),       // on the shared edge: a tie
            hit(2, 5.0),       // wrong triangle, t error 3 / 2
            None,              // missed
            hit(2, 5.0),       // invented
            hit(1, 2.0000002), // right triangle, t error 1e-7
        ];
        let s = score(&judge, &rays, &judged, &answers);
        assert_eq!((s.rays, s.missed, s.extra), (6, 1, 1));
        assert_eq!((s.wrong_triangle, s.ties), (1, 1));
        assert_eq!(s.max_t_error, 1.5);
        let small = (2.0000002f32 as f64 - 2.0) / 2.0;
        assert!((s.mean_t_error - (1.5 + small) / 4.0).abs() < 1e-15);
        assert!((s.hit_miss_rate() - 2.0 / 6.0).abs() < 1e-15);
    }

    #[test]
    fn far_origins_scale_the_error() {
        let ray = Ray::new(Vec3::new(1e6, 0.0, 0.0), Vec3::Z);
        assert_eq!(scale(&ray, 2.0), 1e6);
        assert_eq!(scale(&Ray::new(Vec3::ZERO, Vec3::Z), 2.0), 2.0);
    }
}
