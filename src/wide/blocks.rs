//! Leaf blocks: each leaf's triangles in one contiguous run of words, with the leaf's distinct
//! corners copied in, so that a leaf is one read, as Embree's are.
//!
//! ```text
//! block at word b, for a leaf of c triangles with v distinct corners:
//!   b .. b + c                triangle ids, in slot order
//!   b + c .. b + 2c - 1       per triangle after the first, its corners' places in the
//!                             block's corner list (byte j for corner j; byte 3 unused)
//!   b + 2c - 1 .. + 3v        the distinct corners, x y z as f32 bits, in first-use order
//! ```
//! The first triangle's corners are always the list's first three (a triangle with a slot is
//! not degenerate, so its three indices differ), so its places are not stored.
//!
//! The slot copies of `bvh::leaves` read a leaf through a chain of two dependent loads (the
//! slot's indices, then the corners at them), two trips to memory on a tree beyond the caches.
//! The corner copy breaks the chain but costs 36 bytes a triangle; a block keeps only the
//! leaf's distinct corners. Two triangles sharing an edge (three quarters of the leaves of a
//! terrain) take 60 bytes, within one cache line's worth: 8 - 4/c + 12 v/c bytes a triangle,
//! about 28 on a 1M-triangle terrain (2.5 triangles and 4.5 distinct corners a leaf) against 40
//! for the corner copy with its ids.
//!
//! A leaf word ([`leaf_word`]) then holds the block's first word and the triangle count in
//! place of the first slot; `WideBvh::build` rewrites the collapsed tree's leaf words.

use std::collections::HashMap;
use std::sync::Arc;

use glam::Vec3;

use crate::bvh::nodes::leaf_word;
use crate::mesh::Mesh;
use crate::prefetch::prefetch;

/// Every leaf's block (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct LeafBlocks {
    mesh: Arc<Mesh>,
    words: Vec<u32>,
    /// Triangles in all the blocks.
    len: usize,
}

impl LeafBlocks {
    /// The blocks of the leaves `leaf_words` (slot-range leaf words) over the triangles
    /// `order` (the builder's slot order) of `mesh`, and the block word of each leaf word, in
    /// the order given. `None` if the blocks would not be addressable by a leaf word (or a
    /// leaf word names slots beyond `order`, or a leaf's first triangle repeats an index).
    ///
    /// Blocks are laid out in slot order, so that neighbouring leaves stay neighbours in
    /// memory: in the tree's order instead (a node's leaves side by side), incoherent rays take
    /// 2-6% longer on the 1M-triangle terrain.
    pub(crate) fn new(
        mesh: Arc<Mesh>,
        order: &[u32],
        leaf_words: &[u32],
        parallel: bool,
    ) -> Option<(Self, Vec<u32>)> {
        // Each leaf's (first, count) above its index, so that one integer sort puts the
        // leaves in slot order.
        let mut by_slot: Vec<u64> = leaf_words
            .iter()
            .enumerate()
            .map(|(i, &word)| {
                let (first, count) = leaf_word::unpack(word);
                (u64::from(first) << 5 | u64::from(count - 1)) << 32 | i as u64
            })
            .collect();
        by_slot.sort_unstable();
        // Runs of leaves make their blocks apart (on rayon's pool for large trees), each from
        // word 0; the runs are then joined and their block words moved by what precedes them.
        let runs: Vec<&[u64]> = by_slot.chunks(LEAVES_PER_RUN).collect();
        let parallel = parallel && runs.len() > 1;
        let made = crate::parallel::map(parallel, runs, |run| {
            blocks_of(&mesh, order, leaf_words, run)
        });
        let mut words = Vec::with_capacity(made.iter().flatten().map(|(w, _)| w.len()).sum());
        let mut block_words = vec![0; leaf_words.len()];
        for (run_words, run_blocks) in made.into_iter().collect::<Option<Vec<_>>>()? {
            let offset = u32::try_from(words.len()).ok()?;
            for (leaf, block, count) in run_blocks {
                let block = offset.checked_add(block)?;
                if block as usize >= leaf_word::MAX_SLOTS {
                    return None;
                }
                block_words[leaf] = leaf_word::pack(block, count);
            }
            words.extend_from_slice(&run_words);
        }
        let len = order.len();
        Some((Self { mesh, words, len }, block_words))
    }

