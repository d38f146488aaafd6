//! A hint that a value will be read soon, so that the CPU fetches its cache line while other
//! work goes on: what lets the interleaved engines (`wide::interleaved`) overlap one ray's
//! cache misses with other rays' arithmetic.
//!
//! A prefetch never faults, never changes memory and never changes what a later read
//! returns, so it cannot change an answer; the portable twin is to do nothing (other targets,
//! and the tests compare the interleaved engine, which prefetches, with the one-ray loop,
//! which does not).

/// Asks for the cache line holding the start of `value` to be brought into the L1 cache.
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    // SAFETY: `prefetcht0` takes any address (it is a hint: it neither faults nor writes);
    // this one is the address of a live value. SSE, which it needs, is part of the x86-64
    // baseline.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
