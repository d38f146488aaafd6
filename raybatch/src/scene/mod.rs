//! Scenes: many meshes, each with its own tree, placed in the world as instances with rigid
//! transforms, behind the same interface as one tree.
//!
//! A [`Scene`] holds meshes (any tree kind, chosen per mesh: [`MeshTree`]), instances of them
//! ([`InstanceDesc`]: a mesh, a [`Rigid`] transform, filter layers; several instances may
//! share a mesh), and a top-level tree over the instances' world boxes. It is an
//! [`crate::accel::Accel`], so every query of [`crate::query`] works on it, per ray and
//! batched, answering in *global* triangle ids ([`Scene::resolve`] gives instance and
//! triangle back). [`Scene::filtered`] restricts a query to some layers.
//!
//! **What a scene answer is.** For each instance, the ray carried into its mesh space by
//! [`Rigid::ray_to_mesh`] (documented operations, see [`rigid`]) is traced exactly against the
//! mesh; the scene keeps, over all instances, the closest hit by `t` and then lowest global id,
//! any hit, or every hit. At an identity transform that is the bare tree's answer bit for bit;
//! otherwise it is exact for the rounded mesh-space ray, whose `t` equals the world ray's up to
//! a few units in the last place (a rotation preserves lengths; the direction is not
//! renormalised). Culling in the top level never changes an answer: its boxes are padded to
//! cover the transform's rounding ([`instance`]). Batched answers equal per-ray answers bit
//! for bit.
//!
//! Between frames: [`Scene::set_transform`] (one instance, refits its path),
//! [`Scene::set_transforms`] (many, one refit), [`Scene::rebuild_top`] (new top-level tree),
//! [`Scene::deform_mesh`] (new vertices, the mesh's AABB tree refitted: [`refit`]). Bad input
//! is a [`SceneError`] and leaves the scene as it was.

pub mod error;
pub mod filter;
pub mod instance;
pub mod mesh_tree;
pub mod refit;
pub mod rigid;
mod top;
pub mod trace;
pub mod world;

pub use error::SceneError;
pub use filter::SceneView;
pub use instance::{ALL_LAYERS, Instance, InstanceDesc};
pub use mesh_tree::{MeshTree, SceneMesh};
pub use rigid::{RIGID_TOLERANCE, Rigid};
pub use trace::SceneScratch;
pub use world::{Scene, SceneHit};
