//! The AABB tree: a binary BVH built with the binned SAH ([`super::build`]), stored in one of two
//! node formats ([`super::nodes::full`], 32 bytes, or [`super::nodes::quantized`], 16 bytes).
//!
//! The tree keeps the mesh (shared through an `Arc`, never copied or reordered) and a triangle
//! order array (4 bytes per triangle) that maps leaf slots to triangle ids; degenerate triangles
//! are left out of it, so they are never tested.

use std::sync::Arc;

use glam::Vec3;

use super::build::{BuildError, BuildOptions, BuiltTree, build};
use super::leaves::{LeafCopy, LeafTriangles};
use super::nodes::{FullNodes, NodeFormat, QuantizedNodes};
use super::{Bvh, Node};
use crate::accel::Footprint;
use crate::geom::Aabb;
use crate::mesh::Mesh;

/// A binary AABB tree over a mesh, with node format `N`.
#[derive(Clone, Debug)]
pub struct AabbTree<N: NodeFormat = FullNodes> {
    pub(crate) nodes: N,
    pub(crate) triangles: LeafTriangles,
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
        Ok(Self::from_parts(nodes, mesh, built, *options))
    }

    /// The tree of `nodes`, packed from `built` over `mesh` with `options`.
    pub(crate) fn from_parts(
        nodes: N,
        mesh: Arc<Mesh>,
        built: BuiltTree,
        options: BuildOptions,
    ) -> Self {
        let copy = options.leaf_copy.or(LeafCopy::Nothing);
        Self {
            nodes,
            triangles: LeafTriangles::new(mesh, built.triangle_order, copy),
            depth: built.depth,
            options,
        }
    }

    /// The options the tree was built with.
    pub fn options(&self) -> &BuildOptions {
        &self.options
    }

    /// The mesh the tree was built over; triangle ids refer to it.
    pub fn mesh(&self) -> &Mesh {
        self.triangles.mesh()
    }
}

impl<N: NodeFormat> Bvh for AabbTree<N> {
    type Cache = ();
    type NodeBox = ();
    const AVX2_TRAVERSAL: bool = N::AVX2_TRAVERSAL;

    fn len(&self) -> usize {
        self.nodes.node_count()
    }

    fn root_bounds(&self, _: &mut ()) -> Aabb {
        self.nodes.bounds(0)
    }

    fn root_bounds_uncached(&self) -> Option<Aabb> {
        Some(self.nodes.bounds(0))
    }

    #[inline(always)]
    fn keep(_: &Aabb) {}

    #[inline(always)]
    fn child_bounds(&self, node: &Node, _: &(), _: &mut ()) -> [Aabb; 2] {
        let [a, b] = node.children;
        [self.nodes.bounds(a), self.nodes.bounds(b)]
    }

    #[inline(always)]
    fn node(&self, index: u32) -> Node {
        self.nodes.node(index)
    }

    #[inline(always)]
    fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]) {
        self.triangles.get(slot)
    }

    fn depth(&self) -> usize {
        self.depth
    }
}

crate::query::compiled_queries!(AabbTree, QuantizedAabbTree);

impl<N: NodeFormat> crate::accel::Corners for AabbTree<N> {
    fn corners(&self, id: u32) -> [glam::Vec3; 3] {
        self.mesh().triangle(id)
    }
}

impl<N: NodeFormat> Footprint for AabbTree<N> {
    fn name(&self) -> &'static str {
        N::NAME
    }

    fn triangle_count(&self) -> usize {
        self.mesh().triangle_count()
    }

    fn node_count(&self) -> usize {
        self.nodes.node_count()
    }

    fn heap_bytes(&self) -> usize {
        self.nodes.heap_bytes() + self.triangles.heap_bytes()
    }
}
