//! Shape queries: which triangles a sphere, a box or a capsule overlaps, and when a sphere or
//! a capsule moved along a segment first touches the mesh.
//!
//! Game AI asks more than "can A see B": an agent has a radius, so "can it walk from A to B"
//! is a capsule swept along the segment, and "which walls are within 2 m" an overlap. The
//! queries walk a tree as the rays do, entering every node whose box the shape (or the volume
//! it sweeps) may touch, and decide each triangle in `f64` (the `exact` module): culls are
//! conservative, the triangle tests closed (touching counts) and the same for every
//! structure that answers, so a tree's answer equals [`brute_force`]'s, the tie rule
//! included (on equal contact times the lowest triangle id wins).
//!
//! The binary AABB trees and the wide trees answer ([`ShapeQueries`] on [`crate::AnyAccel`]);
//! the zero-byte trees, the grids and the kd-tree return [`ShapeError::Unsupported`].

pub mod brute_force;
pub(crate) mod exact;
mod query;
mod walk;

use glam::{DVec3, Vec3};

use crate::catalog::AccelKind;
use crate::geom::Aabb;

pub use query::ShapeQueries;
pub(crate) use walk::{BoxQuery, ShapeWalk, push_order};

/// A solid shape: a ball, an axis-aligned box or a capsule (the points within `radius` of a
/// segment), closed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The points within `radius` of `centre`.
    Sphere {
        /// Its centre.
        centre: Vec3,
        /// Its radius (0 is a point).
        radius: f32,
    },
    /// The points of the box, its faces included.
    Box(Aabb),
    /// The points within `radius` of the segment from `a` to `b` (a sphere if `a == b`).
    Capsule {
        /// One end of its segment.
        a: Vec3,
        /// The other end.
        b: Vec3,
        /// Its radius (0 is a segment).
        radius: f32,
    },
}

/// Where a moving shape first touches the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// The fraction of the motion at the first contact, in `[0, 1]` (0: touching at the start).
    pub t: f32,
    /// The triangle touched (the lowest id among those touched at `t`).
    pub triangle: u32,
    /// The point of the triangle nearest to the shape at `t`.
    pub point: Vec3,
    /// The unit direction from `point` towards the shape's centre line at `t` (the
    /// triangle's normal facing the shape where they meet at a point of the centre line).
    pub normal: Vec3,
}

/// Why a shape query was not answered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeError {
    /// The structure kind does not answer shape queries.
    Unsupported {
        /// Its kind.
        kind: AccelKind,
    },
    /// The shape or the motion cannot be answered truthfully (the reason).
    Invalid(&'static str),
}

impl std::fmt::Display for ShapeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ShapeError::Unsupported { kind } => {
                let answering: Vec<&str> = AccelKind::ALL
                    .iter()
                    .filter(|k| k.answers_shapes())
                    .map(|k| k.name())
                    .collect();
                write!(
                    f,
                    "the {} structure does not answer shape queries ({} do)",
                    kind.name(),
                    answering.join(", ")
                )
            }
            ShapeError::Invalid(why) => write!(f, "invalid shape query: {why}"),
        }
    }
}

impl std::error::Error for ShapeError {}

impl Shape {
    /// The shape as a capsule's segment ends and radius (a sphere is one with both ends at
    /// its centre), or the box it is.
    fn round_or_box(&self) -> Result<(Vec3, Vec3, f32), Aabb> {
        match *self {
            Shape::Sphere { centre, radius } => Ok((centre, centre, radius)),
            Shape::Capsule { a, b, radius } => Ok((a, b, radius)),
            Shape::Box(b) => Err(b),
        }
    }

    /// The shape as a capsule, if it is round.
    fn capsule(&self) -> Option<(Vec3, Vec3, f32)> {
        self.round_or_box().ok()
    }

    /// An error unless every coordinate is finite, the radius finite and at least 0, and a
    /// box's minimum at most its maximum.
    pub fn validate(&self) -> Result<(), ShapeError> {
        let finite = |points: &[Vec3]| points.iter().all(|p| p.is_finite());
        match self.round_or_box() {
            Err(b) if !finite(&[b.min, b.max]) => {
                Err(ShapeError::Invalid("a box corner is NaN or infinite"))
            }
            Err(b) if b.min.cmpgt(b.max).any() => {
                Err(ShapeError::Invalid("a box's minimum exceeds its maximum"))
            }
            Err(_) => Ok(()),
            Ok((a, b, radius)) => {
                if !finite(&[a, b]) {
                    Err(ShapeError::Invalid("a centre or an end is NaN or infinite"))
                } else if !(radius.is_finite() && radius >= 0.0) {
                    Err(ShapeError::Invalid(
                        "the radius is negative, NaN or infinite",
                    ))
                } else {
                    Ok(())
                }
            }
        }
    }

