//! [`QuantizedVertexTree`]: the AABB tree over a [`QuantizedMesh`], decoding each leaf
//! triangle's corners when it is tested.
//!
//! It is the [`super::AabbTree`]'s build and node formats with another leaf store: instead of
//! the shared `f32` mesh it owns the quantized mesh (6, 4 or 3 bytes per vertex instead of 12)
//! and [`Bvh::triangle`] decodes the three corners (a multiply and an add per coordinate, both
//! exact). The tree is built over the decoded mesh ([`QuantizedMesh::dequantize`], dropped after
//! the build), so its boxes hold the decoded triangles and every answer is exactly the answer
//! for that mesh: the traversals, kernels and tie rule are the crate's, unchanged. It is not an
//! [`crate::AccelKind`]: every kind answers for the mesh it is given, this one for a mesh
//! within half a grid step of it ([`crate::mesh::quantized`]).

use glam::Vec3;

use super::build::{BuildError, BuildOptions, build};
use super::nodes::{FullNodes, NodeFormat};
use super::{Bvh, Node};
use crate::accel::Footprint;
use crate::geom::Aabb;
use crate::mesh::quantized::QuantizedMesh;

/// A binary AABB tree over a quantized mesh (see the module docs), with full nodes.
#[derive(Clone, Debug)]
pub struct QuantizedVertexTree {
    nodes: FullNodes,
    /// Slot to triangle id (degenerate triangles of the decoded mesh have no slot).
    order: Vec<u32>,
    mesh: QuantizedMesh,
    depth: usize,
}

impl QuantizedVertexTree {
    /// Builds the tree over `mesh` (decoded for the build only). `options.leaf_copy` is
    /// ignored: a copy of the triangles would undo the memory saving.
    pub fn build(mesh: QuantizedMesh, options: &BuildOptions) -> Result<Self, BuildError> {
        let built = build(&mesh.dequantize(), options)?;
        Ok(Self {
            nodes: FullNodes::pack(&built)?,
            order: built.triangle_order,
            mesh,
            depth: built.depth,
        })
    }

    /// The quantized mesh; triangle ids refer to it (and to the mesh it was made from).
    pub fn mesh(&self) -> &QuantizedMesh {
        &self.mesh
    }
}

impl Bvh for QuantizedVertexTree {
    type Cache = ();
    type NodeBox = ();
    const AVX2_TRAVERSAL: bool = FullNodes::AVX2_TRAVERSAL;

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
        node.children.map(|c| self.nodes.bounds(c))
    }

    #[inline(always)]
    fn node(&self, index: u32) -> Node {
        self.nodes.node(index)
    }

    #[inline(always)]
    fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]) {
        let id = self.order[slot as usize];
        (id, self.mesh.triangle(id))
    }

    fn depth(&self) -> usize {
        self.depth
    }
}

crate::query::compiled_queries!(QuantizedVertexTree);

impl Footprint for QuantizedVertexTree {
    fn name(&self) -> &'static str {
        "quantized-vertices"
    }

    fn triangle_count(&self) -> usize {
        self.mesh.triangle_count()
    }

    fn node_count(&self) -> usize {
        self.nodes.node_count()
    }

    /// Nodes and slot order, like the other trees (the mesh is not counted; here it is owned:
    /// [`QuantizedMesh::heap_bytes`]).
    fn heap_bytes(&self) -> usize {
        self.nodes.heap_bytes() + size_of_val(self.order.as_slice())
    }
}
