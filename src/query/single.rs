//! One ray at a time: the engine behind [`RayQueries`], for every [`Accel`].
//!
//! Each query prepares the ray once, picks the kernel at compile time (the watertight kernel
//! monomorphized for the ray's dominant axis) and runs [`Accel::trace_alone`]: [`Accel::trace`]
//! with the thread's scratch for that structure ([`crate::workspace::Workspace`]), or a
//! stack of the walk's own.

use crate::accel::Accel;
use crate::geom::{Kernel, KernelTask, PreparedRay, Ray, TriangleTest};
use crate::hit::{Any, Closest, CountingClosest, EachHit, Hit, Visitor};

/// The single-ray queries. Every structure of the crate implements them (each compiled once,
/// in this crate); invalid rays miss and are occluded (see [`Ray::validate`]), and on equal
/// `t` the lowest triangle id wins. Usable as a trait object (`&dyn RayQueries`) but for its
/// generic methods.
pub trait RayQueries {
    /// The closest hit (watertight kernel), or `None`.
    fn cast_ray(&self, ray: &Ray) -> Option<Hit> {
        self.cast_ray_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::cast_ray`] with a chosen kernel.
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit>;

    /// [`RayQueries::cast_ray_with`], and how many nodes (leaves included; cells for the
    /// grids) the one-ray walk entered: the cost of the ray, for heat maps (see
    /// [`Visitor::enter_node`]). An invalid ray misses having entered none.
    fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32);

    /// True if the ray hits anything in `[tmin, tmax]` (line of sight is `!occluded` of a
    /// [`Ray::segment`]). Stops at the first hit found. An invalid ray (see [`Ray::validate`]:
    /// a NaN or infinite point, a segment of length zero) is occluded: a sightline built from
    /// a bad position fails closed, never reads as clear.
    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::occluded`] with a chosen kernel.
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool;

    /// Calls `f` once per triangle hit in `[tmin, tmax]`, in no particular order (watertight).
    fn for_each_hit(&self, ray: &Ray, mut f: impl FnMut(Hit))
    where
        Self: Sized,
    {
        self.for_each_hit_with(ray, Kernel::Watertight, &mut f)
    }

    /// [`RayQueries::for_each_hit`] with a chosen kernel.
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit));

    /// Every hit, sorted by `t` then triangle id (watertight).
    fn all_hits(&self, ray: &Ray) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.for_each_hit_with(ray, Kernel::Watertight, &mut |h| hits.push(h));
        Hit::sort(&mut hits);
        hits
    }

    /// Runs a visitor of the caller's over every hit of `ray` (as ray number 0): the walk
    /// behind every other query, for searches they do not cover ("the first N hits", a filter
    /// that skips some triangles). Compiled where it is called, for each visitor type.
    fn visit<V: Visitor>(&self, ray: &Ray, kernel: Kernel, visitor: &mut V)
    where
        Self: Sized;
}

/// Runs `visitor` over every hit of `ray` (prepared) with `kernel`, as ray number 0.
pub(crate) fn trace_one<A: Accel, V: Visitor>(
    accel: &A,
    ray: &PreparedRay,
    kernel: Kernel,
    visitor: &mut V,
) {
    kernel.dispatch(
        ray.kz as usize,
        TraceOne {
            accel,
            ray,
            visitor,
        },
    )
}

/// [`trace_one`] with the kernel chosen per test of the watertight kernel's axis
/// ([`Kernel::dispatch_any_axis`]): the same answers, compiled once per kernel.
pub(crate) fn trace_one_any_axis<A: Accel, V: Visitor>(
    accel: &A,
    ray: &PreparedRay,
    kernel: Kernel,
    visitor: &mut V,
) {
    kernel.dispatch_any_axis(TraceOne {
        accel,
        ray,
        visitor,
    })
}

/// [`Accel::trace_alone`] packaged for [`Kernel::dispatch`].
struct TraceOne<'a, A: Accel, V> {
    accel: &'a A,
    ray: &'a PreparedRay,
    visitor: &'a mut V,
}

impl<A: Accel, V: Visitor> KernelTask for TraceOne<'_, A, V> {
    type Output = ();
    #[inline(always)]
    fn run<K: TriangleTest>(self) {
        self.accel.trace_alone::<K, V>(self.ray, self.visitor);
    }
}

/// [`RayQueries::cast_ray_with`] on `accel`.
pub(crate) fn cast_ray_with<A: Accel>(accel: &A, ray: &Ray, kernel: Kernel) -> Option<Hit> {
    let prepared = PreparedRay::new(ray)?;
    let mut best = [Hit::none_before(prepared.tmax)];
    trace_one(accel, &prepared, kernel, &mut Closest { best: &mut best });
    best[0].found()
}

/// [`RayQueries::cast_ray_visits`] on `accel`.
pub(crate) fn cast_ray_visits<A: Accel>(
    accel: &A,
    ray: &Ray,
    kernel: Kernel,
) -> (Option<Hit>, u32) {
    let Some(prepared) = PreparedRay::new(ray) else {
        return (None, 0);
    };
    let mut best = [Hit::none_before(prepared.tmax)];
    let mut counting = CountingClosest {
        closest: Closest { best: &mut best },
        nodes: 0,
    };
    trace_one_any_axis(accel, &prepared, kernel, &mut counting);
    let nodes = counting.nodes;
    (best[0].found(), nodes)
}

/// [`RayQueries::occluded_with`] on `accel`.
pub(crate) fn occluded_with<A: Accel>(accel: &A, ray: &Ray, kernel: Kernel) -> bool {
    let Some(prepared) = PreparedRay::new(ray) else {
        return true; // An invalid ray is blocked: line of sight fails closed.
    };
    let mut occluded = [false];
    let mut any = Any {
        occluded: &mut occluded,
    };
    trace_one(accel, &prepared, kernel, &mut any);
    occluded[0]
}

/// [`RayQueries::visit`] on `accel`.
#[inline]
pub(crate) fn visit<A: Accel, V: Visitor>(accel: &A, ray: &Ray, kernel: Kernel, visitor: &mut V) {
    if let Some(prepared) = PreparedRay::new(ray) {
        trace_one(accel, &prepared, kernel, visitor);
    }
}

/// [`RayQueries::for_each_hit_with`] on `accel`.
pub(crate) fn for_each_hit_with<A: Accel>(
    accel: &A,
    ray: &Ray,
    kernel: Kernel,
    f: &mut dyn FnMut(Hit),
) {
    if let Some(prepared) = PreparedRay::new(ray) {
        trace_one_any_axis(accel, &prepared, kernel, &mut EachHit(f));
    }
}
