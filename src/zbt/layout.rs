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
//! - high word of triangle `P + 1` (the *aux word* of an internal node, which always owns at
//!   least 2 triangles): the precomputed node sorting byte in bits 0..8, then the *inherited
//!   faces* of the first child in bits 8..14 and of the second in bits 14..20 (bit `a`: min on
//!   axis `a`, bit `3 + a`: max), see [`super::build`].
//!
//! Leaves need no aux word. Offsets are relative, so a tree can sit anywhere in a larger array
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
/// First bit of the children's inherited-face masks in the aux word.
const FACES_SHIFT: u32 = 8;
/// Bits of one inherited-face mask.
const FACE_BITS: u32 = 6;

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

/// An internal node's aux word: its ordering byte and the faces each child inherits.
pub(crate) fn aux_word(order: u8, inherited: [u8; 2]) -> u32 {
    debug_assert!(inherited.iter().all(|&m| m < 1 << FACE_BITS));
    order as u32
        | (inherited[0] as u32) << FACES_SHIFT
        | (inherited[1] as u32) << (FACES_SHIFT + FACE_BITS)
}

/// The ordering byte of an aux word.
#[inline(always)]
pub(crate) fn aux_order(aux: u32) -> u8 {
    aux as u8
}

/// The faces each child inherits, from an aux word.
#[inline(always)]
pub(crate) fn aux_inherited(aux: u32) -> [u8; 2] {
    let mask = (1 << FACE_BITS) - 1;
    [
        ((aux >> FACES_SHIFT) & mask) as u8,
        ((aux >> (FACES_SHIFT + FACE_BITS)) & mask) as u8,
    ]
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
        let w = aux_word(0xA5, [0b10_1101, 0b11_1111]);
        assert!(w < 1 << 24);
        assert_eq!(aux_order(w), 0xA5);
        assert_eq!(aux_inherited(w), [0b10_1101, 0b11_1111]);
        assert_eq!(aux_inherited(aux_word(7, [0, 0])), [0, 0]);
    }
}
