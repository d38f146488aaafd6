//! Where the zero-byte tree hides its nodes: the spare high bits of the mesh's vertex indices.
//!
//! Vertex indices are kept below 2^24, so each of a triangle's three 32-bit indices has 8 spare
//! high bits: 24 bits per triangle, read as one *high word* (index 0's byte in bits 0..8, index
//! 1's in 8..16, index 2's in 16..24). A node is identified with the position of its first
//! triangle `P` and owns triangles `P..P + count`:
//!
//! - high word of triangle `P` (the *node word*): `count - 1` in bits 0..3, and in bits 3..24
//!   the offset from `P` to the second child (0 for a leaf). The first child is implicit: it
//!   starts right after the node's triangles, at `P + count`.
//! - high word of triangle `P + 1` (the *aux word*, only meaningful when `count >= 2`): the
//!   precomputed node sorting byte in bits 0..8 (internal nodes), then in bit 8 the *selected*
//!   flag and from bit 9 a 2-bit corner selector for each of the node's first 7 triangles (see
//!   [`super::BoxVertices::Selected`]).
//!
//! A node with one triangle has no aux word: an internal one reads its first child's node word
//! as its ordering byte. That is the seed's "wrong but harmless" case: the byte only orders the
//! visit, never the answer. Offsets are relative, so a tree can sit anywhere in a larger array
//! (the hybrid tree's chunks); 21 offset bits bound a zero-byte tree to [`MAX_TRIANGLES`].

/// Bits of a vertex index that address vertices; the rest hold node data.
pub(crate) const INDEX_BITS: u32 = 24;
/// Mask of the address bits of a vertex index.
pub(crate) const INDEX_MASK: u32 = (1 << INDEX_BITS) - 1;
/// Most vertices a zero-byte tree's mesh may have: indices must leave 8 bits free.
pub const MAX_VERTICES: usize = 1 << INDEX_BITS;
/// Bits of the node word holding `count - 1`.
const COUNT_BITS: u32 = 3;
/// Most triangles one node owns.
pub(crate) const MAX_NODE_TRIANGLES: u32 = 1 << COUNT_BITS;
/// Bits of the node word holding the offset to the second child.
const OFFSET_BITS: u32 = INDEX_BITS - COUNT_BITS;
/// Most triangles one zero-byte tree may hold: offsets to a second child must fit 21 bits.
pub const MAX_TRIANGLES: usize = 1 << OFFSET_BITS;
/// Triangles of a node that carry a corner selector in the aux word.
pub(crate) const MAX_SELECTORS: usize = 7;
/// Bit of the aux word that says the node's box comes from one selected corner per triangle.
const SELECTED_BIT: u32 = 1 << 8;
/// First selector bit of the aux word.
const SELECTOR_SHIFT: u32 = 9;

/// The 24-bit high word of a packed triangle.
#[inline(always)]
pub(crate) fn high_word(triangle: &[u32; 3]) -> u32 {
    (triangle[0] >> INDEX_BITS)
        | ((triangle[1] >> INDEX_BITS) << 8)
        | ((triangle[2] >> INDEX_BITS) << 16)
}

/// Stores `word` (24 bits) in the high bits of `triangle`, keeping its vertex indices.
pub(crate) fn set_high_word(triangle: &mut [u32; 3], word: u32) {
    debug_assert!(word < 1 << 24);
    for (k, index) in triangle.iter_mut().enumerate() {
        *index = (*index & INDEX_MASK) | (((word >> (8 * k)) & 0xFF) << INDEX_BITS);
    }
}

/// The vertex indices of a packed triangle, node data removed.
#[inline(always)]
pub(crate) fn indices(triangle: &[u32; 3]) -> [u32; 3] {
    triangle.map(|i| i & INDEX_MASK)
}

/// A node word: `count` triangles (1..=8), second child `offset` positions ahead (0: leaf).
pub(crate) fn node_word(count: u32, offset: u32) -> u32 {
    debug_assert!((1..=MAX_NODE_TRIANGLES).contains(&count));
    debug_assert!((offset as usize) < MAX_TRIANGLES);
    (count - 1) | (offset << COUNT_BITS)
}

/// `(count, offset)` of a node word.
#[inline(always)]
pub(crate) fn unpack_node_word(word: u32) -> (u32, u32) {
    ((word & (MAX_NODE_TRIANGLES - 1)) + 1, word >> COUNT_BITS)
}

/// An aux word: the ordering byte and, if given, one corner selector per triangle.
pub(crate) fn aux_word(order: u8, selectors: Option<&[u8]>) -> u32 {
    let Some(selectors) = selectors else {
        return order as u32;
    };
    debug_assert!(selectors.len() <= MAX_SELECTORS && selectors.iter().all(|&s| s < 3));
    selectors
        .iter()
        .enumerate()
        .fold(order as u32 | SELECTED_BIT, |w, (k, &s)| {
            w | ((s as u32) << (SELECTOR_SHIFT + 2 * k as u32))
        })
}

/// The ordering byte of an aux word.
#[inline(always)]
pub(crate) fn aux_order(aux: u32) -> u8 {
    aux as u8
}

/// The corner selectors of an aux word (`None` if the box needs every corner), as a word
/// whose 2-bit fields, lowest first, are the selectors of the node's triangles.
#[inline(always)]
pub(crate) fn aux_selectors(aux: u32) -> Option<u32> {
    (aux & SELECTED_BIT != 0).then_some(aux >> SELECTOR_SHIFT)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn high_word_round_trips_and_keeps_indices() {
        let mut t = [INDEX_MASK, 5, 0x00AB_CDEF];
        set_high_word(&mut t, 0x00A1_B2C3);
        assert_eq!(high_word(&t), 0x00A1_B2C3);
        assert_eq!(indices(&t), [INDEX_MASK, 5, 0x00AB_CDEF]);
        set_high_word(&mut t, 0);
        assert_eq!(t, [INDEX_MASK, 5, 0x00AB_CDEF]);
    }

    #[test]
    fn node_words_round_trip_at_the_limits() {
        for count in 1..=MAX_NODE_TRIANGLES {
            for offset in [0, 1, 7, MAX_TRIANGLES as u32 - 1] {
                let w = node_word(count, offset);
                assert!(w < 1 << 24);
                assert_eq!(unpack_node_word(w), (count, offset));
            }
        }
    }

    #[test]
    fn aux_words_round_trip() {
        let sel = [2u8, 0, 1, 2, 1, 0, 2];
        let w = aux_word(0xA5, Some(&sel));
        assert!(w < 1 << 24);
        assert_eq!(aux_order(w), 0xA5);
        let s = aux_selectors(w).unwrap();
        for (k, &e) in sel.iter().enumerate() {
            assert_eq!((s >> (2 * k)) & 3, e as u32);
        }
        assert_eq!(aux_selectors(aux_word(7, None)), None);
        assert_eq!(aux_order(aux_word(7, None)), 7);
    }
}
