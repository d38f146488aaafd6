//! The one-ray loop's pending children: a stack in a fixed array, pushed without branches in
//! the node's precomputed order for the ray's octant.
//!
//! A visit of a node of `W` children pushes at most `W` and pops the nearest at once, going
//! one level down, so a walk never holds more than `W - 1` entries per level of its path plus
//! the `W` of a push, and the builder keeps every path shorter than [`MAX_DEPTH`]:
//! `(MAX_WIDTH - 1) * MAX_DEPTH + MAX_WIDTH` entries always fit in [`DEPTH_SLOTS`]. Every
//! index is taken modulo [`DEPTH_SLOTS`] into an array [`MAX_WIDTH`] slots longer (a push
//! writes `W` slots whatever the mask), so no index can leave the array whatever `len` is: the
//! compiler drops the bounds checks, and the depth bound keeps the index from wrapping (debug
//! builds check it).
//!
//! The walk is bound by the latency of each node's load and of picking the next child, and by
//! mispredicted branches, more than by instruction count, so the push stays plain: one that
//! compresses the hit children in AVX2 registers (permute to the octant's order, a table of
//! shuffles, one 32-byte store) takes 95 fewer instructions per ray but runs 8% slower, its
//! choice of the next child going through a longer chain of shuffles. Taking the nearest hit
//! child straight from registers instead of popping it back, an 8-wide node's new length from
//! the mask's `popcnt` instead of the writes' running position, and moving the nearest hit
//! child to the front of the node's order (the order then waits for the box test) are all
//! slower too (docs/benchmarks.md).

use std::mem::MaybeUninit;

use super::order::order_slots;
use crate::bvh::build::MAX_DEPTH;

/// A pending child: its word and the distance at which the ray enters its box.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub(crate) struct Pending {
    pub(crate) word: u32,
    pub(crate) entry: f32,
}

/// The widest node the stack takes.
const MAX_WIDTH: usize = 8;

/// Slots a walk can use: a power of two of at least `(MAX_WIDTH - 1) * MAX_DEPTH + MAX_WIDTH`.
const DEPTH_SLOTS: usize = 1024;
const _: () = assert!(
    (MAX_WIDTH - 1) * MAX_DEPTH + MAX_WIDTH <= DEPTH_SLOTS && DEPTH_SLOTS.is_power_of_two()
);

/// The one-ray loop's stack (see the module docs).
///
/// Its slots are not initialised when it is made, so a stack costs nothing to create and a ray
/// traced alone keeps its own on the call stack ([`super::WideBvh`]'s `trace_alone`) instead of
/// looking up the thread's workspace (6% fewer instructions a ray). Only slots below `len`
/// are ever read, and every one of them has been written: see [`Stack::pop`].
pub(crate) struct Stack {
    /// `DEPTH_SLOTS` plus the `MAX_WIDTH` a push may write past the top.
    slots: [MaybeUninit<Pending>; DEPTH_SLOTS + MAX_WIDTH],
    len: usize,
}

impl Default for Stack {
    #[inline(always)]
    fn default() -> Self {
        Self {
            slots: [const { MaybeUninit::uninit() }; DEPTH_SLOTS + MAX_WIDTH],
            len: 0,
        }
    }
}

impl std::fmt::Debug for Stack {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stack").field("len", &self.len).finish()
    }
}

impl Stack {
    /// Empties the stack.
    #[inline(always)]
    pub(crate) fn reset(&mut self) {
        self.len = 0;
    }

    /// Pushes the children hit (bit `k` of `mask` for slot `k`, entering at `entries[k]`) in
    /// the node's order for the ray's octant (`order`: the slots nearest first, `log2(W)` bits
    /// each, see [`super::order::octant_orders`]), farthest first, so the nearest is on top.
    #[inline(always)]
    pub(crate) fn push_hits<const W: usize>(
        &mut self,
        mask: u32,
        entries: &[f32; W],
        children: &[u32; W],
        order: u32,
    ) {
        debug_assert!(mask < 1 << W);
        debug_assert!(self.len + W <= DEPTH_SLOTS, "a walk deeper than MAX_DEPTH");
        let base = self.len % DEPTH_SLOTS;
        let top: &mut [MaybeUninit<Pending>; W] =
            (&mut self.slots[base..base + W]).try_into().unwrap();
        self.len = base + push(top, mask, entries, children, order);
    }

    /// The top entry, left in place.
    #[inline(always)]
    pub(crate) fn peek(&self) -> Option<Pending> {
        let top = self.len.checked_sub(1)?;
        // SAFETY: the slot read is below `len`, so it was written (see `pop`).
        Some(unsafe { self.slots[top % DEPTH_SLOTS].assume_init() })
    }

