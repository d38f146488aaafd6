//! Full-precision nodes: 32 bytes, bounds as six `f32` and one packed word.
//!
//! ```text
//! min: [f32; 3] | word: u32 | max: [f32; 3] | order: u32 (low byte used)
//! word, internal: index of the first child (the second follows it), bit 31 clear
//! word, leaf:     bit 31 set | (count - 1) in bits 27..31 | first triangle slot in bits 0..27
//! ```
//! Children sit next to each other, so with 32-byte alignment a pair shares one cache line.

use glam::Vec3;

use super::NodeView;
use super::aabb_tree::NodeFormat;
use super::build::{BuildError, BuiltTree};
use crate::geom::Aabb;

/// The format's name in error messages.
const FORMAT: &str = "full nodes (32 B)";

const LEAF_BIT: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 27;
const SLOT_MASK: u32 = (1 << COUNT_SHIFT) - 1;
/// Largest number of triangle slots a leaf word can address.
pub const MAX_SLOTS: usize = 1 << COUNT_SHIFT;

#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct FullNode {
    min: [f32; 3],
    word: u32,
    max: [f32; 3],
    order: u32,
}

/// Packs a leaf's triangle range (`count` in 1..=16, `first` < [`MAX_SLOTS`]). The padding node
/// (an empty leaf, see [`super::build::FIRST_PAIR`]) is stored as one triangle behind an
/// empty box, which no ray ever enters.
pub(crate) fn leaf_word(first: u32, count: u32) -> u32 {
    LEAF_BIT | ((count.max(1) - 1) << COUNT_SHIFT) | first
}

/// Unpacks a leaf word into `(first, count)`.
#[inline(always)]
pub(crate) fn unpack_leaf(word: u32) -> (u32, u32) {
    (word & SLOT_MASK, ((word >> COUNT_SHIFT) & 0xF) + 1)
}

#[inline(always)]
pub(crate) fn is_leaf(word: u32) -> bool {
    word & LEAF_BIT != 0
}

/// The node array of an [`super::AabbTree`] with full-precision bounds.
#[derive(Clone, Debug, Default)]
pub struct FullNodes {
    nodes: Vec<FullNode>,
}

impl NodeFormat for FullNodes {
    const NAME: &'static str = "aabb";

    fn pack(tree: &BuiltTree) -> Result<Self, BuildError> {
        let (built, slots) = (&tree.nodes, tree.triangle_order.len());
        let max = (LEAF_BIT as usize).min(MAX_SLOTS);
        if built.len() > max || slots > MAX_SLOTS {
            return Err(BuildError::TooLarge {
                format: FORMAT,
                needed: built.len().max(slots),
                max,
            });
        }
        let nodes = built
            .iter()
            .map(|n| FullNode {
                min: n.bounds.min.to_array(),
                max: n.bounds.max.to_array(),
                word: if n.first_child == 0 {
                    leaf_word(n.first, n.count)
                } else {
                    n.first_child
                },
                order: n.order as u32,
            })
            .collect();
        Ok(Self { nodes })
    }

    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    fn heap_bytes(&self) -> usize {
        self.nodes.len() * size_of::<FullNode>()
    }

    #[inline(always)]
    fn view(&self, index: u32) -> NodeView {
        let n = &self.nodes[index as usize];
        let bounds = Aabb::new(Vec3::from_array(n.min), Vec3::from_array(n.max));
        if is_leaf(n.word) {
            let (first, count) = unpack_leaf(n.word);
            NodeView::leaf(bounds, first, count)
        } else {
            NodeView::internal(bounds, n.word, n.order as u8)
        }
    }
}
