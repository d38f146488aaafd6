//! [`ShapeQueries`]: the overlap and sweep queries, and the walks' two kinds of query.

use glam::{DVec3, Vec3};

use super::{BoxQuery, Contact, Earliest, Shape, ShapeError, check_motion};
use crate::catalog::AnyAccel;
use crate::geom::{Aabb, Ray};
use crate::query::RayQueries;

/// Overlap and sweep queries against a mesh (see [`crate::shape`]).
pub trait ShapeQueries {
    /// Whether `shape` overlaps any triangle (touching counts).
    fn overlaps(&self, shape: &Shape) -> Result<bool, ShapeError>;

    /// Calls `f` with the id of every triangle `shape` overlaps, each once, in no particular
    /// order.
    fn for_each_overlap(&self, shape: &Shape, f: &mut dyn FnMut(u32)) -> Result<(), ShapeError>;

    /// The ids of the triangles `shape` overlaps, ascending.
    fn overlapping(&self, shape: &Shape) -> Result<Vec<u32>, ShapeError> {
        let mut ids = Vec::new();
        self.for_each_overlap(shape, &mut |id| ids.push(id))?;
        ids.sort_unstable();
        Ok(ids)
    }

    /// The first contact of a sphere or capsule moved by `t * motion`, `t` from 0 to 1 (a
    /// shape already touching has `t = 0`); `None` if the path is clear. A box does not sweep
    /// ([`ShapeError::Invalid`]). A sphere of radius 0 is a ray: its contact is the ray
    /// query's hit from its centre along `motion` over `[0, 1]`, bit for bit.
    fn sweep(&self, shape: &Shape, motion: Vec3) -> Result<Option<Contact>, ShapeError>;

    /// Whether the sweep of `shape` by `motion` touches anything ("is the path clear" is the
    /// negation): the same answer as `sweep(..).is_some()`, stopping at the first contact.
    fn sweep_blocked(&self, shape: &Shape, motion: Vec3) -> Result<bool, ShapeError>;
}

impl ShapeQueries for AnyAccel {
    fn overlaps(&self, shape: &Shape) -> Result<bool, ShapeError> {
        let mut any = false;
        let mut query = Overlap::new(shape, |_| {
            any = true;
            true
        })?;
        self.walk_shape(&mut query)?;
        Ok(any)
    }

    fn for_each_overlap(&self, shape: &Shape, f: &mut dyn FnMut(u32)) -> Result<(), ShapeError> {
        let mut query = Overlap::new(shape, |id| {
            f(id);
            false
        })?;
        self.walk_shape(&mut query)
    }

    fn sweep(&self, shape: &Shape, motion: Vec3) -> Result<Option<Contact>, ShapeError> {
        if let Some(ray) = point_ray(shape, motion)? {
            return Ok(self.cast_ray(&ray).map(|hit| ray_contact(self, &ray, hit)));
        }
        let mut query = Sweep::new(shape, motion, false)?;
        self.walk_shape(&mut query)?;
        Ok(query.best.map(|first| shape.contact(motion, &first)))
    }

    fn sweep_blocked(&self, shape: &Shape, motion: Vec3) -> Result<bool, ShapeError> {
        if let Some(ray) = point_ray(shape, motion)? {
            return Ok(self.occluded(&ray));
        }
        let mut query = Sweep::new(shape, motion, true)?;
        self.walk_shape(&mut query)?;
        Ok(query.best.is_some())
    }
}

/// The ray a sweep of a sphere of radius 0 is (from its centre along a motion that is not
/// zero, over `[0, 1]`), after checking the inputs; `None` for any other sweep.
fn point_ray(shape: &Shape, motion: Vec3) -> Result<Option<Ray>, ShapeError> {
    shape.validate()?;
    check_motion(motion)?;
    Ok(match *shape {
        Shape::Sphere { centre, radius } if radius == 0.0 && motion != Vec3::ZERO => {
            Some(Ray::with_range(centre, motion, 0.0, 1.0)).filter(Ray::is_valid)
        }
        _ => None,
    })
}

/// A ray's hit as a sweep's contact: where the centre meets the triangle, the normal facing
/// the ray.
fn ray_contact(tree: &AnyAccel, ray: &Ray, hit: crate::Hit) -> Contact {
    let corners = tree.corners(hit.triangle).map(|c| c.as_dvec3());
    let normal = super::facing(corners, ray.dir.as_dvec3());
    Contact {
        t: hit.t,
        triangle: hit.triangle,
        point: ray.at(hit.t),
        normal: normal.as_vec3(),
    }
}

/// A margin that makes a box test in `f64` conservative against the triangle tests: far above
/// their rounding, far below any box's size that matters.
fn margin(scale: f64) -> f64 {
    1e-9 * scale + f64::MIN_POSITIVE
}

