//! Full-precision nodes: 32 bytes, bounds as six `f32` and one packed word.
//!
//! ```text
//! min: [f32; 3] | word: u32 | max: [f32; 3] | order: u32 (low byte used)
//! word, internal: index of the first child (the second follows it), bit 31 clear
//! word, leaf:     bit 31 set | (count - 1) in bits 27..31 | first triangle slot in bits 0..27
//! ```
//! Children sit next to each other, so with 32-byte alignment a pair shares one cache line.

use glam::Vec3;

use super::NodeFormat;
use super::leaf_word::{self, LEAF_BIT, MAX_SLOTS};
use crate::bvh::Node;
use crate::bvh::build::{BuildError, BuiltTree};
use crate::geom::Aabb;

/// The format's name in error messages.
const FORMAT: &str = "full nodes (32 B)";

/// One node: bounds, the packed word and the ordering byte.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct FullNode {
    min: [f32; 3],
    word: u32,
    max: [f32; 3],
    order: u32,
}

/// The node array of an [`crate::bvh::AabbTree`] with full-precision bounds.
#[derive(Clone, Debug, Default)]
pub struct FullNodes {
    nodes: Vec<FullNode>,
}

impl FullNodes {
    /// Replaces node `index`'s box (a refit: the caller keeps every box around its
    /// triangles and its children's boxes).
    pub(crate) fn set_bounds(&mut self, index: u32, bounds: Aabb) {
        let n = &mut self.nodes[index as usize];
        n.min = bounds.min.to_array();
        n.max = bounds.max.to_array();
    }
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
                    leaf_word::pack(n.first, n.count)
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
    fn bounds(&self, index: u32) -> Aabb {
        let n = &self.nodes[index as usize];
        Aabb::new(Vec3::from_array(n.min), Vec3::from_array(n.max))
    }

    #[inline(always)]
    fn node(&self, index: u32) -> Node {
        let n = &self.nodes[index as usize];
        if leaf_word::is_leaf(n.word) {
            let (first, count) = leaf_word::unpack(n.word);
            Node::leaf(first, count)
        } else {
            Node::internal(n.word, n.order as u8)
        }
    }
}
