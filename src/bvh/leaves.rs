//! The triangles of a tree's leaves, in leaf-slot order: the mesh (shared, never copied or
//! reordered), the triangle id of every slot, and optionally a copy in leaf order of each
//! slot's vertex indices or corners ([`LeafCopy`]).
//!
//! Leaves address their triangles as ranges of slots, so a leaf's triangles are contiguous here.
//! Reading one through the mesh alone takes three dependent loads (id, then indices, then
//! vertices); the index copy starts the chain at the indices, the corner copy reads the
//! corners from one contiguous block (36 bytes per triangle). The index copy keeps each slot's
//! id beside its indices, so that a hit's id comes with them: 12 bytes a slot, the indices packed
//! to 21 bits (meshes of more than 2^21 vertices get no index copy).
//! Every tree built from the SAH builder keeps one of these.

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
    /// [`crate::WideTree8`]) copy the vertex indices; the quantized 8-wide tree
    /// ([`crate::QuantizedWideTree8`]) takes leaf blocks ([`LeafCopy::Blocks`]) on large trees
    /// (over 8 MiB with its mesh, from about 270k triangles) within 38 bytes a triangle (the
    /// indices where blocks would take more); the others copy nothing (their memory is their
    /// point).
    #[default]
    Auto,
    /// Nothing: each triangle is read through its id and the mesh's index array.
    Nothing,
    /// Each triangle's three vertex indices with its id: 12 bytes per triangle in all, the
    /// indices packed to 21 bits. Meshes of more than 2^21 vertices, whose indices do not
    /// pack, copy nothing.
    Indices,
    /// Each triangle's corners (36 bytes per triangle).
    Corners,
    /// The wide trees: each leaf's triangle ids and distinct corners in one block, one read a
    /// leaf (about 28 bytes per triangle on a terrain, see `wide::blocks`). The binary trees
    /// copy the indices instead, and so do wide trees whose blocks would not be addressable
    /// (over 2^27 words: about 19M triangles of a terrain).
    Blocks,
}

impl LeafCopy {
    /// Every choice.
    pub const ALL: [LeafCopy; 5] = [
        LeafCopy::Auto,
        LeafCopy::Nothing,
        LeafCopy::Indices,
        LeafCopy::Corners,
        LeafCopy::Blocks,
    ];

    /// Short name for tables and the command line.
    pub fn name(self) -> &'static str {
        match self {
            LeafCopy::Auto => "auto",
            LeafCopy::Nothing => "nothing",
            LeafCopy::Indices => "indices",
            LeafCopy::Corners => "corners",
            LeafCopy::Blocks => "blocks",
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
    /// Each slot's vertex indices, packed, and id together (see [`PackedSlot`]).
    PackedIndicesAndId(Vec<PackedSlot>),
    /// The ids, and each slot's corners.
    IdsAndCorners(Vec<u32>, Vec<[Vec3; 3]>),
}

impl Slots {
    /// Asks for huge pages under the arrays (see `crate::huge_pages`).
    fn advise_huge_pages(&self) {
        use crate::huge_pages::advise;
        match self {
            Slots::Ids(ids) => {
                advise(ids);
            }
            Slots::PackedIndicesAndId(packed) => {
                advise(packed);
            }
            Slots::IdsAndCorners(ids, corners) => {
                advise(ids);
                advise(corners);
            }
        }
    }
}

/// A slot of the index copy: its triangle's three vertex indices, 21 bits each in one 64-bit
/// word, then its id, so that the read that starts a triangle's chain brings its id too. 12
/// bytes a slot (`packed(4)`: 4-byte alignment, fields only ever read by value).
///
/// Against a 16-byte slot (indices whole, id beside them) it saves 4 bytes a triangle at no
/// cost in time (docs/benchmarks.md). Meshes whose indices do not pack (more than 2^21
/// vertices) read their triangles through the mesh: a 16-byte slot for them, as a fourth
/// kind of copy, cost 5% more instructions on every mesh (the match on the copy in each
/// triangle read).
#[derive(Clone, Copy, Debug)]
#[repr(C, packed(4))]
struct PackedSlot {
    /// The three indices, index `k` in bits `21k..21k + 21`.
    word: u64,
    id: u32,
}

const _: () = assert!(size_of::<PackedSlot>() == 12);

impl PackedSlot {
    /// Bits of each vertex index.
    const INDEX_BITS: u32 = 21;
    /// The largest vertex count whose indices fit.
    const MAX_VERTICES: usize = 1 << Self::INDEX_BITS;
    /// One index's bits in the word.
    const INDEX_MASK: u64 = (1 << Self::INDEX_BITS) - 1;

    /// Triangle `id`'s slot; each of `indices` must be below [`PackedSlot::MAX_VERTICES`].
    fn new(indices: [u32; 3], id: u32) -> Self {
        debug_assert!(indices.iter().all(|&i| (i as usize) < Self::MAX_VERTICES));
        let word = (0..3).fold(0, |word, k| {
            word | u64::from(indices[k]) << (Self::INDEX_BITS * k as u32)
        });
        Self { word, id }
    }

    /// The vertex indices.
    #[inline(always)]
    fn indices(self) -> [u32; 3] {
        let word = self.word;
        [0, 1, 2].map(|k| ((word >> (Self::INDEX_BITS * k)) & Self::INDEX_MASK) as u32)
    }

