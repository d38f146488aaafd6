//! The kd-tree: an axis-aligned BSP tree whose planes cut space, not the triangle
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

use node::MAX_INDEX;
pub use traverse::KdScratch;

use crate::accel::{Accel, Footprint, RayStream};
use crate::bvh::BuildError;
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::grid::mailbox::SHARED;
use crate::grid::uniform::live_triangles;
use crate::hit::Visitor;
use crate::mesh::Mesh;
use crate::traverse::origin_order;
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
    /// misses; errors if the tree needs more nodes or references than its 8-byte nodes can
    /// address.
    pub fn build(mesh: impl Into<Arc<Mesh>>, max_leaf_size: u32) -> Result<Self, BuildError> {
        let mesh = mesh.into();
        let (live, triangle_boxes, bounds) = live_triangles(&mesh)?;
        let boxes: Vec<(u32, Aabb)> = live
            .iter()
            .map(|&id| {
                let (min, max) = triangle_boxes[id as usize];
                (id, Aabb::new(min, max))
            })
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
    const GROUP_BY_OCTANT: bool = false;

    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut KdScratch,
        visitor: &mut V,
    ) -> f32 {
        traverse::trace::<K, V>(self, ray, id, scratch, visitor)
    }

    /// One ray at a time, in Morton order of their origins (`crate::traverse::origin_order`).
    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut KdScratch,
        visitor: &mut V,
    ) {
        let tree = (&self.bounds, &*self.mesh);
        origin_order::trace_stream::<_, K, V>(self, tree, stream, scratch, visitor);
    }
}

crate::query::compiled_queries!(KdTree);

impl crate::accel::Corners for KdTree {
    fn corners(&self, id: u32) -> [glam::Vec3; 3] {
        self.mesh().triangle(id)
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

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::geom::{Kernel, Ray};
    use crate::hit::Hit;
    use crate::query::{RayQueries, brute_force};

    /// Two clusters of unit squares and one square lying in the plane `x = 5` between them,
    /// which the first split cuts through.
    fn split_mesh() -> Mesh {
        let (mut v, mut t) = (Vec::new(), Vec::new());
        let mut square = |corners: [Vec3; 4]| {
            let b = v.len() as u32;
            v.extend(corners);
            t.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
        };
        for i in 0..8 {
            let x = if i < 4 { 0.0 } else { 9.0 };
            let z = (i % 4) as f32;
            let o = Vec3::new(x, 0.0, z);
            square([o, o + Vec3::X, o + Vec3::X + Vec3::Y, o + Vec3::Y]);
        }
        let p = Vec3::new(5.0, 0.0, 0.0);
        square([
            p,
            p + Vec3::Y,
            p + Vec3::Y + Vec3::Z * 4.0,
            p + Vec3::Z * 4.0,
        ]);
        Mesh::new(v, t).unwrap()
    }

    #[test]
    fn rays_and_triangles_in_a_split_plane() {
        let mesh = Arc::new(split_mesh());
        let tree = KdTree::build(mesh.clone(), 1).unwrap();
        assert!(tree.depth() >= 1);
        let mut rays = vec![
            // In the plane x = 5 (the flat square's), along y and z.
            Ray::new(Vec3::new(5.0, -1.0, 0.5), Vec3::Y),
            Ray::new(Vec3::new(5.0, 0.5, -1.0), Vec3::Z),
            // Across the plane, through the square's edge and corner.
            Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
            Ray::new(Vec3::new(-1.0, 1.0, 4.0), Vec3::X),
        ];
        for i in 0..50 {
            let a = i as f32 * 0.41;
            rays.push(Ray::new(
                Vec3::new(5.0, 0.5, 2.0),
                Vec3::new(a.cos(), 0.1, a.sin()),
            ));
        }
        for ray in rays {
            let want = brute_force::cast_ray(&mesh, &ray, Kernel::Watertight);
            assert_eq!(tree.cast_ray(&ray), want, "{ray:?}");
            let mut all = tree.all_hits(&ray);
            let mut expected = brute_force::all_hits(&mesh, &ray, Kernel::Watertight);
            Hit::sort(&mut all);
            Hit::sort(&mut expected);
            assert_eq!(all, expected, "{ray:?}");
        }
    }
}
