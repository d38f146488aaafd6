//! The zero-byte AABB tree and its hybrid: trees that need no memory beside the mesh.
//!
//! A zero-byte tree reorders the mesh's triangles so that every node is a run of 1 to 8
//! consecutive triangles whose box *is* the node's box (on the faces it does not inherit from
//! its parent's box), recomputed when needed, and hides the node's links, triangle count,
//! child-ordering byte and its children's inherited faces in the spare high bits of the vertex
//! indices. It is a binary tree whose nodes own triangles *and* have children, so both
//! traversal engines run it unchanged; the batched engine recomputes each node's box once per
//! batch visit.
//!
//! - `layout`: where the node data sits in the index bits (the limits follow from it);
//! - `cover`: which triangles define a node's box;
//! - `build`: the SAH build around those covers, and the faces children inherit;
//! - `packed`: reading nodes, boxes and triangles back from the packed mesh;
//! - `cache`: the per-thread box cache shared by every tree ([`BOX_CACHE_BYTES`]);
//! - `hybrid`: [`PackedTree`], the one implementation of both trees: [`HybridTree`], an AABB
//!   tree whose leaves are zero-byte trees over chunks of triangles (which lifts the triangle
//!   limit), and [`ZeroByteTree`], the same without the top level;
//! - `stats`: [`ZbtStats`], the shape of either tree's zero-byte parts;
//! - `tree`: the zero-byte tree's own build and limit.
//!
//! **Ids.** Both trees reorder the triangles and hand back the permutation (`new id -> original
//! id`) without keeping it (it would cost 4 bytes per triangle): hits report the tree's ids.
//! To use per-triangle data (materials), reorder it once: `data_new[i] = data[permutation[i]]`;
//! or keep the permutation and map each hit's id. The vertex array and each triangle's corner
//! order are never changed; [`ZeroByteTree::into_mesh`] gives back a plain mesh (in the tree's
//! order). [`crate::AnyAccel`] keeps the permutation beside both trees so that they answer in
//! the original ids like every other structure.

mod build;
mod cache;
mod cover;
mod hybrid;
mod layout;
mod packed;
mod stats;
mod tree;

pub use cache::BYTES as BOX_CACHE_BYTES;
pub use hybrid::{HybridOptions, HybridTree, PackedTree};
pub use layout::{MAX_TRIANGLES, MAX_VERTICES};
pub use stats::ZbtStats;
pub use tree::ZeroByteTree;

use crate::bvh::ChildOrdering;
use crate::mesh::Mesh;

/// How to build a [`ZeroByteTree`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZbtOptions {
    /// Sets of at most this many triangles (1..=8) become leaves.
    pub leaf_size: u32,
    /// A child inherits a face of its parent's box (and needs no triangle reaching it) when
    /// the gap is at most this fraction of the child's extent on that axis; 0 keeps every box
    /// exact, a negative or NaN slack inherits nothing. The default 0.1 measured best (0.1 to
    /// 0.25 within noise; 1 doubles the time: boxes too loose), see docs/benchmarks.md.
    pub inherit_slack: f32,
    /// Keep recomputed boxes in a per-thread cache ([`BOX_CACHE_BYTES`]) shared by every
    /// zero-byte tree the thread queries; off, every box is recomputed at every visit.
    pub box_cache: bool,
    /// How internal nodes order their children.
    pub ordering: ChildOrdering,
    /// Build large subtrees on rayon's thread pool.
    pub parallel: bool,
}

impl Default for ZbtOptions {
    fn default() -> Self {
        Self {
            leaf_size: 4,
            inherit_slack: 0.1,
            box_cache: true,
            ordering: ChildOrdering::Pns,
            parallel: true,
        }
    }
}

impl From<&crate::bvh::BuildOptions> for ZbtOptions {
    /// The zero-byte options that follow an AABB tree's: its leaf size capped at 8 (a node
    /// holds at most 8 triangles), its ordering and parallelism; the rest default.
    fn from(options: &crate::bvh::BuildOptions) -> Self {
        Self {
            leaf_size: options.max_leaf_size.clamp(1, layout::MAX_NODE_TRIANGLES),
            ordering: options.ordering,
            parallel: options.parallel,
            ..Self::default()
        }
    }
}

/// Why a zero-byte or hybrid tree could not be built.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ZbtError {
    /// More triangles than a zero-byte tree's 21-bit child offsets reach
    /// ([`MAX_TRIANGLES`]); the hybrid tree has no such limit.
    TooManyTriangles {
        /// Triangles in the mesh.
        count: usize,
        /// The most supported.
        max: usize,
    },
    /// More vertices than 24-bit indices address ([`MAX_VERTICES`]).
    TooManyVertices {
        /// Vertices in the mesh.
        count: usize,
        /// The most supported.
        max: usize,
    },
    /// `leaf_size` is not in 1..=8.
    BadLeafSize(u32),
    /// The hybrid tree's chunk size is not in 1..=[`MAX_TRIANGLES`].
    BadChunkSize(u32),
}

impl std::fmt::Display for ZbtError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ZbtError::TooManyTriangles { count, max } => write!(
                f,
                "{count} triangles is more than a zero-byte tree supports ({max}); \
                 the hybrid tree has no triangle limit"
            ),
            ZbtError::TooManyVertices { count, max } => write!(
                f,
                "{count} vertices is more than a zero-byte tree supports ({max}): \
                 vertex indices must leave 8 bits free"
            ),
            ZbtError::BadLeafSize(n) => write!(f, "leaf size {n} is not in 1..=8"),
            ZbtError::BadChunkSize(n) => {
                write!(f, "chunk size {n} is not in 1..={MAX_TRIANGLES}")
            }
        }
    }
}

impl std::error::Error for ZbtError {}

/// A failed build: why, and the mesh, handed back unchanged.
#[derive(Clone, Debug, PartialEq)]
pub struct Rejected {
    /// Why the tree could not be built.
    pub error: ZbtError,
    /// The mesh that was passed in.
    pub mesh: Mesh,
}

impl std::fmt::Display for Rejected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.error.fmt(f)
    }
}

impl std::error::Error for Rejected {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

/// Checks `mesh` against the limits every zero-byte tree shares (vertex indices below 2^24)
/// and the leaf size.
fn check_common(mesh: &Mesh, leaf_size: u32) -> Result<(), ZbtError> {
    if !(1..=layout::MAX_NODE_TRIANGLES).contains(&leaf_size) {
        return Err(ZbtError::BadLeafSize(leaf_size));
    }
    if mesh.vertices().len() > MAX_VERTICES {
        return Err(ZbtError::TooManyVertices {
            count: mesh.vertices().len(),
            max: MAX_VERTICES,
        });
    }
    Ok(())
}
