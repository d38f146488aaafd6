//! The one-ray loop's stack of pending nodes ([`PendingStack`]): the thread's `Vec`, which
//! takes a tree of any depth, or a [`FixedStack`] on the call stack, which a ray traced alone
//! brings so as not to look up the thread's workspace.
//!
//! The binary loop pushes at most one node per level of its path (the far child) and goes one
//! level down, so it never holds more than `depth - 1` entries ([`crate::bvh::Bvh::depth`]).

use std::mem::MaybeUninit;

/// What the one-ray loop needs of a stack.
pub(crate) trait PendingStack<T> {
    /// Empties the stack for a walk of a tree `depth` nodes deep.
    fn start(&mut self, depth: usize);
    /// Puts `item` on top.
    fn push(&mut self, item: T);
    /// The top item, removed.
    fn pop(&mut self) -> Option<T>;
}

/// Grown to the tree's depth once per thread, then reused.
impl<T> PendingStack<T> for Vec<T> {
    #[inline(always)]
    fn start(&mut self, depth: usize) {
        self.clear();
        self.reserve(depth + 1);
    }

    #[inline(always)]
    fn push(&mut self, item: T) {
        Vec::push(self, item);
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        Vec::pop(self)
    }
}

/// A stack of at most `N` items in an inline array whose slots are not initialised when it is
/// made, so that making one per ray costs nothing (an array of defaults would be written whole
/// each time). Only slots below `len` are read, and each was written (see [`FixedStack::pop`]).
/// A push beyond `N` panics (a tree deeper than its [`crate::bvh::Bvh::depth`] says): callers
/// take a `FixedStack` only for trees that fit.
pub(crate) struct FixedStack<T, const N: usize> {
    slots: [MaybeUninit<T>; N],
    len: usize,
}

impl<T: Copy, const N: usize> FixedStack<T, N> {
    /// An empty stack.
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Self {
            slots: [const { MaybeUninit::uninit() }; N],
            len: 0,
        }
    }
}

impl<T: Copy, const N: usize> PendingStack<T> for FixedStack<T, N> {
    /// Its capacity is fixed: the caller has checked that `depth` fits.
    #[inline(always)]
    fn start(&mut self, depth: usize) {
        debug_assert!(depth <= N + 1, "a tree {depth} deep on a stack of {N}");
        self.len = 0;
    }

    #[inline(always)]
    fn push(&mut self, item: T) {
        self.slots[self.len] = MaybeUninit::new(item);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: every slot below `len` has been written since the stack was made: none at
        // first, a push writes slot `len` before counting it, a pop (or `start`) only lowers
        // `len`. The slot read is below the old `len`.
        Some(unsafe { self.slots[self.len].assume_init() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;

    /// A long walk of random pushes, pops and restarts, from a stack made without writing its
    /// slots, against a `Vec` doing the same: the same items come back in the same order (the
    /// one unsafe read only ever meets slots the stack wrote).
    #[test]
    fn pushes_and_pops_match_a_vec() {
        let mut rng = TestRng::new(7);
        let mut stack = FixedStack::<(u32, f32), 97>::new();
        let mut model: Vec<(u32, f32)> = Vec::new();
        for step in 0..200_000u32 {
            if model.len() < 97 && rng.range(0.0, 1.0) < 0.5 {
                let item = (step, rng.range(0.0, 9.0));
                stack.push(item);
                PendingStack::push(&mut model, item);
            } else {
                assert_eq!(stack.pop(), PendingStack::pop(&mut model), "step {step}");
            }
            if rng.range(0.0, 1.0) < 0.001 {
                stack.start(97);
                model.start(97);
            }
        }
    }

    /// A push beyond the capacity panics instead of writing past the array.
    #[test]
    #[should_panic]
    fn a_push_past_the_capacity_panics() {
        let mut stack = FixedStack::<u32, 4>::new();
        for item in 0..5 {
            stack.push(item);
        }
    }
}
