//! [`ZbtStats`]: the shape of the zero-byte trees in a packed mesh, for both trees' `stats`.

use super::packed::PackedMesh;

/// The shape of a zero-byte tree (or of the zero-byte parts of a hybrid tree).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ZbtStats {
    /// Nodes.
    pub nodes: usize,
    /// Nodes with children.
    pub internal_nodes: usize,
    /// Triangles owned by nodes with children (tested at every visit on the way down).
    pub internal_triangles: usize,
    /// Faces inherited from the parent's box, over all nodes (6 per node at most).
    pub inherited_faces: usize,
}

impl ZbtStats {
    /// The stats of the zero-byte trees rooted at `roots`.
    pub(crate) fn of(packed: &PackedMesh, roots: impl IntoIterator<Item = u32>) -> Self {
        let mut stats = Self::default();
        for root in roots {
            packed.walk(root, |node| {
                stats.nodes += 1;
                if node.has_children() {
                    stats.internal_nodes += 1;
                    stats.internal_triangles += node.count as usize;
                    let inherited = node.inherited.map(|m| m.count_ones() as usize);
                    stats.inherited_faces += inherited[0] + inherited[1];
                }
            });
        }
        stats
    }
}
