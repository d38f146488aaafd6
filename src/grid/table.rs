//! The spatial hash's table: non-empty cells only, found by a multiplicative hash of the cell
//! indices, collisions resolved by linear probing (closed hashing, which suits the caches: no
//! linked lists, one 16-byte slot per cell, slots contiguous).
//!
//! The table is at most half full, so a lookup of an empty cell (the common case in a sparse
//! world) ends at the first free slot after a probe or two; a cell's slot gives the range of
//! its triangle references in one shared array.

/// The key of a free slot (no cell has it: keys are linear cell indices below `2^63`).
const FREE: u64 = u64::MAX;

/// One cell: its linear index and its references `first..first + count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Slot {
    key: u64,
    first: u32,
    count: u32,
}

/// Non-empty cells by linear index (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct CellTable {
    slots: Vec<Slot>,
    len: usize,
}

impl CellTable {
    /// A table for `cells` cells (at most half full).
    pub(crate) fn with_capacity(cells: usize) -> Self {
        let size = (cells.max(1) * 2).next_power_of_two();
        Self {
            slots: vec![
                Slot {
                    key: FREE,
                    first: 0,
                    count: 0
                };
                size
            ],
            len: 0,
        }
    }

    /// The home slot of `key`, a linear cell index `x + nx * (y + ny * z)`: a multiplicative
    /// hash, with the products folded so that the high bits count.
    #[inline(always)]
    fn home(&self, key: u64) -> usize {
        let h = key.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        (h ^ (h >> 29)) as usize & (self.slots.len() - 1)
    }

    /// Stores cell `key` with references `first..first + count`; `count > 0`, each key once,
    /// at most the capacity given.
    pub(crate) fn insert(&mut self, key: u64, first: u32, count: u32) {
        debug_assert!(key != FREE && count > 0 && self.len * 2 < self.slots.len());
        let mask = self.slots.len() - 1;
        let mut i = self.home(key);
        while self.slots[i].key != FREE {
            debug_assert!(self.slots[i].key != key, "cell {key} inserted twice");
            i = (i + 1) & mask;
        }
        self.slots[i] = Slot { key, first, count };
        self.len += 1;
    }

    /// The reference range of cell `key`, empty if the cell holds nothing.
    #[inline(always)]
    pub(crate) fn get(&self, key: u64) -> (u32, u32) {
        let mask = self.slots.len() - 1;
        let mut i = self.home(key);
        loop {
            let slot = self.slots[i];
            if slot.key == key {
                return (slot.first, slot.count);
            }
            if slot.key == FREE {
                return (0, 0);
            }
            i = (i + 1) & mask;
        }
    }

    /// Number of cells stored.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Bytes on the heap.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.slots.len() * size_of::<Slot>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colliding_keys_are_all_found() {
        let mut t = CellTable::with_capacity(8);
        // Keys sharing a home slot: insert until three collide.
        let home = t.home(1);
        let colliding: Vec<u64> = (1..100_000u64)
            .filter(|&k| t.home(k) == home)
            .take(3)
            .collect();
        assert_eq!(colliding.len(), 3);
        for (n, &k) in colliding.iter().enumerate() {
            t.insert(k, n as u32 * 10, n as u32 + 1);
        }
        for (n, &k) in colliding.iter().enumerate() {
            assert_eq!(t.get(k), (n as u32 * 10, n as u32 + 1));
        }
        assert_eq!(t.get(0), (0, 0));
        assert_eq!(t.len(), 3);
        assert!(t.heap_bytes() >= 16 * 16);
    }
}
