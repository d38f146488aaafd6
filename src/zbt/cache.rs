//! The box cache: recomputed node boxes kept in a small direct-mapped table, one per
//! thread, shared by every zero-byte and hybrid tree that thread queries.
//!
//! Recomputing a box reads up to 8 triangles and 24 scattered vertices; the nodes near the root
//! are recomputed by almost every ray, so keeping the last [`ENTRIES`] boxes pays where it hits.
//! Each entry is tagged with the tree's [`StructureId`] (never reused, so a dropped or rebuilt
//! tree can never be served a stale box, as it could if tagged by address) and the node index,
//! so two trees never see each other's boxes. The table is allocated on first use: a tree built
//! with the cache off never allocates it.

use crate::geom::Aabb;
use crate::workspace::StructureId;

/// Entries per thread: about 4K boxes, within the memory budget below.
pub const ENTRIES: usize = 4096;

/// Bytes of one thread's cache once allocated.
pub const BYTES: usize = ENTRIES * size_of::<Entry>();

// The memory budget: at most 256 KiB per thread.
const _: () = assert!(BYTES <= 256 * 1024);

/// A cached box and whose it is (`tree == 0`: empty, as ids are never 0).
#[derive(Clone, Copy, Debug)]
struct Entry {
    tree: u64,
    node: u32,
    bounds: Aabb,
}

const EMPTY: Entry = Entry {
    tree: 0,
    node: 0,
    bounds: Aabb::EMPTY,
};

/// One thread's box cache (see the module docs).
#[derive(Debug, Default)]
pub struct BoxCache {
    entries: Vec<Entry>,
}

impl BoxCache {
    /// The box of node `node` of tree `tree`: the cached one, or `compute()`'s, which then
    /// replaces whatever shared its slot.
    #[inline(always)]
    pub fn get(&mut self, tree: StructureId, node: u32, compute: impl FnOnce() -> Aabb) -> Aabb {
        if self.entries.is_empty() {
            self.entries = vec![EMPTY; ENTRIES];
        }
        let slot = slot_of(tree.get(), node);
        let entry = &mut self.entries[slot];
        if entry.tree == tree.get() && entry.node == node {
            return entry.bounds;
        }
        let bounds = compute();
        *entry = Entry {
            tree: tree.get(),
            node,
            bounds,
        };
        bounds
    }

    /// Bytes this cache holds (0 until first used).
    #[cfg(test)]
    fn heap_bytes(&self) -> usize {
        self.entries.len() * size_of::<Entry>()
    }
}

/// The slot of `(tree, node)`: a multiplicative hash, so that nodes close in index (a subtree)
/// and the same node of two trees spread over the table.
#[inline(always)]
fn slot_of(tree: u64, node: u32) -> usize {
    let key = (node as u64) ^ tree.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    (key.wrapping_mul(0xD6E8_FEB8_6659_FD93) >> (64 - ENTRIES.trailing_zeros())) as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn unit(x: f32) -> Aabb {
        Aabb::new(Vec3::splat(x), Vec3::splat(x + 1.0))
    }

    #[test]
    fn entries_are_tagged_by_tree_and_node() {
        let mut cache = BoxCache::default();
        assert_eq!(cache.heap_bytes(), 0);
        let (a, b) = (StructureId::new(), StructureId::new());
        assert_eq!(cache.get(a, 5, || unit(1.0)), unit(1.0));
        // Served from the cache: the closure's box is not used.
        assert_eq!(cache.get(a, 5, || unit(9.0)), unit(1.0));
        // Another tree, same node: its own box.
        assert_eq!(cache.get(b, 5, || unit(2.0)), unit(2.0));
        assert_eq!(cache.get(a, 6, || unit(3.0)), unit(3.0));
        assert_eq!(cache.heap_bytes(), BYTES);
    }

    #[test]
    fn slots_spread() {
        let id = StructureId::new().get();
        let mut used = vec![false; ENTRIES];
        for node in 0..ENTRIES as u32 {
            used[slot_of(id, node)] = true;
        }
        // A random map fills about 1 - 1/e of the table; a bad hash far less.
        assert!(used.iter().filter(|&&u| u).count() > ENTRIES / 2);
    }
}