/// The overlap query: boxes against the shape's box (in `f64`, grown by a margin for the
/// round shapes), triangles by the exact test; `found` is told each overlapping id and says
/// whether to stop.
struct Overlap<'s, F> {
    shape: &'s Shape,
    low: DVec3,
    high: DVec3,
    found: F,
}

impl<'s, F: FnMut(u32) -> bool> Overlap<'s, F> {
    fn new(shape: &'s Shape, found: F) -> Result<Self, ShapeError> {
        shape.validate()?;
        let (low, high) = match shape.capsule() {
            // A box's own faces: the triangle test compares against exactly these.
            None => {
                let b = shape.bounds();
                (b.min.as_dvec3(), b.max.as_dvec3())
            }
            Some((a, b, r)) => {
                let (a, b, r) = (a.as_dvec3(), b.as_dvec3(), f64::from(r));
                let grow = r + margin(a.abs().max(b.abs()).max_element() + r);
                (a.min(b) - grow, a.max(b) + grow)
            }
        };
        Ok(Self {
            shape,
            low,
            high,
            found,
        })
    }
}

impl<F: FnMut(u32) -> bool> Overlap<'_, F> {
    fn touches(&self, bounds: &Aabb) -> bool {
        let (min, max) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
        min.cmple(self.high).all() && max.cmpge(self.low).all()
    }
}

impl<F: FnMut(u32) -> bool> BoxQuery for Overlap<'_, F> {
    fn entry(&self, bounds: &Aabb) -> Option<f64> {
        self.touches(bounds).then_some(0.0)
    }

    fn triangle(&mut self, id: u32, corners: &[Vec3; 3]) -> bool {
        // The triangle's own box first: most of a leaf's triangles fail it.
        self.touches(&Aabb::from_points(corners))
            && self.shape.overlaps_triangle(corners)
            && (self.found)(id)
    }
}

/// The sweep query: a box is entered if the motion's ray from the origin meets it grown by
/// the shape (its box minus the shape's segment, plus the radius) before the best contact.
struct Sweep<'s> {
    shape: &'s Shape,
    motion: Vec3,
    /// The shape's segment's lowest and highest corner, and its radius, in `f64`.
    low: DVec3,
    high: DVec3,
    radius: f64,
    /// Stop at the first contact.
    any: bool,
    best: Option<Earliest>,
}

impl<'s> Sweep<'s> {
    fn new(shape: &'s Shape, motion: Vec3, any: bool) -> Result<Self, ShapeError> {
        let Some((a, b, radius)) = shape.capsule() else {
            return Err(ShapeError::Invalid("a box does not sweep"));
        };
        let (a, b) = (a.as_dvec3(), b.as_dvec3());
        Ok(Self {
            shape,
            motion,
            low: a.min(b),
            high: a.max(b),
            radius: f64::from(radius),
            any,
            best: None,
        })
    }
}

impl Sweep<'_> {
    /// The best contact's time so far (1 before any).
    fn end(&self) -> f64 {
        self.best.as_ref().map_or(1.0, |b| b.t)
    }
}

impl BoxQuery for Sweep<'_> {
    const NEAREST_FIRST: bool = true;

    fn entry(&self, bounds: &Aabb) -> Option<f64> {
        if bounds.is_empty() {
            return None;
        }
        let (min, max) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
        let scale = min
            .abs()
            .max(max.abs())
            .max(self.high.abs())
            .max(self.low.abs());
        let grow = self.radius + margin(scale.max_element() + self.radius);
        let (lo, hi) = (min - self.high - grow, max - self.low + grow);
        let d = self.motion.as_dvec3();
        let (mut near, mut far) = (0.0f64, self.end());
        for axis in 0..3 {
            if d[axis] == 0.0 {
                if lo[axis] > 0.0 || hi[axis] < 0.0 {
                    return None;
                }
                continue;
            }
            let (t0, t1) = (lo[axis] / d[axis], hi[axis] / d[axis]);
            near = near.max(t0.min(t1));
            far = far.min(t0.max(t1));
        }
        (near <= far).then_some(near)
    }

    fn still_reaches(&self, entry: f64) -> bool {
        entry <= self.end()
    }

    fn triangle(&mut self, id: u32, corners: &[Vec3; 3]) -> bool {
        // The triangle's own box first (and against the best contact so far): the exact
        // test costs dozens of box tests.
        if self.entry(&Aabb::from_points(corners)).is_none() {
            return false;
        }
        match self.shape.sweep_time(self.motion, corners) {
            Some(t) => Earliest::keep(&mut self.best, t, id, corners) && self.any,
            None => false,
        }
    }
}
