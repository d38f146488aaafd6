//! # raybatch
//!
//! Large batches of ray queries against indexed triangle meshes: closest hit, any hit (line of
//! sight, occlusion) and all hits, exact (watertight) and fast.
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
//! Module map: [`geom`] (rays, boxes, triangle kernels), [`mesh`] (validated meshes, OBJ),
//! [`tree`] (the trees and their traversal interface), [`query`] (the query engines).

pub mod geom;
pub mod mesh;
pub mod obj;
pub mod query;
pub mod scenes;
pub mod tree;

pub use geom::{Aabb, Kernel, Ray, RayError};
pub use glam;
pub use mesh::{Mesh, MeshError};
pub use query::Hit;
pub use query::batch::{BatchError, BatchOptions, BatchOrdering, BatchQueries};
pub use query::single::RayQueries;
pub use tree::{AabbTree, BuildError, BuildOptions, Bvh, ChildOrdering, QuantizedAabbTree};
