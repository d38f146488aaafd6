//! Geometry kernels: rays, boxes and ray/triangle tests.

pub mod aabb;
pub mod ray;
pub mod triangle;

pub use aabb::Aabb;
pub use ray::{PreparedRay, Ray, RayError, octant};
pub use triangle::{
    Kernel, KernelTask, MollerTrumbore, TriangleHit, TriangleTest, Watertight, WatertightAxis,
    is_degenerate,
};