    /// The slot order the blocks of `leaf_words` (block words) were made from, and the first
    /// slot of each block (by its first word): blocks are laid out in slot order, so each
    /// leaf's slots follow the slots of the blocks before it.
    pub(crate) fn slot_ranges(
        &self,
        leaf_words: impl Iterator<Item = u32>,
    ) -> (Vec<u32>, HashMap<u32, u32>) {
        let mut blocks: Vec<(u32, u32)> = leaf_words.map(leaf_word::unpack).collect();
        blocks.sort_unstable();
        let mut order = Vec::with_capacity(self.len);
        let mut first_slots = HashMap::with_capacity(blocks.len());
        for (block, count) in blocks {
            first_slots.insert(block, order.len() as u32);
            order.extend_from_slice(&self.words[block as usize..(block + count) as usize]);
        }
        (order, first_slots)
    }

    /// The mesh the ids refer to.
    pub(crate) fn mesh(&self) -> &Arc<Mesh> {
        &self.mesh
    }

    /// Triangles in all the blocks.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Triangle `k` (in slot order) of the leaf of block `block` (its first word) and `count`
    /// triangles: its id and corners.
    #[inline(always)]
    pub(crate) fn get(&self, block: u32, count: u32, k: u32) -> (u32, [Vec3; 3]) {
        let (block, count, k) = (block as usize, count as usize, k as usize);
        let words = &self.words[block..];
        // Triangle 0's stored place word would be at `count - 1`: an id, replaced by a select.
        let stored = words[count + k.max(1) - 1];
        let places = if k == 0 { FIRST_PLACES } else { stored };
        let corner_list = &words[2 * count - 1..];
        let corner = |j: u32| {
            let at = 3 * ((places >> (8 * j)) & 0xFF) as usize;
            let xyz = &corner_list[at..at + 3];
            Vec3::new(
                f32::from_bits(xyz[0]),
                f32::from_bits(xyz[1]),
                f32::from_bits(xyz[2]),
            )
        };
        (words[k], [corner(0), corner(1), corner(2)])
    }

    /// Prefetches the block of `count` triangles at `block`, up to the corners of a strip
    /// (`count + 2` corners: the usual leaf; a larger one finds its last corners on the way).
    #[inline(always)]
    pub(crate) fn prefetch(&self, block: u32, count: u32) {
        const LINE_WORDS: usize = 16;
        let (block, count) = (block as usize, count as usize);
        let end = (block + 2 * count - 1 + 3 * (count + 2)).min(self.words.len());
        let mut word = block;
        while word < end {
            prefetch(&self.words[word]);
            word += LINE_WORDS;
        }
        // The last line, which the stride may skip when the block starts mid-line.
        if end > block {
            prefetch(&self.words[end - 1]);
        }
    }

    /// Asks for huge pages under the blocks (see `crate::huge_pages`).
    pub(crate) fn advise_huge_pages(&self) {
        crate::huge_pages::advise(&self.words);
    }

    /// Bytes added to the mesh.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.words.len() * size_of::<u32>()
    }
}

/// Leaves whose blocks one task of [`LeafBlocks::new`] makes.
const LEAVES_PER_RUN: usize = 16 * 1024;

/// The blocks of the leaves `run` (sorted keys of [`LeafBlocks::new`]) from word 0, and each
/// leaf's index, block and count; `None` as [`LeafBlocks::new`].
#[allow(clippy::type_complexity)]
fn blocks_of(
    mesh: &Mesh,
    order: &[u32],
    leaf_words: &[u32],
    run: &[u64],
) -> Option<(Vec<u32>, Vec<(usize, u32, u32)>)> {
    let mut words = Vec::new();
    let mut corners = Vec::new();
    let mut blocks = Vec::with_capacity(run.len());
    for &key in run {
        let leaf = key as u32 as usize;
        let (first, count) = leaf_word::unpack(leaf_words[leaf]);
        let block = u32::try_from(words.len()).ok()?;
        let ids = order.get(first as usize..(first + count) as usize)?;
        push_block(&mut words, &mut corners, mesh, ids)?;
        blocks.push((leaf, block, count));
    }
    Some((words, blocks))
}

