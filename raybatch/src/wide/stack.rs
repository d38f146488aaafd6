//! The one-ray loop's pending children: a stack in a fixed array, pushed without branches in
//! the node's precomputed order for the ray's octant.
//!
//! A visit pushes at most four children and pops the nearest at once, going one level down, so
//! a walk never holds more than three entries per level of its path plus the four of a push,
//! and the builder keeps every path shorter than [`MAX_DEPTH`]: `3 * MAX_DEPTH + 4` entries
//! always fit in [`DEPTH_SLOTS`]. Every index
//! is taken modulo [`DEPTH_SLOTS`] into an array four slots longer (a push writes four slots
//! whatever the mask), so no index can leave the array whatever `len` is: the compiler drops
//! the bounds checks, and the depth bound keeps the index from wrapping (debug builds check it).
//!
//! The walk is bound by the latency of each node's load and of picking the next child, and by
//! mispredicted branches, more than by instruction count: a push that compressed the hit children in AVX2 registers (permute to the
//! octant's order, a table of shuffles, one 32-byte store) took 95 fewer instructions per ray
//! but ran 8% slower (fandisk, 1M incoherent rays: 222 against 206 ms, best of 5 x 3 passes),
//! its choice of the next child going through a longer chain of shuffles; it was dropped.

use glam::Vec4;

use crate::bvh::build::MAX_DEPTH;

/// A pending child: its word and the distance at which the ray enters its box.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub(crate) struct Pending {
    pub(crate) word: u32,
    pub(crate) entry: f32,
}

/// Slots a walk can use: a power of two of at least `3 * MAX_DEPTH + 4`.
const DEPTH_SLOTS: usize = 512;
const _: () = assert!(3 * MAX_DEPTH + 4 <= DEPTH_SLOTS && DEPTH_SLOTS.is_power_of_two());

/// The one-ray loop's stack (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct Stack {
    /// `DEPTH_SLOTS` plus the four a push may write past the top.
    slots: Box<[Pending; DEPTH_SLOTS + 4]>,
    len: usize,
}

impl Default for Stack {
    fn default() -> Self {
        Self {
            slots: Box::new([Pending::default(); DEPTH_SLOTS + 4]),
            len: 0,
        }
    }
}

impl Stack {
    /// Empties the stack.
    #[inline(always)]
    pub(crate) fn reset(&mut self) {
        self.len = 0;
    }

    /// Pushes the children hit (bit `k` of `mask` for slot `k`, entering at `entries[k]`) in
    /// the node's order for the ray's octant (`order`, see
    /// [`super::node::WideNode::order_children`]), farthest first, so the nearest is on top.
    #[inline(always)]
    pub(crate) fn push_hits(&mut self, mask: u32, entries: Vec4, children: &[u32; 4], order: u8) {
        debug_assert!(mask < 16);
        debug_assert!(self.len + 4 <= DEPTH_SLOTS, "a walk deeper than MAX_DEPTH");
        let base = self.len % DEPTH_SLOTS;
        let top: &mut [Pending; 4] = (&mut self.slots[base..base + 4]).try_into().unwrap();
        self.len = base + push(top, mask, entries, children, order);
    }

    /// The top entry, removed.
    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<Pending> {
        self.len = self.len.checked_sub(1)?;
        Some(self.slots[self.len % DEPTH_SLOTS])
    }
}

/// Writes the hit children to `top`, farthest first, and returns how many. Every slot in order
/// is written at the top, which moves past it only if the slot was hit, so which children a
/// ray hits never costs a mispredicted branch.
#[inline(always)]
fn push(top: &mut [Pending; 4], mask: u32, entries: Vec4, children: &[u32; 4], order: u8) -> usize {
    let entries = entries.to_array();
    let mut pushed = 0;
    for k in (0..4).rev() {
        let slot = ((order >> (2 * k)) & 3) as usize;
        top[pushed] = Pending {
            word: children[slot],
            entry: entries[slot],
        };
        pushed += ((mask >> slot) & 1) as usize;
    }
    pushed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;

    /// Every order byte a node can hold: a permutation of the four slots.
    fn permutations() -> Vec<u8> {
        let all: Vec<u8> = (0..=255u8)
            .filter(|byte| (0..4).fold(0u8, |seen, k| seen | 1 << ((byte >> (2 * k)) & 3)) == 15)
            .collect();
        assert_eq!(all.len(), 24);
        all
    }

    /// For every order and mask (none hit included), popping returns the hit children nearest
    /// first in the order, with their entries.
    #[test]
    fn pops_the_hit_children_in_order() {
        let mut rng = TestRng::new(3);
        let mut stack = Stack::default();
        for order in permutations() {
            for mask in 0..16u32 {
                let entries = Vec4::from_array(std::array::from_fn(|_| rng.range(0.0, 9.0)));
                let children = std::array::from_fn(|_| rng.range(0.0, 1e6) as u32);
                stack.reset();
                stack.len = 5;
                stack.push_hits(mask, entries, &children, order);
                let mut popped = Vec::new();
                while stack.len > 5 {
                    let pending = stack.pop().unwrap();
                    popped.push((pending.word, pending.entry));
                }
                let expected: Vec<_> = (0..4)
                    .map(|k| ((order >> (2 * k)) & 3) as usize)
                    .filter(|&slot| mask & (1 << slot) != 0)
                    .map(|slot| (children[slot], entries[slot]))
                    .collect();
                assert_eq!(popped, expected, "order {order:08b} mask {mask:04b}");
            }
        }
    }
}
