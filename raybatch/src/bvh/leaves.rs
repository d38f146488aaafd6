//! The triangles of a tree's leaves, in leaf-slot order: the mesh (shared, never copied or
//! reordered), the triangle id of every slot, and optionally a copy of each slot's corners.
//!
//! Leaves address their triangles as ranges of slots, so a leaf's triangles are contiguous here.
//! Reading one through the mesh takes two dependent loads (id, then indices, then vertices); the
//! optional corner copy ([`BuildOptions::leaf_corners`], 36 more bytes per triangle) reads them
//! from one contiguous block instead. Every tree built from the SAH builder keeps one of these.

use std::sync::Arc;

use glam::Vec3;

use super::build::BuildOptions;
use crate::mesh::Mesh;
use crate::prefetch::prefetch;

/// A tree's leaf triangles (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct LeafTriangles {
    mesh: Arc<Mesh>,
    /// Slot to triangle id (degenerate triangles have no slot).
    order: Vec<u32>,
    /// Corners of each slot's triangle, if `leaf_corners` (else empty).
    corners: Vec<[Vec3; 3]>,
}

impl LeafTriangles {
    /// The triangles of `order` (the builder's slot order) over `mesh`.
    pub(crate) fn new(mesh: Arc<Mesh>, order: Vec<u32>, options: &BuildOptions) -> Self {
        let corners = if options.leaf_corners {
            order.iter().map(|&id| mesh.triangle(id)).collect()
        } else {
            Vec::new()
        };
        Self {
            mesh,
            order,
            corners,
        }
    }

    /// The mesh the slots refer to.
    pub(crate) fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// Puts `mesh` (the same triangles, moved vertices) in place of the mesh, refreshing the
    /// corner copy (a refit).
    pub(crate) fn replace_mesh(&mut self, mesh: Arc<Mesh>) {
        if !self.corners.is_empty() {
            self.corners = self.order.iter().map(|&id| mesh.triangle(id)).collect();
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
        let id = self.order[slot as usize];
        match self.corners.get(slot as usize) {
            Some(corners) => (id, *corners),
            None => (id, self.mesh.triangle(id)),
        }
    }

    /// Prefetches the next link of the chain of dependent reads behind slots `slots` (slot ->
    /// id -> vertex indices -> corners): at `stage` 0 the ids are read (the slot order is
    /// small and mostly cached) and the vertex indices prefetched, at stage 1 the corners.
    /// Returns true once the corners are on their way (after stage 0 with the corner copy),
    /// so that a caller that takes turns between rays ([`crate::wide::interleaved`]) can issue
    /// one link per turn and find the whole chain in cache when it reads the triangles.
    #[inline(always)]
    pub(crate) fn prefetch(&self, slots: std::ops::Range<u32>, stage: u8) -> bool {
        let (first, end) = (slots.start as usize, slots.end as usize);
        if let Some(corners) = self.corners.get(first..end) {
            corners.iter().for_each(prefetch);
            return true;
        }
        let (triangles, vertices) = (self.mesh.triangles(), self.mesh.vertices());
        for &id in &self.order[first..end] {
            let indices = &triangles[id as usize];
            if stage == 0 {
                prefetch(indices);
            } else {
                indices
                    .iter()
                    .for_each(|&i| prefetch(&vertices[i as usize]));
            }
        }
        stage > 0
    }

    /// Bytes added to the mesh: the slot order and the corner copy.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.order.len() * size_of::<u32>() + self.corners.len() * size_of::<[Vec3; 3]>()
    }
}
