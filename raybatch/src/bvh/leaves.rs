//! The triangles of a tree's leaves, in leaf-slot order: the mesh (shared, never copied or
//! reordered), the triangle id of every slot, and optionally a copy in leaf order of each
//! slot's vertex indices or corners ([`LeafCopy`]).
//!
//! Leaves address their triangles as ranges of slots, so a leaf's triangles are contiguous here.
//! Reading one through the mesh alone takes three dependent loads (id, then indices, then
//! vertices); the index copy starts the chain at the indices (12 bytes per triangle), the
//! corner copy reads the corners from one contiguous block (36 bytes per triangle). The index
//! copy keeps each slot's id beside its indices, so that a hit's id comes with them. Every tree
//! built from the SAH builder keeps one of these.

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

/// Each slot's triangle id and what is copied of its triangle, in slot order.
#[derive(Clone, Debug)]
enum Slots {
    /// The ids alone: each triangle is read through the mesh.
    Ids(Vec<u32>),
    /// Each slot's vertex indices and id together (see [`IndexedSlot`]).
    IndicesAndId(Vec<IndexedSlot>),
    /// The ids, and each slot's corners.
    IdsAndCorners(Vec<u32>, Vec<[Vec3; 3]>),
}

/// A slot of the index copy: its triangle's vertex indices, then its id, in one aligned
/// 16-byte block, so that the read that starts a triangle's chain brings its id too. The same
/// 16 bytes a slot as the ids and copied indices kept in two arrays, whose ids cost a miss of
/// their own: against them, per `bvh8` bunny ray, 13% fewer misses of a 1 MiB L2 and 5% fewer
/// of L1 (callgrind's cache model, 100k incoherent rays), 0.8% fewer instructions and
/// 0.94-0.97x the time (alternated, best of 9 x 3 passes, `bvh8` and `bvh4`; no change on the
/// fandisk and the teapot, whose leaves fit in L2).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct IndexedSlot {
    indices: [u32; 3],
    id: u32,
}

/// A tree's leaf triangles (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct LeafTriangles {
    mesh: Arc<Mesh>,
    /// Slot to triangle id (degenerate triangles have no slot), with the copy.
    slots: Slots,
    /// Number of slots, kept apart from `slots` although derivable: the wide trees ask for it
    /// (`is_empty`) before every ray, and a match on the copy there cost about 10 instructions
    /// a `bvh8` ray (callgrind, bunny).
    len: usize,
}

impl LeafTriangles {
    /// The triangles of `order` (the builder's slot order) over `mesh`, with `copy` (already
    /// resolved: [`LeafCopy::Auto`] copies nothing).
    pub(crate) fn new(mesh: Arc<Mesh>, order: Vec<u32>, copy: LeafCopy) -> Self {
        let len = order.len();
        let slots = match copy {
            LeafCopy::Auto | LeafCopy::Nothing => Slots::Ids(order),
            LeafCopy::Indices => {
                let indices = mesh.triangles();
                let with_id = |id: u32| IndexedSlot {
                    indices: indices[id as usize],
                    id,
                };
                Slots::IndicesAndId(order.into_iter().map(with_id).collect())
            }
            LeafCopy::Corners => {
                let corners = Self::corners_of(&mesh, &order);
                Slots::IdsAndCorners(order, corners)
            }
        };
        Self { mesh, slots, len }
    }

    /// The corners of the triangles `order` of `mesh`.
    fn corners_of(mesh: &Mesh, order: &[u32]) -> Vec<[Vec3; 3]> {
        order.iter().map(|&id| mesh.triangle(id)).collect()
    }

    /// The mesh the slots refer to.
    pub(crate) fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// Puts `mesh` (the same triangles, moved vertices) in place of the mesh, refreshing the
    /// corner copy (a refit).
    pub(crate) fn replace_mesh(&mut self, mesh: Arc<Mesh>) {
        if let Slots::IdsAndCorners(order, corners) = &mut self.slots {
            *corners = Self::corners_of(&mesh, order);
        }
        self.mesh = mesh;
    }

    /// Every slot's triangle id, in slot order.
    pub(crate) fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.len() as u32).map(|slot| self.id(slot))
    }

    /// Number of slots.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Slot `slot`: its triangle id and corners.
    #[inline(always)]
    pub(crate) fn get(&self, slot: u32) -> (u32, [Vec3; 3]) {
        let slot = slot as usize;
        match &self.slots {
            Slots::Ids(order) => {
                let id = order[slot];
                (id, self.mesh.triangle(id))
            }
            Slots::IndicesAndId(indices) => {
                let vertices = self.mesh.vertices();
                let IndexedSlot { indices, id } = indices[slot];
                (id, indices.map(|i| vertices[i as usize]))
            }
            Slots::IdsAndCorners(order, corners) => (order[slot], corners[slot]),
        }
    }

    /// Slot `slot`'s triangle id.
    #[inline(always)]
    pub(crate) fn id(&self, slot: u32) -> u32 {
        match &self.slots {
            Slots::Ids(order) | Slots::IdsAndCorners(order, _) => order[slot as usize],
            Slots::IndicesAndId(indices) => indices[slot as usize].id,
        }
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
        // Each arm says whether it sent the corners.
        match (&self.slots, stage) {
            (Slots::IdsAndCorners(_, corners), _) => {
                corners[first..end].iter().for_each(prefetch);
                true
            }
            (Slots::IndicesAndId(indices), 0) => {
                indices[first..end].iter().for_each(prefetch);
                false
            }
            (Slots::IndicesAndId(indices), _) => {
                let corners = |slot: &IndexedSlot| mesh.prefetch_corners(&slot.indices);
                indices[first..end].iter().for_each(corners);
                true
            }
            (Slots::Ids(order), 0) => {
                order[first..end]
                    .iter()
                    .for_each(|&id| mesh.prefetch_indices(id));
                false
            }
            (Slots::Ids(order), _) => {
                let corners = |&id: &u32| mesh.prefetch_corners(&mesh.triangles()[id as usize]);
                order[first..end].iter().for_each(corners);
                true
            }
        }
    }

    /// Bytes added to the mesh: the slot order and the copy.
    pub(crate) fn heap_bytes(&self) -> usize {
        match &self.slots {
            Slots::Ids(order) => order.len() * size_of::<u32>(),
            Slots::IndicesAndId(indices) => indices.len() * size_of::<IndexedSlot>(),
            Slots::IdsAndCorners(order, corners) => {
                order.len() * size_of::<u32>() + corners.len() * size_of::<[Vec3; 3]>()
            }
        }
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
            assert_eq!(leaves.len(), order.len(), "{copy:?}");
            assert_eq!(leaves.ids().collect::<Vec<_>>(), order, "{copy:?}");
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
