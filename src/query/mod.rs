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
//!   misses ([`crate::geom::Ray::validate`] says why); mismatched slices are a [`BatchError`].

pub mod batched;
pub mod brute_force;
pub mod single;

pub use batched::{BatchError, BatchQueries};
pub use single::RayQueries;
