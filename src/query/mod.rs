//! The queries users call: closest hit, any hit (occlusion, line of sight) and all hits, one
//! ray at a time ([`RayQueries`]) or a batch at once ([`BatchQueries`]), written once on top of
//! [`crate::accel::Accel`] so that every structure gets all of them.
//!
//! The contract every structure and every path follows:
//! - **exact**: with the watertight kernel, a ray through a shared edge or vertex of a closed
//!   mesh hits it (no leaks); every answer equals [`brute_force`]'s over the same mesh;
//! - **the tie rule** of [`crate::hit`]: on equal `t` the lowest triangle id wins;
//! - **batched equals per ray** bit for bit (triangle, `t`, `u`, `v`, occlusion, the set of all
//!   hits), for any batch size, ray order, options or thread count;
//! - **no panic on bad input**: an invalid ray (NaN, infinite, zero direction, empty range)
//!   misses and is occluded, so line of sight fails closed ([`crate::geom::Ray::validate`] says
//!   why); mismatched slices are a [`BatchError`].

pub mod batched;
pub mod brute_force;
pub mod single;

pub use batched::{BatchError, BatchQueries};
pub use single::RayQueries;

/// Implements [`RayQueries`] and [`BatchQueries`] for each listed [`crate::accel::Accel`] with
/// the engines of [`single`] and [`batched`]. The impls are not generic, so each structure's
/// queries are compiled once, in this crate, instead of again in every crate that calls them.
/// (In the crate's own unit-test build they are inline, so only the queries a test calls are
/// compiled there.)
macro_rules! compiled_queries {
    ($($structure:ty),+ $(,)?) => {$(
        impl $crate::query::RayQueries for $structure {
            #[cfg_attr(test, inline)]
            fn cast_ray_with(
                &self,
                ray: &$crate::geom::Ray,
                kernel: $crate::geom::Kernel,
            ) -> Option<$crate::hit::Hit> {
                $crate::query::single::cast_ray_with(self, ray, kernel)
            }
            #[cfg_attr(test, inline)]
            fn cast_ray_visits(
                &self,
                ray: &$crate::geom::Ray,
                kernel: $crate::geom::Kernel,
            ) -> (Option<$crate::hit::Hit>, u32) {
                $crate::query::single::cast_ray_visits(self, ray, kernel)
            }
            #[cfg_attr(test, inline)]
            fn occluded_with(&self, ray: &$crate::geom::Ray, kernel: $crate::geom::Kernel) -> bool {
                $crate::query::single::occluded_with(self, ray, kernel)
            }
            #[cfg_attr(test, inline)]
            fn for_each_hit_with(
                &self,
                ray: &$crate::geom::Ray,
                kernel: $crate::geom::Kernel,
                f: &mut dyn FnMut($crate::hit::Hit),
            ) {
                $crate::query::single::for_each_hit_with(self, ray, kernel, f)
            }
            fn visit<V: $crate::hit::Visitor>(
                &self,
                ray: &$crate::geom::Ray,
                kernel: $crate::geom::Kernel,
                visitor: &mut V,
            ) where
                Self: Sized,
            {
                $crate::query::single::visit(self, ray, kernel, visitor)
            }
        }

        impl $crate::query::BatchQueries for $structure {
            #[cfg_attr(test, inline)]
            fn cast_ray_batch_with(
                &self,
                rays: &[$crate::geom::Ray],
                hits: &mut [Option<$crate::hit::Hit>],
                options: &$crate::batch::BatchOptions,
            ) -> Result<(), $crate::query::BatchError> {
                $crate::query::batched::cast_ray_batch_with(self, rays, hits, options)
            }
            #[cfg_attr(test, inline)]
            fn occluded_batch_with(
                &self,
                rays: &[$crate::geom::Ray],
                occluded: &mut [bool],
                options: &$crate::batch::BatchOptions,
            ) -> Result<(), $crate::query::BatchError> {
                $crate::query::batched::occluded_batch_with(self, rays, occluded, options)
            }
            #[cfg_attr(test, inline)]
            fn for_each_hit_batch_with(
                &self,
                rays: &[$crate::geom::Ray],
                options: &$crate::batch::BatchOptions,
                f: &(dyn Fn(usize, $crate::hit::Hit) + Sync),
            ) {
                $crate::query::batched::for_each_hit_batch_with(self, rays, options, f)
            }
        }
    )+};
}
pub(crate) use compiled_queries;
