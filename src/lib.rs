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
//! Module map (ARCHITECTURE.md in the repository tells how they fit):
//! - data: [`geom`] (rays, boxes, triangle kernels), [`mesh`] (validated meshes, OBJ);
//! - the interface: [`accel`] (what every structure implements), [`hit`] (hits, the tie rule,
//!   visitors), [`workspace`] (per-thread memory);
//! - structures: [`bvh`] (binary BVHs: build, ordering, node formats), [`wide`] (the 4- and
//!   8-wide BVHs collapsed from it; the 8-wide one is the default), [`zbt`] (the zero-byte
//!   tree and its hybrid, no memory beside the mesh), [`grid`] (the uniform grid and the
//!   spatial hash) and [`kdtree`], which split space;
//! - engines: [`traverse`] (how a BVH walks one ray or a stream), [`batch`] (batch machinery);
//! - adapters: [`permuted`] (a reordering structure answering in the original ids), [`scene`]
//!   (many meshes placed as instances, answering in world space);
//! - what users call: [`query`] (per-ray and batched queries, brute force), [`catalog`] (every
//!   structure by name, behind one dynamic type), [`users`] (a line-of-sight request queue,
//!   audio occlusion).

#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod accel;
pub mod batch;
pub mod bvh;
pub mod catalog;
pub mod geom;
pub mod grid;
pub mod hit;
mod huge_pages;
pub mod kdtree;
pub mod mesh;
mod parallel;
pub mod permuted;
mod prefetch;
pub mod query;
pub mod scene;
#[cfg(test)]
mod test_support;
pub mod traverse;
pub mod users;
pub mod wide;
pub mod workspace;
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod x86;
pub mod zbt;

pub use accel::{Accel, Footprint, RayStream, StreamLayout};
pub use batch::{BatchOptions, BatchOrdering, Interleave, PartitionKernel};
pub use bvh::{
    AabbTree, BuildError, BuildOptions, Bvh, ChildOrdering, LeafCopy, QuantizedAabbTree,
};
pub use catalog::{AccelKind, AnyAccel, KindTask, Structure};
pub use geom::{Aabb, Kernel, Ray, RayError};
pub use glam;
pub use grid::{GridOptions, SpatialHash, UniformGrid};
pub use hit::{Hit, Visitor};
pub use kdtree::KdTree;
pub use mesh::{Mesh, MeshError};
pub use query::{BatchError, BatchQueries, RayQueries};
pub use scene::{InstanceDesc, Rigid, Scene, SceneError, SceneHit};
pub use wide::{QuantizedWideTree, QuantizedWideTree8, WideTree, WideTree8};
pub use workspace::{StructureId, Workspace};
pub use zbt::{HybridTree, ZeroByteTree};
