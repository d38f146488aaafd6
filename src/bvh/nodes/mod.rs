//! Node storage formats of the [`super::AabbTree`]: how a built tree ([`super::build`]) is packed
//! and read back.
//!
//! - [`full`]: 32 bytes per node, `f32` bounds.
//! - [`quantized`]: 16 bytes per node, `u16` bounds on a grid over the root box, rounded
//!   outward, so the boxes only grow and answers stay identical.

pub mod full;
pub mod quantized;

use super::Node;
use super::build::{BuildError, BuiltTree};
use crate::geom::Aabb;

pub use full::FullNodes;
pub use quantized::QuantizedNodes;

/// A node storage format for [`super::AabbTree`].
pub trait NodeFormat: Sized + Send + Sync {
    /// Name for tables.
    const NAME: &'static str;
    /// See [`super::Bvh::AVX2_TRAVERSAL`].
    const AVX2_TRAVERSAL: bool = true;
    /// Packs built nodes; fails if the format cannot address them.
    fn pack(built: &BuiltTree) -> Result<Self, BuildError>;
    /// Number of nodes.
    fn node_count(&self) -> usize;
    /// The (possibly enlarged) box of node `index`.
    fn bounds(&self, index: u32) -> Aabb;
    /// The contents of node `index`.
    fn node(&self, index: u32) -> Node;
    /// Bytes of the node array.
    fn heap_bytes(&self) -> usize;
}

/// The leaf word both formats share: bit 31 set, `count - 1` in bits 27..31, first triangle
/// slot in bits 0..27 (in a wide tree over leaf blocks, `wide::blocks`, the block's first
/// word instead).
pub(crate) mod leaf_word {
    /// Marks a leaf word.
    pub const LEAF_BIT: u32 = 1 << 31;
    const COUNT_SHIFT: u32 = 27;
    const SLOT_MASK: u32 = (1 << COUNT_SHIFT) - 1;
    /// Largest number of triangle slots a leaf word can address.
    pub const MAX_SLOTS: usize = 1 << COUNT_SHIFT;

    // The 4 count bits hold `count - 1` for every leaf size the builder makes.
    const _: () = assert!(crate::bvh::build::MAX_LEAF_SIZE as usize <= 16);

    /// Packs a leaf's triangle range (`count` in 1..=16, `first` < [`MAX_SLOTS`]). The padding
    /// node (an empty leaf, see [`crate::bvh::build::FIRST_PAIR`]) is stored as one triangle
    /// behind an empty box, which no ray ever enters.
    pub fn pack(first: u32, count: u32) -> u32 {
        LEAF_BIT | ((count.max(1) - 1) << COUNT_SHIFT) | first
    }

    /// Unpacks a leaf word into `(first, count)`.
    #[inline(always)]
    pub fn unpack(word: u32) -> (u32, u32) {
        (word & SLOT_MASK, ((word >> COUNT_SHIFT) & 0xF) + 1)
    }

    /// True if `word` is a leaf word.
    #[inline(always)]
    pub fn is_leaf(word: u32) -> bool {
        word & LEAF_BIT != 0
    }
}
