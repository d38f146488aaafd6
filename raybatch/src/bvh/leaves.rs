//! The triangles of a tree's leaves, in leaf-slot order: the mesh (shared, never copied or
//! reordered), the triangle id of every slot, and optionally a copy in leaf order of each
//! slot's vertex indices or corners ([`LeafCopy`]).
//!
//! Leaves address their triangles as ranges of slots, so a leaf's triangles are contiguous here.
//! Reading one through the mesh alone takes three dependent loads (id, then indices, then
//! vertices); the index copy starts the chain at the indices (12 bytes per triangle), the
//! corner copy reads the corners from one contiguous block (36 bytes per triangle). The slot's
//! id is still read from the slot order, beside the chain: only a hit needs it, so the wide
//! trees' one-ray loop reads it only then ([`LeafTriangles::corners`], then
//! [`LeafTriangles::id`]: 0.91-0.94x the time per bunny ray). Every tree built from the SAH
//! builder keeps one of these.

use std::sync::Arc;

use glam::Vec3;

use crate::mesh::Mesh;
use crate::prefetch::prefetch;

/// What a tree copies of its leaves' triangles beside the mesh, in leaf order, to shorten the
/// chain of dependent loads that reads a leaf's triangles (see [`crate::BuildOptions::leaf_copy`]).
/// The answers are the same whatever the choice.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LeafCopy {
    /// The structure's default: the wide trees with full nodes ([`crate::WideTree`],
    /// [`crate::WideTree8`]) copy the vertex indices; the others copy nothing (their memory
    /// is their point).
    #[default]
    Auto,
    /// Nothing: each triangle is read through its id and the mesh's index array.
    Nothing,
    /// Each triangle's three vertex indices (12 bytes per triangle).
    Indices,
    /// Each triangle's corners (36 bytes per triangle).
    Corners,
}

impl LeafCopy {
    /// Every choice.
    pub const ALL: [LeafCopy; 4] = [
        LeafCopy::Auto,
        LeafCopy::Nothing,
        LeafCopy::Indices,
        LeafCopy::Corners,
    ];

    /// Short name for tables and the command line.
    pub fn name(self) -> &'static str {
        match self {
            LeafCopy::Auto => "auto",
            LeafCopy::Nothing => "nothing",
            LeafCopy::Indices => "indices",
            LeafCopy::Corners => "corners",
        }
    }

    /// The choice named `name` (see [`LeafCopy::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|copy| copy.name() == name)
    }

    /// This choice, with [`LeafCopy::Auto`] replaced by the structure's `default`.
    pub(crate) fn or(self, default: LeafCopy) -> LeafCopy {
        match self {
            LeafCopy::Auto => default,
            chosen => chosen,
        }
    }
}

/// The copy a [`LeafTriangles`] keeps, in slot order.
#[derive(Clone, Debug)]
enum Copied {
    Nothing,
    Indices(Vec<[u32; 3]>),
    Corners(Vec<[Vec3; 3]>),
}

/// A tree's leaf triangles (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct LeafTriangles {
    mesh: Arc<Mesh>,
    /// Slot to triangle id (degenerate triangles have no slot).
    order: Vec<u32>,
    /// What is copied of each slot's triangle.
    copied: Copied,
}

impl LeafTriangles {
    /// The triangles of `order` (the builder's slot order) over `mesh`, with `copy` (already
    /// resolved: [`LeafCopy::Auto`] copies nothing).
    pub(crate) fn new(mesh: Arc<Mesh>, order: Vec<u32>, copy: LeafCopy) -> Self {
        let copied = Self::copy_of(&mesh, &order, copy);
        Self {
            mesh,
            order,
            copied,
        }
    }

    /// The copy `copy` of the triangles of `order` over `mesh`.
    fn copy_of(mesh: &Mesh, order: &[u32], copy: LeafCopy) -> Copied {
        match copy {
            LeafCopy::Auto | LeafCopy::Nothing => Copied::Nothing,
            LeafCopy::Indices => {
                let indices = mesh.triangles();
                Copied::Indices(order.iter().map(|&id| indices[id as usize]).collect())
            }
            LeafCopy::Corners => {
                Copied::Corners(order.iter().map(|&id| mesh.triangle(id)).collect())
            }
        }
    }

    /// The mesh the slots refer to.
    pub(crate) fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// Puts `mesh` (the same triangles, moved vertices) in place of the mesh, refreshing the
    /// corner copy (a refit).
    pub(crate) fn replace_mesh(&mut self, mesh: Arc<Mesh>) {
        if let Copied::Corners(_) = self.copied {
            self.copied = Self::copy_of(&mesh, &self.order, LeafCopy::Corners);
        }
        self.mesh = mesh;
    }

    /// Slot to triangle id.
    pub(crate) fn order(&self) -> &[u32] {
        &self.order
    }

    /// Number of slots.
    pub(crate) fn len(&self) -> usize {
        self.order.len()
    }

