//! # raybatch
//!
//! Large batches of ray queries against indexed triangle meshes: closest hit, any hit (line of
//! sight, occlusion) and all hits, exact (watertight) and fast, per ray or a batch at a time,
//! with bit-identical answers either way.
//!
//! ```
//! use raybatch::{AabbTree, BuildOptions, Mesh, Ray, RayQueries};
//! use glam::Vec3;
//!
//! let mesh = Mesh::new(
//!     vec![Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0)],
//!     vec![[0, 1, 2]],
//! )?;
//! let tree: AabbTree = AabbTree::build(mesh, &BuildOptions::default())?;
//! let hit = tree.cast_ray(&Ray::new(Vec3::new(0.2, 0.2, 0.0), Vec3::Z)).unwrap();
//! assert_eq!((hit.triangle, hit.t), (0, 1.0));
//! assert!(tree.occluded(&Ray::segment(Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.2, 0.2, 2.0))));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! What is here:
//! - meshes and rays: [`Mesh`] (validated once; [`mesh`] also reads OBJ files and quantizes
//!   vertices), [`Ray`], [`Hit`] (the tie rule: on equal `t` the lowest triangle id wins);
//! - the structures, every one exact and answering alike: [`AccelKind`] names them,
//!   [`AccelKind::for_mesh`] picks one, [`AccelKind::build`] builds it as an [`AnyAccel`];
//!   each also has a type of its own ([`WideTree8`], [`AabbTree`], [`ZeroByteTree`], ...);
//! - the queries every structure answers: [`RayQueries`] one ray at a time, [`BatchQueries`]
//!   a batch at a time with the same answers bit for bit ([`BatchOptions`] holds the expert
//!   knobs), [`Visitor`] for searches of your own, [`brute_force`] as the reference;
//! - [`scene`]: many meshes placed as instances, with layers and edits between frames;
//! - [`users`]: what games build on the queries: a line-of-sight request queue and audio
//!   occlusion.
//!
//! ARCHITECTURE.md in the repository tells how the pieces fit; docs/benchmarks.md how fast
//! each structure is.

#![warn(missing_docs)]
#![deny(unsafe_code)]

mod accel;
mod batch;
mod bvh;
mod catalog;
pub mod cook;
mod geom;
mod grid;
mod hit;
mod huge_pages;
mod kdtree;
pub mod mesh;
mod parallel;
mod permuted;
mod prefetch;
mod query;
pub mod scene;
pub mod shape;
#[cfg(test)]
mod test_support;
mod traverse;
pub mod users;
mod wide;
mod workspace;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod x86;
pub mod zbt;

pub use accel::Footprint;
pub use batch::{BatchOptions, BatchOrdering, Interleave, PartitionKernel};
pub use bvh::{
    AabbTree, BuildError, BuildOptions, ChildOrdering, LeafCopy, MAX_LEAF_SIZE, QuantizedAabbTree,
    QuantizedVertexTree,
};
pub use catalog::{AccelKind, AnyAccel, KindTask, Structure};
pub use cook::CookError;
pub use geom::{Aabb, Kernel, Ray, RayError};
pub use glam;
pub use grid::{GridOptions, SpatialHash, UniformGrid};
pub use hit::{Hit, RAY_DONE, Visitor};
pub use kdtree::KdTree;
pub use mesh::{Mesh, MeshError};
pub use query::brute_force;
pub use query::{BatchError, BatchQueries, RayQueries};
pub use scene::{InstanceDesc, RayFilter, Rigid, Scene, SceneError, SceneHit};
pub use wide::{QuantizedWideTree, QuantizedWideTree8, WideTree, WideTree8};
pub use zbt::{HybridOptions, HybridTree, ZbtOptions, ZeroByteTree};

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
