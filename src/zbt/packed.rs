//! A mesh whose index array carries zero-byte tree nodes ([`super::layout`]): reading a node,
//! recomputing its box, reading a triangle, and unpacking the plain mesh again.
//!
//! Positions `0..tree_len` hold the tree's triangles (the non-degenerate ones); the degenerate
//! ones follow, in no node, as no ray can hit them.

use glam::{Vec3, Vec3A};

use super::build::inherit;
use super::layout::{
    INDEX_MASK, aux_inherited, aux_order, high_word, indices, set_high_word, unpack_node_word,
};
use crate::bvh::Node;
use crate::bvh::build::Prim;
use crate::geom::Aabb;
use crate::mesh::Mesh;

/// Vertices and packed triangles (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct PackedMesh {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    tree_len: u32,
}

impl PackedMesh {
    /// Wraps arrays whose first `tree_len` triangles carry node words.
    ///
    /// Panics if a triangle's vertex index (node bits masked off) is out of range: callers pass
    /// a validated mesh's indices, and [`PackedMesh::corners`] relies on it.
    pub(crate) fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>, tree_len: usize) -> Self {
        let in_range = |&i: &u32| ((i & INDEX_MASK) as usize) < vertices.len();
        assert!(
            triangles.iter().flatten().all(in_range),
            "a packed vertex index beyond the vertices"
        );
        Self {
            vertices,
            triangles,
            tree_len: tree_len as u32,
        }
    }

    /// Reorders `mesh`'s triangles to the built order (`prims`, then the degenerate triangles
    /// in id order) and stores `high` (one word per tree position) in their index bits.
    /// Returns the packed mesh and the permutation (position -> original id).
    pub(crate) fn pack(mesh: Mesh, prims: &[Prim], high: &[u32]) -> (Self, Vec<u32>) {
        debug_assert_eq!(prims.len(), high.len());
        let degenerate = (0..mesh.triangle_count() as u32).filter(|&id| mesh.is_degenerate(id));
        let permutation: Vec<u32> = prims.iter().map(|p| p.id).chain(degenerate).collect();
        let (vertices, original) = mesh.into_parts();
        let mut triangles: Vec<[u32; 3]> = permutation
            .iter()
            .map(|&id| original[id as usize])
            .collect();
        for (t, &word) in triangles.iter_mut().zip(high) {
            set_high_word(t, word);
        }
        (Self::new(vertices, triangles, prims.len()), permutation)
    }

    /// Positions that belong to the tree (node indices are below it).
    pub(crate) fn tree_len(&self) -> u32 {
        self.tree_len
    }

    /// All triangles, degenerate ones included.
    pub(crate) fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The vertex array (never changed by the tree).
    pub(crate) fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }

    /// The contents of the node at position `p`, with child indices shifted by `base` (the
    /// hybrid tree's node numbering; 0 for a plain zero-byte tree).
    #[inline(always)]
    pub(crate) fn node(&self, p: u32, base: u32) -> Node {
        let (count, offset) = unpack_node_word(high_word(&self.triangles[p as usize]));
        if offset == 0 {
            return Node::leaf(p, count);
        }
        // An internal node owns at least 2 triangles: `p + 1` is its aux word.
        let aux = high_word(&self.triangles[p as usize + 1]);
        Node {
            first: p,
            count,
            children: [base + p + count, base + p + offset],
            order: aux_order(aux),
            inherited: aux_inherited(aux),
        }
    }

    /// The box of the node at position `p`, recomputed from the corners of its triangles, with
    /// the faces of `inherited` taken from its parent's box `parent` (see [`super::build`]).
    #[inline(always)]
    pub(crate) fn bounds(&self, p: u32, parent: &Aabb, inherited: u8) -> Aabb {
        let p = p as usize;
        let (count, _) = unpack_node_word(high_word(&self.triangles[p]));
        let (mut min, mut max) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        for position in p..p + count as usize {
            for c in self.corners(position) {
                let c = Vec3A::from(c);
                (min, max) = (min.min(c), max.max(c));
            }
        }
        if inherited != 0 {
            let parent = (parent.min.into(), parent.max.into());
            (min, max) = inherit((min, max), parent, inherited);
        }
        Aabb::new(min.into(), max.into())
    }

    /// Calls `f` with every node of the zero-byte (sub)tree rooted at position `root`.
    pub(crate) fn walk(&self, root: u32, mut f: impl FnMut(&Node)) {
        let mut stack = vec![root];
        while let Some(p) = stack.pop() {
            let node = self.node(p, 0);
            f(&node);
            if node.has_children() {
                stack.extend(node.children);
            }
        }
    }

    /// Triangle at position `slot`: its id (the position) and corners.
    #[inline(always)]
    pub(crate) fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]) {
        (slot, self.corners(slot as usize))
    }

    /// The corners of the triangle at `position`, read without checking the vertex indices
    /// against the vertex array: the walk recomputes every box from corners, and those checks
    /// were some 15% of a zero-byte walk's instructions. Twin: [`PackedMesh::corners_checked`]
    /// (compared by `tests`).
    #[inline(always)]
    #[allow(unsafe_code)]
    pub(crate) fn corners(&self, position: usize) -> [Vec3; 3] {
        let t = &self.triangles[position];
        t.map(|index| {
            let i = (index & INDEX_MASK) as usize;
            debug_assert!(i < self.vertices.len());
            // SAFETY: `new` checked that every masked index of every triangle is below
            // `vertices.len()`, and neither array changes afterwards (no method takes them
            // mutably); `t` is one of those triangles.
            unsafe { *self.vertices.get_unchecked(i) }
        })
    }

    /// [`PackedMesh::corners`] with checked indexing.
    pub(crate) fn corners_checked(&self, position: usize) -> [Vec3; 3] {
        self.triangles[position].map(|index| self.vertices[(index & INDEX_MASK) as usize])
    }

    /// The plain index array (node data removed), in the tree's triangle order.
    pub(crate) fn plain_triangles(&self) -> Vec<[u32; 3]> {
        self.triangles.iter().map(indices).collect()
    }

    /// The plain mesh in the tree's triangle order, the arrays reused (no copy).
    pub(crate) fn into_mesh(self) -> Mesh {
        let mut triangles = self.triangles;
        for t in &mut triangles {
            *t = indices(t);
        }
        Mesh::from_valid_parts(self.vertices, triangles)
    }

    /// A copy of the plain mesh in the tree's triangle order.
    pub(crate) fn to_mesh(&self) -> Mesh {
        Mesh::from_valid_parts(self.vertices.clone(), self.plain_triangles())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::bunny;

    /// The unchecked corner reads return what checked indexing returns, for every triangle of
    /// the bunny with node words of all bit patterns in the index bits.
    #[test]
    fn unchecked_corners_equal_checked_ones() {
        let (vertices, mut triangles) = bunny().into_parts();
        for (k, t) in triangles.iter_mut().enumerate() {
            set_high_word(t, (k as u32).wrapping_mul(0x9E37_79B9) >> 8);
        }
        let len = triangles.len();
        let packed = PackedMesh::new(vertices, triangles, len);
        for position in 0..packed.triangle_count() {
            assert_eq!(packed.corners(position), packed.corners_checked(position));
        }
    }

    /// Index arrays that point past the vertices are refused at construction.
    #[test]
    #[should_panic(expected = "beyond the vertices")]
    fn out_of_range_indices_are_refused() {
        PackedMesh::new(vec![Vec3::ZERO; 3], vec![[0, 1, 3]], 1);
    }
}