    /// The triangle id.
    #[inline(always)]
    fn id(self) -> u32 {
        self.id
    }
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
    /// resolved: [`LeafCopy::Auto`] copies nothing; [`LeafCopy::Blocks`], which slots cannot
    /// hold, copies the indices).
    pub(crate) fn new(mesh: Arc<Mesh>, order: Vec<u32>, copy: LeafCopy) -> Self {
        let len = order.len();
        let slots = match copy {
            LeafCopy::Auto | LeafCopy::Nothing => Slots::Ids(order),
            LeafCopy::Indices | LeafCopy::Blocks
                if mesh.vertices().len() <= PackedSlot::MAX_VERTICES =>
            {
                let indices = mesh.triangles();
                let packed = |id: u32| PackedSlot::new(indices[id as usize], id);
                Slots::PackedIndicesAndId(order.into_iter().map(packed).collect())
            }
            // Indices that do not pack: read through the mesh (see `PackedSlot`).
            LeafCopy::Indices | LeafCopy::Blocks => Slots::Ids(order),
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

    /// The copy the slots hold (never [`LeafCopy::Auto`] or [`LeafCopy::Blocks`]).
    pub(crate) fn copy(&self) -> LeafCopy {
        match self.slots {
            Slots::Ids(_) => LeafCopy::Nothing,
            Slots::PackedIndicesAndId(_) => LeafCopy::Indices,
            Slots::IdsAndCorners(..) => LeafCopy::Corners,
        }
    }

    /// The mesh the slots refer to.
    pub(crate) fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// Asks for huge pages under the slots and the mesh's arrays (see `crate::huge_pages`).
    pub(crate) fn advise_huge_pages(&self) {
        self.slots.advise_huge_pages();
        crate::huge_pages::advise(self.mesh.vertices());
        crate::huge_pages::advise(self.mesh.triangles());
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
            Slots::PackedIndicesAndId(packed) => {
                let vertices = self.mesh.vertices();
                let packed = packed[slot];
                (packed.id(), packed.indices().map(|i| vertices[i as usize]))
            }
            Slots::IdsAndCorners(order, corners) => (order[slot], corners[slot]),
        }
    }

    /// Slot `slot`'s triangle id.
    #[inline(always)]
    pub(crate) fn id(&self, slot: u32) -> u32 {
        match &self.slots {
            Slots::Ids(order) | Slots::IdsAndCorners(order, _) => order[slot as usize],
            Slots::PackedIndicesAndId(packed) => packed[slot as usize].id(),
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
            (Slots::PackedIndicesAndId(packed), 0) => {
                packed[first..end].iter().for_each(prefetch);
                false
            }
            (Slots::PackedIndicesAndId(packed), _) => {
                let corners = |slot: &PackedSlot| mesh.prefetch_corners(&slot.indices());
                packed[first..end].iter().for_each(corners);
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
            Slots::PackedIndicesAndId(packed) => packed.len() * size_of::<PackedSlot>(),
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
            (LeafCopy::Auto, 4),
            (LeafCopy::Nothing, 4),
            (LeafCopy::Indices, 12),
            (LeafCopy::Corners, 40),
            (LeafCopy::Blocks, 12),
        ] {
            let mut leaves = LeafTriangles::new(mesh.clone(), order.clone(), copy);
            assert_eq!(leaves.heap_bytes(), order.len() * bytes, "{copy:?}");
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

    /// A packed slot gives back the largest index and every id bit, and does not mix them.
    #[test]
    fn a_packed_slot_keeps_indices_and_id_apart() {
        let top = PackedSlot::MAX_VERTICES as u32 - 1;
        for (indices, id) in [
            ([top, 0, top], u32::MAX),
            ([0, top, 0], 0),
            ([1, 2, 3], 0x8000_0001),
            ([top, top, top], 0x7FF_FC00),
        ] {
            let slot = PackedSlot::new(indices, id);
            assert_eq!((slot.indices(), slot.id()), (indices, id));
        }
    }

    /// A mesh of exactly 2^21 vertices packs its indices, the last one included; one vertex
    /// more and the mesh is read through itself.
    #[test]
    fn meshes_pack_up_to_two_to_the_21_vertices() {
        for (count, bytes) in [
            (PackedSlot::MAX_VERTICES, 12),
            (PackedSlot::MAX_VERTICES + 1, 4),
        ] {
            let vertices = (0..count)
                .map(|i| Vec3::new(i as f32, (i % 7) as f32, 1.0))
                .collect();
            let last = count as u32 - 1;
            let triangles = vec![[0, 1, 2], [last, last - 1, last - 2], [last, 0, 5]];
            let mesh = Arc::new(Mesh::new(vertices, triangles).unwrap());
            let leaves = LeafTriangles::new(mesh.clone(), vec![2, 0, 1], LeafCopy::Indices);
            assert_eq!(leaves.heap_bytes(), 3 * bytes, "{count} vertices");
            for (slot, id) in [(0, 2), (1, 0), (2, 1)] {
                assert_eq!(
                    leaves.get(slot),
                    (id, mesh.triangle(id)),
                    "{count} vertices"
                );
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
