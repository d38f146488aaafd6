//! Large arrays asked onto 2 MiB pages, so that a walk through a tree beyond the caches does not
//! also miss the TLB at every node.
//!
//! A 1M-triangle tree and its mesh take some 50 MB. With 4 KiB pages every random node or
//! vertex read is likely to need a page walk as well as a trip to memory (a core's second-level
//! TLB covers 16 MiB of 4 KiB pages), and on a virtual machine a page walk is two nested ones.
//! Embree asks the kernel for transparent huge pages for its trees; we do the same for the
//! arrays a walk reads of a wide tree beyond the caches (`WideBvh::build`): its nodes, its
//! leaf copy, its mesh's vertices and indices. Only there: merging pages is synchronous work
//! (the kernel may compact memory to find huge pages), which smaller trees do not repay, and
//! the advice stays on the address range. On the 1M-triangle terrain (`bvh8`, one thread,
//! incoherent rays one at a time) it saves about 8%; batches, which share nodes among rays,
//! gain little (docs/benchmarks.md).
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
    whole_huge_pages(data).is_some_and(|(start, len)| madvise::huge(start, len).collapsed)
}

/// The whole huge pages inside `data` as `(start, len)`, if it is large enough to advise.
fn whole_huge_pages<T>(data: &[T]) -> Option<(usize, usize)> {
    let start = data.as_ptr() as usize;
    let bytes = size_of_val(data);
    if bytes < ADVISE_FROM_BYTES {
        return None;
    }
    let first = start.next_multiple_of(HUGE_PAGE);
    let end = (start + bytes) / HUGE_PAGE * HUGE_PAGE;
    (first < end).then_some((first, end - first))
}

/// What the kernel said to each advice.
#[derive(Clone, Copy, Debug)]
struct Advised {
    /// `MADV_HUGEPAGE` taken: later pages of the range may be huge.
    #[cfg_attr(not(test), allow(dead_code))]
    marked: bool,
    /// `MADV_COLLAPSE` taken: the range's pages were merged.
    collapsed: bool,
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[allow(unsafe_code)]
mod madvise {
    use super::Advised;

    /// `madvise(MADV_HUGEPAGE)` then `madvise(MADV_COLLAPSE)` on `len` bytes from `start`, both
    /// multiples of the huge page size.
    pub(super) fn huge(start: usize, len: usize) -> Advised {
        let address = start as *mut libc::c_void;
        // SAFETY: the range lies inside one live allocation (a slice the caller borrows),
        // rounded inwards to whole pages. Both advices leave every byte of it as it was, at
        // the same address: they only choose the page size behind it. A failure (`EINVAL` on
        // older kernels, `ENOMEM`, `EAGAIN`) changes nothing.
        let marked = unsafe { libc::madvise(address, len, libc::MADV_HUGEPAGE) } == 0;
        // SAFETY: as above.
        let collapsed = marked && unsafe { libc::madvise(address, len, libc::MADV_COLLAPSE) } == 0;
        Advised { marked, collapsed }
    }
}

/// The portable twin: ordinary pages.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
mod madvise {
    use super::Advised;

    pub(super) fn huge(_start: usize, _len: usize) -> Advised {
        Advised {
            marked: false,
            collapsed: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Advice never changes a value, whether or not the kernel takes it; small arrays are left
    /// alone; the range advised is whole huge pages inside the array.
    #[test]
    fn advice_keeps_every_value() {
        let values: Vec<u64> = (0..3_000_000u64)
            .map(|k| k.wrapping_mul(0x9e37_79b9))
            .collect();
        let copy = values.clone();
        advise(&values);
        assert_eq!(values, copy);
        assert!(!advise(&values[..1000]) && whole_huge_pages(&values[..1000]).is_none());
        assert!(!advise::<u64>(&[]));
        let (start, len) = whole_huge_pages(&values).unwrap();
        let array = values.as_ptr() as usize..values.as_ptr() as usize + 24_000_000;
        assert!(start % HUGE_PAGE == 0 && len % HUGE_PAGE == 0 && len > 0);
        assert!(array.start <= start && start + len <= array.end);
    }

    /// Where the kernel has transparent huge pages, it takes the first advice: the range is
    /// valid (the second, `MADV_COLLAPSE`, may fail for want of memory or on older kernels).
    #[test]
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    fn the_kernel_takes_the_advice() {
        if !std::path::Path::new("/sys/kernel/mm/transparent_hugepage/enabled").exists() {
            return;
        }
        let values = vec![7u8; 6 << 20];
        let (start, len) = whole_huge_pages(&values).unwrap();
        assert!(madvise::huge(start, len).marked);
        assert!(values.iter().all(|&v| v == 7));
    }
}
