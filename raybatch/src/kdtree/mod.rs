//! The kd-tree (seed 004): an axis-aligned BSP tree whose planes cut space, not the triangle
//! list. Built with the SAH, it isolates clusters and cuts away empty space; a ray walks it
//! front to back and stops as soon as the nearest pending node lies behind the best hit.
//!
//! - `node`: the 8-byte node (split position and child link, or a leaf's reference range);
//! - `build`: the binned SAH build and the side rule for triangles straddling a plane;
//! - `traverse`: the front-to-back walk and why it is exact.
//!
//! Triangles straddling a plane are stored in both children, so, as in the grid, a ray may meet
//! a triangle in several leaves: the walk tests it once (the grid's [`crate::grid::Mailbox`]).

mod build;
mod node;
mod traverse;

use std::sync::Arc;

pub use node::MAX_INDEX;
pub use traverse::KdScratch;

use crate::accel::{Accel, Footprint};
use crate::bvh::BuildError;
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::grid::mailbox::SHARED;
use crate::grid::uniform::live_triangles;
use crate::hit::Visitor;
use crate::mesh::Mesh;
use node::KdNode;

/// A kd-tree over a mesh (see the module docs).
#[derive(Clone, Debug)]
pub struct KdTree {
    mesh: Arc<Mesh>,
    bounds: Aabb,
    nodes: Vec<KdNode>,
    /// Triangle references, leaf after leaf ([`SHARED`] set for triangles in several leaves).
    refs: Vec<u32>,
    depth: usize,
}

impl KdTree {
    /// Builds the tree; nodes of more than `max_leaf_size` triangles are split while the SAH
    /// says it pays. An empty mesh (or one of degenerate triangles only) gives a tree every ray
    /// misses; errors if the tree needs more than [`MAX_INDEX`] nodes or references.
    pub fn build(mesh: impl Into<Arc<Mesh>>, max_leaf_size: u32) -> Result<Self, BuildError> {
        let mesh = mesh.into();
        let (live, bounds) = live_triangles(&mesh)?;
        let boxes: Vec<(u32, Aabb)> = live
            .iter()
            .map(|&id| (id, Aabb::from_points(&mesh.triangle(id))))
            .collect();
        let built = build::build(&boxes, bounds, max_leaf_size as usize).map_err(|e| {
            BuildError::TooLarge {
                format: "kd-tree (30-bit node and reference indices)",
                needed: e.0,
                max: MAX_INDEX,
            }
        })?;
        let refs = mark_shared(built.refs, mesh.triangle_count());
        // No triangle: no node (a structure every ray misses).
        let nodes = if refs.is_empty() {
            Vec::new()
        } else {
            built.nodes
        };
        Ok(Self {
            mesh,
            bounds,
            nodes,
            refs,
            depth: built.depth,
        })
    }

    /// The mesh the tree was built over; triangle ids refer to it.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Depth of the deepest leaf (the root's is 0).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Triangle references in the leaves (a triangle counts once per leaf).
    pub fn reference_count(&self) -> usize {
        self.refs.len()
    }
}

/// `refs` with [`SHARED`] set on the references of triangles stored more than once.
fn mark_shared(mut refs: Vec<u32>, triangles: usize) -> Vec<u32> {
    let mut seen = vec![0u8; triangles];
    for &r in &refs {
        let s = &mut seen[r as usize];
        *s = s.saturating_add(1);
    }
    for r in &mut refs {
        if seen[*r as usize] > 1 {
            *r |= SHARED;
        }
    }
    refs
}

impl Accel for KdTree {
    type Scratch = KdScratch;

    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut KdScratch,
        visitor: &mut V,
    ) -> f32 {
        traverse::trace::<K, V>(self, ray, id, scratch, visitor)
    }
}

impl Footprint for KdTree {
    fn name(&self) -> &'static str {
        "kd"
    }

    fn triangle_count(&self) -> usize {
        self.mesh.triangle_count()
    }

    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    fn heap_bytes(&self) -> usize {
        (self.nodes.len() * size_of::<KdNode>()) + self.refs.len() * size_of::<u32>()
    }
}
