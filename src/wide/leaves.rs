//! A wide tree's leaf triangles: slot ranges over the binary tree's [`LeafTriangles`] (no copy,
//! the index copy or the corner copy), or one block per leaf ([`LeafBlocks`]). Both are read
//! through the leaf word, triangle `k` of the leaf at a time, so the walks need not know which.

use std::sync::Arc;

use glam::Vec3;

use super::blocks::LeafBlocks;
use crate::bvh::leaves::LeafTriangles;
use crate::bvh::nodes::leaf_word;
use crate::mesh::Mesh;

/// The triangles a wide tree's leaf words address (see the module docs).
#[derive(Clone, Debug)]
pub(crate) enum WideLeaves {
    /// Leaf words hold slot ranges.
    Slots(LeafTriangles),
    /// Leaf words hold a block's first word.
    Blocks(LeafBlocks),
}

impl WideLeaves {
    /// The mesh the triangle ids refer to.
    pub(crate) fn mesh(&self) -> &Arc<Mesh> {
        match self {
            WideLeaves::Slots(slots) => slots.mesh(),
            WideLeaves::Blocks(blocks) => blocks.mesh(),
        }
    }

    /// Triangles in the leaves.
    #[inline(always)]
    pub(crate) fn len(&self) -> usize {
        match self {
            WideLeaves::Slots(slots) => slots.len(),
            WideLeaves::Blocks(blocks) => blocks.len(),
        }
    }

    /// Triangle `k` of leaf `word` (`k` below its count), in slot order: its id and corners.
    #[inline(always)]
    pub(crate) fn get(&self, word: u32, k: u32) -> (u32, [Vec3; 3]) {
        let (first, count) = leaf_word::unpack(word);
        match self {
            WideLeaves::Slots(slots) => slots.get(first + k),
            WideLeaves::Blocks(blocks) => blocks.get(first, count, k),
        }
    }

    /// Prefetches link `stage` of leaf `word`'s chain of reads (see [`LeafTriangles::prefetch`];
    /// a block is one link). Returns true once the corners are on their way.
    #[inline(always)]
    pub(crate) fn prefetch(&self, word: u32, stage: u8) -> bool {
        let (first, count) = leaf_word::unpack(word);
        match self {
            WideLeaves::Slots(slots) => slots.prefetch(first..first + count, stage),
            WideLeaves::Blocks(blocks) => {
                blocks.prefetch(first, count);
                true
            }
        }
    }

    /// Asks for huge pages under the copies and the mesh's arrays (see `crate::huge_pages`).
    pub(crate) fn advise_huge_pages(&self) {
        match self {
            WideLeaves::Slots(slots) => slots.advise_huge_pages(),
            WideLeaves::Blocks(blocks) => blocks.advise_huge_pages(),
        }
    }

    /// Bytes added to the mesh.
    pub(crate) fn heap_bytes(&self) -> usize {
        match self {
            WideLeaves::Slots(slots) => slots.heap_bytes(),
            WideLeaves::Blocks(blocks) => blocks.heap_bytes(),
        }
    }
}