    /// The shape's bounding box.
    pub fn bounds(&self) -> Aabb {
        match self.round_or_box() {
            Err(b) => b,
            Ok((a, b, radius)) => {
                let r = Vec3::splat(radius);
                Aabb::new(a.min(b) - r, a.max(b) + r)
            }
        }
    }

    /// Whether the shape overlaps triangle `corners` (touching counts), decided in `f64`.
    pub fn overlaps_triangle(&self, corners: &[Vec3; 3]) -> bool {
        let t = corners.map(|c| c.as_dvec3());
        match self.round_or_box() {
            Err(b) => {
                let (min, max) = (b.min.as_dvec3(), b.max.as_dvec3());
                exact::box_overlaps_triangle((min + max) * 0.5, (max - min) * 0.5, t)
            }
            Ok((a, b, r)) => {
                exact::capsule_overlaps_triangle(a.as_dvec3(), b.as_dvec3(), r.into(), t)
            }
        }
    }

    /// When the shape moved by `t * motion` first touches triangle `corners`, as an `f64`
    /// time in `[0, 1]` (the order of contacts); `None` for a box (it does not sweep) or no
    /// contact.
    pub(crate) fn sweep_time(&self, motion: Vec3, corners: &[Vec3; 3]) -> Option<f64> {
        let (a, b, r) = self.capsule()?;
        let tri = corners.map(|c| c.as_dvec3());
        exact::sweep_time(
            a.as_dvec3(),
            b.as_dvec3(),
            f64::from(r),
            motion.as_dvec3(),
            tri,
        )
    }

    /// The contact of the shape moved by `motion` at the sweep's earliest touch `first`: the
    /// triangle's point nearest to the shape then, and the direction from it to the shape.
    /// (`first` comes from [`Shape::sweep_time`], so the shape is round.)
    fn contact(&self, motion: Vec3, first: &Earliest) -> Contact {
        let (a, b, _) = self.capsule().unwrap_or_default();
        let (t, d) = (first.t, motion.as_dvec3());
        let tri = first.corners.map(|c| c.as_dvec3());
        let (on_shape, on_triangle) =
            exact::closest_segment_triangle(a.as_dvec3() + d * t, b.as_dvec3() + d * t, tri);
        let normal = (on_shape - on_triangle)
            .try_normalize()
            .unwrap_or_else(|| facing(tri, d));
        Contact {
            t: t as f32,
            triangle: first.triangle,
            point: on_triangle.as_vec3(),
            normal: normal.as_vec3(),
        }
    }
}

/// A sweep's earliest touch so far: its `f64` time, triangle and corners. The contact's point
/// and normal are made once, for the touch that stays earliest ([`Shape::contact`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Earliest {
    t: f64,
    triangle: u32,
    corners: [Vec3; 3],
}

impl Earliest {
    /// Keeps the touch of triangle `triangle` at `t` in `best` if it comes first: earlier, or
    /// as early with a lower id (the tie rule). True if kept.
    fn keep(best: &mut Option<Earliest>, t: f64, triangle: u32, corners: &[Vec3; 3]) -> bool {
        let first = best
            .as_ref()
            .is_none_or(|b| (t, triangle) < (b.t, b.triangle));
        if first {
            *best = Some(Earliest {
                t,
                triangle,
                corners: *corners,
            });
        }
        first
    }
}

/// The triangle's unit normal facing against `motion` (the +z axis for a degenerate one).
fn facing([a, b, c]: [DVec3; 3], motion: DVec3) -> DVec3 {
    let n = (b - a).cross(c - a).try_normalize().unwrap_or(DVec3::Z);
    if n.dot(motion) > 0.0 { -n } else { n }
}

/// An error unless `motion` is finite.
fn check_motion(motion: Vec3) -> Result<(), ShapeError> {
    if motion.is_finite() {
        Ok(())
    } else {
        Err(ShapeError::Invalid("the motion is NaN or infinite"))
    }
}

#[cfg(test)]
mod tests;