    /// Slot `slot`: its triangle id and corners.
    #[inline(always)]
    pub(crate) fn get(&self, slot: u32) -> (u32, [Vec3; 3]) {
        (self.id(slot), self.corners(slot))
    }

    /// Slot `slot`'s corners, read without its id where a copy holds them (the one-ray
    /// loops ask for the id, [`Self::id`], only on a hit).
    #[inline(always)]
    pub(crate) fn corners(&self, slot: u32) -> [Vec3; 3] {
        match &self.copied {
            Copied::Nothing => self.mesh.triangle(self.order[slot as usize]),
            Copied::Indices(indices) => {
                let vertices = self.mesh.vertices();
                indices[slot as usize].map(|i| vertices[i as usize])
            }
            Copied::Corners(corners) => corners[slot as usize],
        }
    }

    /// Slot `slot`'s triangle id.
    #[inline(always)]
    pub(crate) fn id(&self, slot: u32) -> u32 {
        self.order[slot as usize]
    }

    /// Prefetches the next link of the chain of dependent reads behind slots `slots` (slot ->
    /// id -> vertex indices -> corners): at `stage` 0 the ids are read (the slot order is
    /// small and mostly cached) and the vertex indices prefetched, at stage 1 the corners.
    /// With the index copy, stage 0 prefetches the copied indices and stage 1 the corners;
    /// with the corner copy, stage 0 the corners. Returns true once the corners are on their
    /// way, so that a caller that takes turns between rays ([`crate::wide::interleaved`]) can issue
    /// one link per turn and find the whole chain in cache when it reads the triangles.
    #[inline(always)]
    pub(crate) fn prefetch(&self, slots: std::ops::Range<u32>, stage: u8) -> bool {
        let (first, end) = (slots.start as usize, slots.end as usize);
        let mesh = &self.mesh;
        let ids = &self.order[first..end];
        match (&self.copied, stage) {
            (Copied::Corners(corners), _) => corners[first..end].iter().for_each(prefetch),
            (Copied::Indices(indices), 0) => indices[first..end].iter().for_each(prefetch),
            (Copied::Indices(indices), _) => indices[first..end]
                .iter()
                .for_each(|i| mesh.prefetch_corners(i)),
            (Copied::Nothing, 0) => ids.iter().for_each(|&id| mesh.prefetch_indices(id)),
            (Copied::Nothing, _) => ids
                .iter()
                .for_each(|&id| mesh.prefetch_corners(&mesh.triangles()[id as usize])),
        }
        stage > 0 || matches!(self.copied, Copied::Corners(_))
    }

    /// Bytes added to the mesh: the slot order and the copy.
    pub(crate) fn heap_bytes(&self) -> usize {
        let copied = match &self.copied {
            Copied::Nothing => 0,
            Copied::Indices(indices) => indices.len() * size_of::<[u32; 3]>(),
            Copied::Corners(corners) => corners.len() * size_of::<[Vec3; 3]>(),
        };
        self.order.len() * size_of::<u32>() + copied
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::bunny;

    /// Every copy reads every slot's triangle as the mesh holds it, costs what it says, and
    /// follows a refit (moved vertices, the same triangles).
    #[test]
    fn every_copy_reads_the_mesh() {
        let mesh = Arc::new(bunny());
        let order: Vec<u32> = (0..mesh.triangle_count() as u32).rev().step_by(3).collect();
        let moved = Arc::new(
            Mesh::new(
                mesh.vertices().iter().map(|v| *v * 2.0 + 1.0).collect(),
                mesh.triangles().to_vec(),
            )
            .unwrap(),
        );
        for (copy, bytes) in [
            (LeafCopy::Auto, 0),
            (LeafCopy::Nothing, 0),
            (LeafCopy::Indices, 12),
            (LeafCopy::Corners, 36),
        ] {
            let mut leaves = LeafTriangles::new(mesh.clone(), order.clone(), copy);
            assert_eq!(leaves.heap_bytes(), order.len() * (4 + bytes), "{copy:?}");
            for (slot, &id) in order.iter().enumerate() {
                assert_eq!(leaves.get(slot as u32), (id, mesh.triangle(id)), "{copy:?}");
            }
            leaves.replace_mesh(moved.clone());
            for (slot, &id) in order.iter().enumerate() {
                assert_eq!(
                    leaves.get(slot as u32),
                    (id, moved.triangle(id)),
                    "{copy:?}"
                );
            }
            for stage in 0..2 {
                let ready = leaves.prefetch(0..order.len().min(16) as u32, stage);
                let expected = stage > 0 || matches!(copy, LeafCopy::Corners);
                assert_eq!(ready, expected, "{copy:?}, stage {stage}");
            }
        }
    }

    /// Names round-trip.
    #[test]
    fn names_round_trip() {
        for copy in LeafCopy::ALL {
            assert_eq!(LeafCopy::from_name(copy.name()), Some(copy));
        }
        assert_eq!(LeafCopy::from_name("all"), None);
    }
}
