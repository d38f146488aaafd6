//! The kd-tree's 8-byte node (after Ericson's compact node, widened to two words
//! so that a split keeps its full `f32` and a leaf its full triangle range).
//!
//! - interior: word 0 is the split position's bits, word 1 is `above << 2 | axis` (axis 0..=2);
//!   the child below the plane is the next node, the one above is node `above`;
//! - leaf: word 0 is the triangle count, word 1 is `first << 2 | 3`: references
//!   `first..first + count` of the tree's reference array.
//!
//! So node and reference indices have 30 bits ([`MAX_INDEX`]).

/// Largest node or reference index a node can hold.
pub const MAX_INDEX: usize = (1 << 30) - 1;

/// The tag of a leaf in the low bits of word 1.
const LEAF: u32 = 3;

/// One kd-tree node (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct KdNode([u32; 2]);

/// A node, decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Decoded {
    /// Split at `position` along `axis`; the child above the plane is node `above` (the one
    /// below is the next node).
    Split {
        axis: usize,
        position: f32,
        above: u32,
    },
    /// References `first..first + count`.
    Leaf { first: u32, count: u32 },
}

impl KdNode {
    /// An interior node; `above <= MAX_INDEX`, `axis < 3`.
    pub(crate) fn split(axis: usize, position: f32, above: u32) -> Self {
        debug_assert!(axis < 3 && above as usize <= MAX_INDEX);
        Self([position.to_bits(), (above << 2) | axis as u32])
    }

    /// A leaf; `first <= MAX_INDEX`.
    pub(crate) fn leaf(first: u32, count: u32) -> Self {
        debug_assert!(first as usize <= MAX_INDEX);
        Self([count, (first << 2) | LEAF])
    }

    /// What the node is.
    #[inline(always)]
    pub(crate) fn decode(self) -> Decoded {
        let [a, b] = self.0;
        match b & 3 {
            LEAF => Decoded::Leaf {
                first: b >> 2,
                count: a,
            },
            axis => Decoded::Split {
                axis: axis as usize,
                position: f32::from_bits(a),
                above: b >> 2,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_are_eight_bytes_and_round_trip() {
        assert_eq!(size_of::<KdNode>(), 8);
        let s = KdNode::split(2, -1.5, MAX_INDEX as u32);
        assert_eq!(
            s.decode(),
            Decoded::Split {
                axis: 2,
                position: -1.5,
                above: MAX_INDEX as u32
            }
        );
        let l = KdNode::leaf(7, 3);
        assert_eq!(l.decode(), Decoded::Leaf { first: 7, count: 3 });
    }
}
