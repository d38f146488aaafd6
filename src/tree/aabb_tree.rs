//! The AABB tree: a binary BVH built with the binned SAH ([`super::build`]), stored in one of two
//! node formats ([`super::full_nodes`], 32 bytes, or [`super::quantized_nodes`], 16 bytes).
//!
//! The tree keeps the mesh (shared through an `Arc`, never copied or reordered) and a triangle
//! order array (4 bytes per triangle) that maps leaf slots to triangle ids; degenerate triangles
//! are left out of it, so they are never tested.

use std::sync::Arc;

use glam::Vec3;

use super::build::{BuildError, BuildOptions, BuiltTree, build};
use super::full_nodes::FullNodes;
use super::quantized_nodes::QuantizedNodes;
use super::{Bvh, NodeView};
use crate::mesh::Mesh;

/// A node storage format for [`AabbTree`], implemented by [`FullNodes`] and
/// [`QuantizedNodes`] in their own modules.
pub trait NodeFormat: Sized + Send + Sync {
    /// Name for tables.
    const NAME: &'static str;
    /// See [`Bvh::AVX2_TRAVERSAL`].
    const AVX2_TRAVERSAL: bool = true;
    /// Packs built nodes; fails if the format cannot address them.
    fn pack(built: &BuiltTree) -> Result<Self, BuildError>;
    fn node_count(&self) -> usize;
    fn view(&self, index: u32) -> NodeView;
    fn heap_bytes(&self) -> usize;
}

/// A binary AABB tree over a mesh, with node format `N`.
#[derive(Clone, Debug)]
pub struct AabbTree<N: NodeFormat = FullNodes> {
    mesh: Arc<Mesh>,
    nodes: N,
    triangle_order: Vec<u32>,
    /// Corners of each slot's triangle, if [`BuildOptions::leaf_corners`] (else empty).
    corners: Vec<[Vec3; 3]>,
    depth: usize,
    options: BuildOptions,
}

/// An [`AabbTree`] with 16-byte quantized nodes.
pub type QuantizedAabbTree = AabbTree<QuantizedNodes>;

impl<N: NodeFormat> AabbTree<N> {
    /// Builds the tree. Errors if the options are invalid or the mesh is too large for the
    /// node format; an empty mesh gives an empty tree that every ray misses.
    pub fn build(mesh: impl Into<Arc<Mesh>>, options: &BuildOptions) -> Result<Self, BuildError> {
        let mesh = mesh.into();
        let built = build(&mesh, options)?;
        let nodes = N::pack(&built)?;
        let corners = if options.leaf_corners {
            built
                .triangle_order
                .iter()
                .map(|&id| mesh.triangle(id))
                .collect()
        } else {
            Vec::new()
        };
        Ok(Self {
            mesh,
            nodes,
            corners,
            triangle_order: built.triangle_order,
            depth: built.depth,
            options: *options,
        })
    }

    /// The options the tree was built with.
    pub fn options(&self) -> &BuildOptions {
        &self.options
    }

    /// The shared mesh.
    pub fn mesh_arc(&self) -> &Arc<Mesh> {
        &self.mesh
    }
}

impl<N: NodeFormat> Bvh for AabbTree<N> {
    const AVX2_TRAVERSAL: bool = N::AVX2_TRAVERSAL;

    fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    fn node_count(&self) -> usize {
        self.nodes.node_count()
    }

    #[inline(always)]
    fn node(&self, index: u32) -> NodeView {
        self.nodes.view(index)
    }

    #[inline(always)]
    fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]) {
        let id = self.triangle_order[slot as usize];
        match self.corners.get(slot as usize) {
            Some(corners) => (id, *corners),
            None => (id, self.mesh.triangle(id)),
        }
    }

    fn depth(&self) -> usize {
        self.depth
    }

    fn heap_bytes(&self) -> usize {
        self.nodes.heap_bytes()
            + self.triangle_order.len() * size_of::<u32>()
            + self.corners.len() * size_of::<[Vec3; 3]>()
    }

    fn name(&self) -> &'static str {
        N::NAME
    }
}
