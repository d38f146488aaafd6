//! One ray at a time: [`RayQueries`], for every [`Accel`].
//!
//! Each query prepares the ray once, picks the kernel at compile time (the watertight kernel
//! monomorphized for the ray's dominant axis) and runs [`Accel::trace_alone`]: [`Accel::trace`]
//! with the thread's scratch for that structure ([`crate::workspace::Workspace`]), or a
//! stack of the walk's own.

use crate::accel::Accel;
use crate::geom::{Kernel, KernelTask, PreparedRay, Ray, TriangleTest};
use crate::hit::{Any, Closest, CountingClosest, EachHit, Hit, Visitor};

/// Runs `visitor` over every hit of `ray` (prepared) with `kernel`, as ray number 0.
pub fn trace_one<A: Accel, V: Visitor>(
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

/// The single-ray queries, for every [`Accel`].
pub trait RayQueries: Accel {
    /// The closest hit (watertight kernel), or `None`. Invalid rays miss (see
    /// [`Ray::validate`]). On equal `t` the lowest triangle id wins.
    fn cast_ray(&self, ray: &Ray) -> Option<Hit> {
        self.cast_ray_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::cast_ray`] with a chosen kernel.
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        let prepared = PreparedRay::new(ray)?;
        let mut best = [Hit::none_before(prepared.tmax)];
        trace_one(self, &prepared, kernel, &mut Closest { best: &mut best });
        best[0].found()
    }

    /// [`RayQueries::cast_ray_with`], and how many nodes (leaves included; cells for the
    /// grids) the one-ray walk entered: the cost of the ray, for heat maps (see
    /// [`Visitor::enter_node`]). An invalid ray misses having entered none.
    fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32) {
        let Some(prepared) = PreparedRay::new(ray) else {
            return (None, 0);
        };
        let mut best = [Hit::none_before(prepared.tmax)];
        let mut counting = CountingClosest {
            closest: Closest { best: &mut best },
            nodes: 0,
        };
        trace_one(self, &prepared, kernel, &mut counting);
        let nodes = counting.nodes;
        (best[0].found(), nodes)
    }

    /// True if the ray hits anything in `[tmin, tmax]` (line of sight is `!occluded` of a
    /// [`Ray::segment`]). Stops at the first hit found.
    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::occluded`] with a chosen kernel.
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        let Some(prepared) = PreparedRay::new(ray) else {
            return false;
        };
        let mut occluded = [false];
        let mut any = Any {
            occluded: &mut occluded,
        };
        trace_one(self, &prepared, kernel, &mut any);
        occluded[0]
    }

    /// Calls `f` once per triangle hit in `[tmin, tmax]`, in no particular order (watertight).
    fn for_each_hit(&self, ray: &Ray, f: impl FnMut(Hit)) {
        self.for_each_hit_with(ray, Kernel::Watertight, f)
    }

    /// [`RayQueries::for_each_hit`] with a chosen kernel.
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: impl FnMut(Hit)) {
        if let Some(prepared) = PreparedRay::new(ray) {
            trace_one(self, &prepared, kernel, &mut EachHit(f));
        }
    }

    /// Every hit, sorted by `t` then triangle id (watertight).
    fn all_hits(&self, ray: &Ray) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.for_each_hit(ray, |h| hits.push(h));
        Hit::sort(&mut hits);
        hits
    }
}

impl<A: Accel> RayQueries for A {}
