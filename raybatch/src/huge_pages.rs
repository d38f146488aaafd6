//! Large arrays asked onto 2 MiB pages, so that a walk through a tree beyond the caches does not
//! also miss the TLB at every node.
//!
//! A 1M-triangle tree and its mesh take some 50 MB. With 4 KiB pages every random node or
//! vertex read is likely to need a page walk as well as a trip to memory (a core's second-level
//! TLB covers 16 MiB of 4 KiB pages), and on a virtual machine a page walk is two nested ones.
//! Embree asks the kernel for transparent huge pages for its trees; we do the same for the
//! arrays a walk reads: tree nodes, leaf copies, mesh vertices and indices. Measured on the
//! 1M-triangle terrain (`bvh8`, one thread, 1M incoherent rays one at a time, best of 4 x 3
//! passes alternated): 498.5 -> 459.6 ms; with every allocation on huge pages (the kernel's
//! `enabled` set to `always`) 371.5 -> 349.9. Batches, which share nodes among rays, gain
//! little (sightlines, any hit: 71.6 -> 69.9).
//!
//! [`advise`] is advice only: it never moves, frees or changes a value (the kernel copies the
//! pages it merges, contents and addresses unchanged), so it cannot change an answer. It works
//! on Linux with glibc, where `madvise` takes `MADV_HUGEPAGE` (back the range with huge pages
//! from now on) and `MADV_COLLAPSE` (merge the pages already written, Linux 6.1 and later);
//! elsewhere, or when the kernel says no (huge pages disabled, an older kernel, memory too
//! fragmented), arrays stay on ordinary pages and nothing else changes.

/// The huge page size on x86-64 and on aarch64 with 4 KiB base pages.
const HUGE_PAGE: usize = 2 << 20;

/// Arrays below this many bytes are left alone: they hold at most one whole huge page.
const ADVISE_FROM_BYTES: usize = 2 * HUGE_PAGE;

/// Asks for the whole 2 MiB pages inside `data` to be huge pages (see the module docs); the
/// partial pages at either end stay as they are. True if the kernel merged them.
pub(crate) fn advise<T>(data: &[T]) -> bool {
    let start = data.as_ptr() as usize;
    let bytes = size_of_val(data);
    if bytes < ADVISE_FROM_BYTES {
        return false;
    }
    let first = start.next_multiple_of(HUGE_PAGE);
    let end = (start + bytes) / HUGE_PAGE * HUGE_PAGE;
    first < end && madvise::huge(first, end - first)
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
mod madvise {
    /// `madvise(MADV_HUGEPAGE)` then `madvise(MADV_COLLAPSE)` on `len` bytes from `start`, both
    /// multiples of the huge page size; true if both succeeded.
    pub(super) fn huge(start: usize, len: usize) -> bool {
        let address = start as *mut libc::c_void;
        // SAFETY: the range lies inside one live allocation (a slice the caller borrows),
        // rounded inwards to whole pages. Both advices leave every byte of it as it was, at
        // the same address: they only choose the page size behind it. A failure (`EINVAL` on
        // older kernels, `ENOMEM`, `EAGAIN`) changes nothing.
        unsafe {
            libc::madvise(address, len, libc::MADV_HUGEPAGE) == 0
                && libc::madvise(address, len, libc::MADV_COLLAPSE) == 0
        }
    }
}

/// The portable twin: ordinary pages.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
mod madvise {
    pub(super) fn huge(_start: usize, _len: usize) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Advice never changes a value, whether or not the kernel takes it; small arrays are left
    /// alone.
    #[test]
    fn advice_keeps_every_value() {
        let values: Vec<u64> = (0..3_000_000u64)
            .map(|k| k.wrapping_mul(0x9e37_79b9))
            .collect();
        let copy = values.clone();
        advise(&values);
        assert_eq!(values, copy);
        assert!(!advise(&values[..1000]));
        assert!(!advise::<u64>(&[]));
    }
}
