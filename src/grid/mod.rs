//! Spatial subdivision by cells: the uniform grid walked along the ray with a
//! 3D-DDA, and the spatial hash that walks the same cells without storing the empty ones.
//!
//! Unlike the BVHs, which split the triangles, these split space: a triangle is stored in
//! every cell its box overlaps, and a ray visits the cells it crosses in order, front to back,
//! so a closest-hit search stops at the first cell that cannot hold anything nearer.
//!
//! - `planes`: the exact plane coordinates the build and the walk share;
//! - [`sizing`]: how many cells ([`GridOptions`]);
//! - `cells`: the dense grid's compact storage (an occupancy bit per cell, the stored cells
//!   found by rank, a coarse cull box each, one array of references);
//! - `cull`: each stored cell's cull box, the bounds of what its triangles put inside it, so
//!   that rays crossing the cell away from them skip its triangle tests (exact in the hash,
//!   rounded out to 30 bits in the dense grid);
//! - `walk`: the exact 3D-DDA (the argument for exactness is in its docs);
//! - [`mailbox`]: a small per-thread set of tested triangles, so a triangle in several cells is
//!   tested once per ray;
//! - `scratch`: [`GridScratch`], a thread's mailbox and the order a batch's rays are walked
//!   in (Morton order of their origins: `crate::traverse::origin_order`);
//! - `uniform`: [`UniformGrid`], the dense grid;
//! - `table`: the hash table of non-empty cells (multiplicative hash, linear probing);
//! - `hash`: [`SpatialHash`], the sparse grid.

pub(crate) mod cells;
mod cull;
mod hash;
pub mod mailbox;
pub(crate) mod planes;
mod scratch;
pub mod sizing;
mod table;
pub(crate) mod uniform;
pub(crate) mod walk;

pub use hash::SpatialHash;
pub use mailbox::Mailbox;
pub use sizing::GridOptions;
pub use uniform::UniformGrid;
