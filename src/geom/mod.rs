//! Geometry kernels: rays, boxes and ray/triangle tests.

pub mod aabb;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
pub(crate) mod box_octet;
pub mod ray;
pub(crate) mod sign_filter;
pub mod triangle;

pub use aabb::Aabb;
pub use ray::{PreparedRay, Ray, RayError, octant};
pub use triangle::{Kernel, KernelTask, MollerTrumbore, TriangleTest, Watertight, is_degenerate};