/// The places of a block's first triangle's corners: the first three of its list.
const FIRST_PLACES: u32 = 0x02_01_00;

/// Appends the block of triangles `ids` of `mesh` to `words`, with `corners` as scratch;
/// `None` (nothing appended) if the first triangle's corners are not three different vertices.
fn push_block(
    words: &mut Vec<u32>,
    corners: &mut Vec<u32>,
    mesh: &Mesh,
    ids: &[u32],
) -> Option<()> {
    let start = words.len();
    words.extend_from_slice(ids);
    corners.clear();
    for (k, &id) in ids.iter().enumerate() {
        let places = mesh.triangles()[id as usize]
            .iter()
            .enumerate()
            .fold(0, |places, (j, &vertex)| {
                places | place(corners, vertex) << (8 * j)
            });
        match k {
            0 if places != FIRST_PLACES => {
                words.truncate(start);
                return None;
            }
            0 => {}
            _ => words.push(places),
        }
    }
    let vertices = mesh.vertices();
    for &vertex in corners.iter() {
        words.extend(vertices[vertex as usize].to_array().map(f32::to_bits));
    }
    Some(())
}

/// Where `vertex` is in `corners`, added at the end if it is not there yet.
fn place(corners: &mut Vec<u32>, vertex: u32) -> u32 {
    let at = corners
        .iter()
        .position(|&v| v == vertex)
        .unwrap_or_else(|| {
            corners.push(vertex);
            corners.len() - 1
        });
    at as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::bunny;

    /// Every leaf's block reads back its triangles' ids and corners as the mesh holds them, in
    /// slot order.
    #[test]
    fn blocks_read_back_the_mesh() {
        let mesh = Arc::new(bunny());
        let order: Vec<u32> = (0..mesh.triangle_count() as u32).rev().collect();
        // Leaves of 1 to 16 triangles over every slot, and one repeated.
        let mut leaves = Vec::new();
        let mut first = 0;
        while first < order.len() as u32 {
            let count = (1 + first % 16).min(order.len() as u32 - first);
            leaves.push(leaf_word::pack(first, count));
            first += count;
        }
        leaves.push(leaves[3]);
        let (blocks, block_words) = LeafBlocks::new(mesh.clone(), &order, &leaves, true).unwrap();
        assert_eq!(blocks.len(), order.len());
        assert_eq!(block_words.len(), leaves.len());
        for (&word, &block_word) in leaves.iter().zip(&block_words) {
            let (first, count) = leaf_word::unpack(word);
            let (block, block_count) = leaf_word::unpack(block_word);
            assert_eq!(block_count, count);
            let read: Vec<_> = (0..count).map(|k| blocks.get(block, count, k)).collect();
            let expected: Vec<_> = (first..first + count)
                .map(|slot| order[slot as usize])
                .map(|id| (id, mesh.triangle(id)))
                .collect();
            assert_eq!(read, expected, "leaf {first}+{count}");
            blocks.prefetch(block, count);
        }
    }

    /// Two triangles sharing an edge take less than a cache line: two ids, the second's
    /// corner places and four corners; a leaf whose first triangle repeats a vertex gets no
    /// blocks.
    #[test]
    fn a_shared_edge_shares_corners() {
        let vertices = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE];
        let mesh = Arc::new(Mesh::new(vertices, vec![[0, 1, 2], [2, 1, 3]]).unwrap());
        let (blocks, _) = LeafBlocks::new(mesh, &[0, 1], &[leaf_word::pack(0, 2)], false).unwrap();
        assert_eq!(blocks.heap_bytes(), 60);
        let vertices = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let mesh = Arc::new(Mesh::new(vertices, vec![[0, 0, 2], [0, 1, 2]]).unwrap());
        assert!(LeafBlocks::new(mesh, &[0, 1], &[leaf_word::pack(0, 2)], false).is_none());
    }
}
