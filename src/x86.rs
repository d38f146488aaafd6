//! x86-64 SIMD pieces every layer's hand-written AVX2 shares: the [`Avx2`] token that proves
//! the CPU has AVX2, the 8x8 transpose that turns eight 32-byte records into eight
//! columns (ray preparation, the stream split, the eight-ray sign filter), and the unaligned
//! loads and stores of eight lanes the eight-ray tests read their columns with.

use std::arch::x86_64::{
    __m256, _mm256_loadu_ps, _mm256_permute2f128_ps, _mm256_shuffle_ps, _mm256_storeu_ps,
    _mm256_unpackhi_ps, _mm256_unpacklo_ps,
};

/// Proof that the CPU has AVX2: only [`Avx2::detect`] makes one, so the safe functions that take
/// it may run AVX2 code.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2(());

impl Avx2 {
    /// `Some` if the CPU has AVX2.
    pub(crate) fn detect() -> Option<Self> {
        std::arch::is_x86_feature_detected!("avx2").then_some(Self(()))
    }

    /// For tests: [`Avx2::detect`], and without AVX2 a note on stderr saying what the test
    /// does instead (`instead`), written directly so that the harness shows it on success.
    #[cfg(test)]
    pub(crate) fn detect_or_note(instead: &str) -> Option<Self> {
        let found = Self::detect();
        if found.is_none() {
            let note = format!("note: this CPU lacks AVX2: {instead}\n");
            let _ = std::io::Write::write_all(&mut std::io::stderr(), note.as_bytes());
        }
        found
    }
}

/// Eight rows of eight values to eight columns: `out[c]` lane `r` is `rows[r]` lane `c`.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn transpose(rows: [__m256; 8]) -> [__m256; 8] {
    let [r0, r1, r2, r3, r4, r5, r6, r7] = rows;
    // Pairs of rows interleaved, then quads, within each 128-bit half...
    let pairs = |a, b| (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
    let quads = |a, b| {
        (
            _mm256_shuffle_ps::<0x44>(a, b),
            _mm256_shuffle_ps::<0xEE>(a, b),
        )
    };
    let ((t0, t1), (t2, t3)) = (pairs(r0, r1), pairs(r2, r3));
    let ((t4, t5), (t6, t7)) = (pairs(r4, r5), pairs(r6, r7));
    let ((u0, u1), (u2, u3)) = (quads(t0, t2), quads(t1, t3));
    let ((u4, u5), (u6, u7)) = (quads(t4, t6), quads(t5, t7));
    // ...then the halves: rows 0-3 low, rows 4-7 high.
    let low = |a, b| _mm256_permute2f128_ps::<0x20>(a, b);
    let high = |a, b| _mm256_permute2f128_ps::<0x31>(a, b);
    [
        low(u0, u4),
        low(u1, u5),
        low(u2, u6),
        low(u3, u7),
        high(u0, u4),
        high(u1, u5),
        high(u2, u6),
        high(u3, u7),
    ]
}

/// Stores eight `f32` (any alignment).
///
/// # Safety
/// The CPU must support AVX.
#[inline]
#[target_feature(enable = "avx")]
pub(crate) unsafe fn store(out: &mut [f32; 8], v: __m256) {
    // SAFETY: `out` is 32 writable bytes.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) }
}

/// Loads eight `f32` stored as their bits (a column of the batch's lanes; any alignment).
///
/// # Safety
/// The CPU must support AVX.
#[inline]
#[target_feature(enable = "avx")]
pub(crate) unsafe fn load_bits(v: &[u32; 8]) -> __m256 {
    // SAFETY: `v` is 32 readable bytes.
    unsafe { _mm256_loadu_ps(v.as_ptr().cast::<f32>()) }
}

/// Loads eight `f32` (any alignment).
///
/// # Safety
/// The CPU must support AVX.
#[inline]
#[target_feature(enable = "avx")]
pub(crate) unsafe fn load(v: &[f32; 8]) -> __m256 {
    // SAFETY: `v` is 32 readable bytes.
    unsafe { _mm256_loadu_ps(v.as_ptr()) }
}