    /// The top entry, removed.
    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<Pending> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: every slot below `len` has been written since the last `reset`. That holds
        // after `reset` (no slot) and after a pop (fewer slots); a push from `len` writes the
        // `W` slots from `base = len % DEPTH_SLOTS` and sets `len` to at most `base + W`, so
        // the slots below `base` were written before (`base <= len`) and the others now. The
        // slot read, `len % DEPTH_SLOTS` after the decrement, is below the old `len` (either
        // `len` itself or, past `DEPTH_SLOTS`, a smaller index), so it was written.
        Some(unsafe { self.slots[self.len % DEPTH_SLOTS].assume_init() })
    }
}

/// Writes the hit children to `top`, farthest first, and returns how many. Every slot in order
/// is written at the top, which moves past it only if the slot was hit, so which children a
/// ray hits never costs a mispredicted branch.
#[inline(always)]
fn push<const W: usize>(
    top: &mut [MaybeUninit<Pending>; W],
    mask: u32,
    entries: &[f32; W],
    children: &[u32; W],
    order: u32,
) -> usize {
    const { assert!(W.is_power_of_two() && W <= MAX_WIDTH) };
    let mut pushed = 0;
    for slot in order_slots(order, W).rev() {
        top[pushed] = MaybeUninit::new(Pending {
            word: children[slot],
            entry: entries[slot],
        });
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
                let entries: [f32; 4] = std::array::from_fn(|_| rng.range(0.0, 9.0));
                let children = std::array::from_fn(|_| rng.range(0.0, 1e6) as u32);
                stack.reset();
                stack.len = 5;
                stack.push_hits::<4>(mask, &entries, &children, u32::from(order));
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

    /// A long walk of random pushes, peeks and pops, from a stack made without writing its
    /// slots, against a `Vec` doing the same: the same entries come back in the same order
    /// (the stack's unsafe reads only ever meet slots it wrote).
    #[test]
    fn pushes_and_pops_match_a_vec() {
        let mut rng = TestRng::new(5);
        let mut stack = Stack::default();
        let mut model: Vec<Pending> = Vec::new();
        for step in 0..200_000u32 {
            if model.len() + 8 <= 600 && rng.range(0.0, 1.0) < 0.45 {
                let mask = rng.range(0.0, 256.0) as u32 & 255;
                let entries: [f32; 8] = std::array::from_fn(|_| rng.range(0.0, 9.0));
                let children: [u32; 8] = std::array::from_fn(|k| step * 8 + k as u32);
                let order = (0..8u32).fold(0, |word, slot| word | (7 - slot) << (3 * slot));
                stack.push_hits::<8>(mask, &entries, &children, order);
                for slot in 0..8 {
                    if mask & (1 << slot) != 0 {
                        model.push(Pending {
                            word: children[slot],
                            entry: entries[slot],
                        });
                    }
                }
            } else {
                assert_eq!(stack.peek(), model.last().copied(), "step {step}");
                assert_eq!(stack.pop(), model.pop(), "step {step}");
            }
            if rng.range(0.0, 1.0) < 0.001 {
                stack.reset();
                model.clear();
            }
        }
    }

    /// The same for 8-wide nodes: random orders (3 bits a slot) and masks.
    #[test]
    fn pops_the_hit_children_of_eight_in_order() {
        let mut rng = TestRng::new(4);
        let mut stack = Stack::default();
        for _ in 0..5_000 {
            let mut slots: Vec<u32> = (0..8).collect();
            for i in (1..8).rev() {
                slots.swap(i, rng.range(0.0, i as f32 + 1.0) as usize % (i + 1));
            }
            let order = slots.iter().rev().fold(0, |word, &slot| (word << 3) | slot);
            let mask = rng.range(0.0, 256.0) as u32 & 255;
            let entries: [f32; 8] = std::array::from_fn(|_| rng.range(0.0, 9.0));
            let children = std::array::from_fn(|_| rng.range(0.0, 1e6) as u32);
            stack.reset();
            stack.push_hits::<8>(mask, &entries, &children, order);
            let popped: Vec<_> = std::iter::from_fn(|| stack.pop())
                .map(|p| (p.word, p.entry))
                .collect();
            let expected: Vec<_> = slots
                .iter()
                .map(|&slot| slot as usize)
                .filter(|&slot| mask & (1 << slot) != 0)
                .map(|slot| (children[slot], entries[slot]))
                .collect();
            assert_eq!(popped, expected, "order {slots:?} mask {mask:08b}");
        }
    }
}
