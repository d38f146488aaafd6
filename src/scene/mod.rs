//! Scenes: many meshes, each with its own tree, placed in the world as instances with rigid
//! transforms (and uniform scales), behind the same interface as one tree.
//!
//! A [`Scene`] holds meshes (any tree kind, chosen per mesh: [`crate::AnyAccel`]), instances
//! of them ([`InstanceDesc`]: a mesh, a [`Rigid`] transform, filter layers, a user value;
//! several instances may share a mesh), and a top-level tree over the instances' world boxes.
//! It answers every query of [`crate::RayQueries`] and [`crate::BatchQueries`], per ray and
//! batched, in *global* triangle ids; [`Scene::cast_ray_resolved`] and its batch form answer
//! with what a game reads (instance, triangle, world position and normal).
//! [`Scene::filtered`] applies a [`RayFilter`] (layers, an instance to pass through, back
//! faces, end points) to a query, [`Scene::filtered_batch`] one filter per ray of a batch.
//!
//! **What a scene answer is.** For each instance, the ray carried into its mesh space by
//! [`Rigid::ray_to_mesh`] (documented operations, see [`Rigid`]) is traced exactly against the
//! mesh; the scene keeps, over all instances, the closest hit by `t` and then lowest global id,
//! any hit, or every hit. At an identity transform that is the bare tree's answer bit for bit;
//! otherwise it is exact for the rounded mesh-space ray. A rotation preserves lengths and the
//! direction is not renormalised, so a hit's `t` matches the world ray's hit point up to the
//! transform's rounding: about `10 eps (|origin - translation| + |p|) / |dir|` for a hit at
//! mesh-space point `p` (`eps = 2^-23`; see [`Rigid`]). Culling in the top level never changes
//! an answer: its boxes are padded to cover the transform's rounding. Batched answers equal
//! per-ray answers bit for bit.
//!
//! Between frames: [`Scene::set_transform`] (one instance, refits its path),
//! [`Scene::set_transforms`] (many, one refit), [`Scene::rebuild_top`] (new top-level tree),
//! [`Scene::deform_mesh`] (new vertices, the mesh's AABB tree refitted),
//! [`Scene::add_mesh`] (a mesh for instances to come), [`Scene::add_instances`] (inserted into
//! the top level, the meshes' trees untouched),
//! [`Scene::remove_instance`] (its path refitted), [`Scene::set_mask`], [`Scene::set_user`].
//! Bad input is a [`SceneError`] and leaves the scene as it was.
//!
//! ```
//! use raybatch::glam::{Quat, Vec3};
//! use raybatch::scene::{InstanceDesc, Rigid, Scene};
//! use raybatch::{AccelKind, BatchQueries, BuildOptions, Mesh, Ray, RayQueries};
//!
//! // One quad in its own space, facing +z, placed twice: as is, and turned and moved.
//! let quad = Mesh::new(
//!     vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)],
//!     vec![[0, 1, 2], [0, 2, 3]],
//! )?;
//! let tree = AccelKind::DEFAULT.build(quad, &BuildOptions::default())?;
//! let door = Rigid::new(Quat::from_rotation_y(0.5), Vec3::new(0.0, 0.0, 5.0))?;
//! let mut scene = Scene::new(
//!     vec![tree],
//!     &[InstanceDesc::new(0, Rigid::IDENTITY), InstanceDesc::new(0, door)],
//! )?;
//!
//! let ray = Ray::new(Vec3::new(0.1, 0.2, 10.0), Vec3::NEG_Z);
//! let hit = scene.cast_ray_resolved(&ray).unwrap();
//! assert_eq!(hit.instance, 1); // the door is in front
//! assert!(hit.normal.z.abs() > 0.8); // turned by 0.5 rad about y
//!
//! // Open the door (a refit of its path in the top-level tree): the ray now reaches the wall.
//! scene.set_transform(1, Rigid::from_translation(Vec3::new(5.0, 0.0, 5.0))?)?;
//! assert_eq!(scene.cast_ray_resolved(&ray).unwrap().instance, 0);
//!
//! // Batched: the same answers as one ray at a time.
//! let rays = vec![ray; 3];
//! let mut hits = vec![None; 3];
//! scene.cast_ray_batch(&rays, &mut hits)?;
//! assert!(hits.iter().all(|h| *h == scene.cast_ray(&ray)));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod filter;
mod instance;
pub(crate) mod refit;
mod resolved;
mod rigid;
mod top;
mod trace;
mod world;

pub use error::SceneError;
pub use filter::{FilteredBatch, RayFilter, SceneView};
pub use instance::{ALL_LAYERS, Instance, InstanceDesc};
pub use resolved::SceneHit;
pub use rigid::{RIGID_TOLERANCE, Rigid};
pub use world::Scene;
