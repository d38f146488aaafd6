//! Per-thread working memory: the batched engine's arrays and each structure's scratch
//! ([`crate::accel::Accel::Scratch`]: traversal stacks, box caches), in one place.
//!
//! Queries run with the calling thread's workspace ([`Workspace::with_local`]), so a thread
//! that answers many queries allocates on its first ones only, and threads never share one.
//! Each structure type gets one scratch value per thread, found by type: every tree of one
//! type that a thread queries shares it (a box cache must therefore tag its entries by tree).
//! A query issued from inside another one's callback on the same thread gets a fresh workspace.

use std::any::{Any, TypeId};
use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::batch::scratch::BatchScratch;

/// The working memory of the queries run on one thread.
#[derive(Default)]
pub struct Workspace {
    /// The batched engine's lanes and answer arrays.
    pub(crate) batch: BatchScratch,
    /// One scratch value per structure type with its type's id, looked up by a linear scan
    /// (few entries) that compares ids without calling through the trait object.
    scratch: Vec<(TypeId, Box<dyn Any + Send>)>,
}

thread_local! {
    static LOCAL: RefCell<Workspace> = RefCell::new(Workspace::default());
}

impl Workspace {
    /// Runs `f` with this thread's workspace (or a fresh one if a query is already using it,
    /// which happens when a hit callback issues another query).
    #[inline]
    pub fn with_local<R>(f: impl FnOnce(&mut Workspace) -> R) -> R {
        LOCAL.with(|cell| match cell.try_borrow_mut() {
            Ok(mut workspace) => f(&mut workspace),
            Err(_) => f(&mut Workspace::default()),
        })
    }

    /// The scratch value of type `S`, created on first use.
    #[inline]
    pub fn scratch<S: Default + Send + 'static>(&mut self) -> &mut S {
        self.parts::<S>().1
    }

    /// The batched engine's arrays and the scratch of type `S`, both at once.
    ///
    /// Inlined: a ray traced alone looks its scratch up on every call (the first call's
    /// allocation is out of line, in [`Workspace::add`]).
    #[inline]
    pub(crate) fn parts<S: Default + Send + 'static>(&mut self) -> (&mut BatchScratch, &mut S) {
        let id = TypeId::of::<S>();
        let index = match self.scratch.iter().position(|(t, _)| *t == id) {
            Some(index) => index,
            None => self.add::<S>(),
        };
        let scratch = self.scratch[index]
            .1
            .downcast_mut::<S>()
            .unwrap_or_else(|| unreachable!("the entry was found or created with type S"));
        (&mut self.batch, scratch)
    }

    /// Adds the scratch of type `S`; returns its index.
    #[cold]
    #[inline(never)]
    fn add<S: Default + Send + 'static>(&mut self) -> usize {
        self.scratch
            .push((TypeId::of::<S>(), Box::new(S::default())));
        self.scratch.len() - 1
    }
}

/// A process-unique id for a structure, to tag the entries of a per-thread cache shared by
/// every structure of one type (the zero-byte tree's box cache): ids are never reused, so a
/// dropped or rebuilt structure can never match a stale entry, as its address could.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StructureId(u64);

impl StructureId {
    /// A new id, different from every other id of the process.
    pub fn new() -> Self {
        static NEXT: AtomicU64 = AtomicU64::new(1);
        Self(NEXT.fetch_add(1, Ordering::Relaxed))
    }

    /// The id as a number (never 0, so 0 can mark an empty cache entry).
    pub fn get(self) -> u64 {
        self.0
    }
}

impl Default for StructureId {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_scratch_per_type_kept_between_calls() {
        let mut w = Workspace::default();
        w.scratch::<Vec<u32>>().push(7);
        *w.scratch::<u64>() = 3;
        assert_eq!(w.scratch::<Vec<u32>>(), &[7]);
        assert_eq!(*w.scratch::<u64>(), 3);
    }

    #[test]
    fn structure_ids_are_unique_and_never_zero() {
        let ids: Vec<u64> = (0..1000).map(|_| StructureId::new().get()).collect();
        let mut sorted = ids.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), ids.len());
        assert!(!ids.contains(&0));
    }

    #[test]
    fn reentrant_use_gets_a_fresh_workspace() {
        Workspace::with_local(|outer| {
            outer.scratch::<Vec<u8>>().push(1);
            Workspace::with_local(|inner| assert!(inner.scratch::<Vec<u8>>().is_empty()));
        });
    }
}
