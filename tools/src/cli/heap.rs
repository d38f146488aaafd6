//! The heap's peak during a piece of work: the tool's global allocator is the system's with two
//! counters beside it (bytes in use, their high mark), so `bench` can print a build's peak next
//! to the bytes the finished structure keeps (`Footprint::heap_bytes`).
//!
//! The counters are relaxed atomics: an allocation costs two atomic adds more, which the timed
//! queries pay only for their few allocations per batch (none per ray). The high mark is exact
//! for one thread and for threads that allocate in turn; threads that allocate at the same
//! moment may each raise it to a value that was never in use at once, by at most the size of
//! one allocation per thread.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// The system allocator, counted.
pub struct Counting;

/// Bytes in use and their high mark since the last [`Counters::start`].
struct Counters {
    in_use: AtomicUsize,
    high_mark: AtomicUsize,
}

impl Counters {
    const fn new() -> Self {
        Self {
            in_use: AtomicUsize::new(0),
            high_mark: AtomicUsize::new(0),
        }
    }

    fn grew(&self, bytes: usize) {
        let now = self.in_use.fetch_add(bytes, Relaxed) + bytes;
        self.high_mark.fetch_max(now, Relaxed);
    }

    fn shrank(&self, bytes: usize) {
        self.in_use.fetch_sub(bytes, Relaxed);
    }

    /// Lowers the high mark to what is in use now, and returns that.
    fn start(&self) -> usize {
        let now = self.in_use.load(Relaxed);
        self.high_mark.store(now, Relaxed);
        now
    }

    /// The high mark's rise since `start` returned `from`.
    fn rise(&self, from: usize) -> usize {
        self.high_mark.load(Relaxed).saturating_sub(from)
    }
}

static HEAP: Counters = Counters::new();

// SAFETY: every call is forwarded unchanged to `System`, which upholds `GlobalAlloc`'s contract;
// the counters only observe the sizes of allocations that succeeded.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's guarantees for `layout` are `System::alloc`'s.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            HEAP.grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            HEAP.grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from this allocator, that is from `System`, with `layout`.
        unsafe { System.dealloc(ptr, layout) };
        HEAP.shrank(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `ptr` came from `System` with `layout`; the caller checked `new_size`.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            HEAP.grew(new_size);
            HEAP.shrank(layout.size());
        }
        p
    }
}

/// Runs `work` and returns its value with the most heap bytes in use at once during it, beyond
/// those in use when it started (what the work needed at its peak, including what it returns).
pub fn peak_during<T>(work: impl FnOnce() -> T) -> (T, usize) {
    let start = HEAP.start();
    let value = work();
    (value, HEAP.rise(start))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_high_mark_rises_to_the_most_in_use_at_once() {
        let heap = Counters::new();
        heap.grew(100);
        let from = heap.start();
        heap.grew(1000);
        heap.shrank(1000);
        heap.grew(10);
        assert_eq!(heap.rise(from), 1000);
        heap.shrank(110);
        assert_eq!(heap.start(), 0);
        // A realloc grows before it shrinks: old and new block count at once.
        heap.grew(50);
        heap.shrank(20);
        assert_eq!(heap.rise(0), 50);
    }
}
