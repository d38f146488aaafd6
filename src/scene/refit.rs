//! Refitting a deformed mesh's AABB tree: new vertex positions, the same triangles, the same
//! tree shape, every box recomputed bottom-up (a leaf's from its triangles' corners, an inner
//! node's as the union of its children's).
//!
//! Exactness only needs what a build gives: each node's box holds every corner of its
//! triangles and both children's boxes. Refitting computes those boxes with `min`/`max` of
//! the new coordinates (no rounding), so the traversal stays conservative and answers stay
//! those of brute force over the deformed mesh. What degrades is speed: the split planes and
//! the child-order bytes were chosen for the old positions (rebuild after large motions).
//!
//! Two cases are refused, as the tree could no longer answer exactly: a triangle degenerate at
//! build has no leaf slot, so it could never be reported, and the deformation gives it an
//! area; or a triangle with a slot loses its area (degenerate triangles are never hit, and the
//! kernel's rounding could hit one still in a leaf). The tree must then be rebuilt.

use std::sync::Arc;

use glam::Vec3;

use crate::bvh::nodes::NodeFormat;
use crate::bvh::{AabbTree, Bvh};
use crate::catalog::AnyAccel;
use crate::geom::Aabb;
use crate::mesh::Mesh;
use crate::scene::error::SceneError;

/// Moves `accel`'s mesh to `vertices` and refits its boxes and the mesh's box; on error
/// nothing changes. Only the binary AABB tree ([`crate::AccelKind::Aabb`]) can be refitted.
pub(crate) fn refit_mesh(accel: &mut AnyAccel, vertices: Vec<Vec3>) -> Result<(), SceneError> {
    let kind = accel.kind().name();
    accel
        .with_aabb(|tree| refit(tree, vertices))
        .unwrap_or(Err(SceneError::NotRefittable { kind }))
}

/// Moves `tree`'s mesh to `vertices` and refits its boxes; on error nothing changes.
fn refit(tree: &mut AabbTree, vertices: Vec<Vec3>) -> Result<(), SceneError> {
    let old = tree.mesh();
    if vertices.len() != old.vertices().len() {
        return Err(SceneError::VertexCountChanged {
            expected: old.vertices().len(),
            given: vertices.len(),
        });
    }
    let mesh = Mesh::new(vertices, old.triangles().to_vec())?;
    check_degenerate_stay_so(tree.triangles.ids(), &mesh)?;
    let bounds = node_bounds(tree, &mesh);
    for (index, b) in bounds.into_iter().enumerate() {
        tree.nodes.set_bounds(index as u32, b);
    }
    tree.triangles.replace_mesh(Arc::new(mesh));
    Ok(())
}

/// Errors if a triangle without a leaf slot (degenerate at build) has an area now, or one with
/// a slot has none.
fn check_degenerate_stay_so(ids: impl Iterator<Item = u32>, mesh: &Mesh) -> Result<(), SceneError> {
    let mut slotted = vec![false; mesh.triangle_count()];
    for id in ids {
        slotted[id as usize] = true;
    }
    let changed = |id: u32| slotted[id as usize] == mesh.is_degenerate(id);
    match (0..mesh.triangle_count() as u32).find(|&id| changed(id)) {
        Some(triangle) if slotted[triangle as usize] => {
            Err(SceneError::NewlyDegenerateTriangle { triangle })
        }
        Some(triangle) => Err(SceneError::NewlyValidTriangle { triangle }),
        None => Ok(()),
    }
}

/// Every node's refitted box, indexed by node: nodes are listed parents first (depth-first
/// from the root), then boxed in reverse so children are done before their parent.
fn node_bounds(tree: &AabbTree, mesh: &Mesh) -> Vec<Aabb> {
    let count = tree.nodes.node_count();
    let mut bounds = vec![Aabb::EMPTY; count];
    if count == 0 {
        return bounds;
    }
    let mut preorder = Vec::with_capacity(count);
    let mut stack = vec![0u32];
    while let Some(index) = stack.pop() {
        preorder.push(index);
        let node = tree.node(index);
        if node.has_children() {
            stack.extend(node.children);
        }
    }
    for &index in preorder.iter().rev() {
        let node = tree.node(index);
        let mut b = (node.first..node.first + node.count)
            .map(|slot| tree.triangles.id(slot))
            .flat_map(|id| mesh.triangle(id))
            .fold(Aabb::EMPTY, Aabb::grow);
        if node.has_children() {
            for child in node.children {
                b = b.union(bounds[child as usize]);
            }
        }
        bounds[index as usize] = b;
    }
    bounds
}
