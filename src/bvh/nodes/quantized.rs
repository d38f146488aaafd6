//! Quantized nodes: 16 bytes, bounds as six `u16` on a grid over the root box.
//!
//! ```text
//! qmin: [u16; 3] | qmax: [u16; 3] | word: u32
//! word, internal: bit 31 clear | order byte in bits 23..31 | child pair index p in bits 0..23
//!                 (children are nodes 2p + 2 and 2p + 3)
//! word, leaf:     bit 31 set | (count - 1) in bits 27..31 | first triangle slot in bits 0..27
//! ```
//!
//! A coordinate is `origin + q * step` per axis, with the grid spanning the root box in 65535
//! steps. Quantization rounds outward (min down, max up) and then checks the dequantized value
//! with the very expression traversal uses, stepping further out if rounding went the wrong
//! way: a dequantized box always contains the exact box, so the conservative slab test stays
//! conservative and the results are identical to the full-precision tree's. The price is that
//! boxes grow by up to one step per side, so a few more nodes are visited.
//!
//! Quantizing relative to the root rather than the parent keeps each node self-contained (no
//! parent box to carry down the stack) at the cost of coarser boxes deep in very large scenes.

use glam::Vec3;

use super::NodeFormat;
use super::leaf_word::{self, MAX_SLOTS};
use crate::bvh::Node;
use crate::bvh::build::{BuildError, BuiltTree, FIRST_PAIR};
use crate::geom::Aabb;

/// The format's name in error messages.
const FORMAT: &str = "quantized nodes (16 B)";

const PAIR_BITS: u32 = 23;
const PAIR_MASK: u32 = (1 << PAIR_BITS) - 1;
const STEPS: f32 = u16::MAX as f32;

/// One node: bounds on the grid and the packed word.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct QuantizedNode {
    qmin: [u16; 3],
    qmax: [u16; 3],
    word: u32,
}

/// The node array of a [`crate::bvh::QuantizedAabbTree`]: nodes plus the quantization grid.
#[derive(Clone, Debug, Default)]
pub struct QuantizedNodes {
    nodes: Vec<QuantizedNode>,
    origin: Vec3,
    step: Vec3,
}

/// The grid coordinate `origin + q * step`, the one expression used both to build and to read.
#[inline(always)]
fn dequantize(origin: f32, step: f32, q: u16) -> f32 {
    origin + q as f32 * step
}

impl NodeFormat for QuantizedNodes {
    const NAME: &'static str = "quantized";
    const AVX2_TRAVERSAL: bool = false;

    fn pack(tree: &BuiltTree) -> Result<Self, BuildError> {
        let (built, slots) = (&tree.nodes, tree.triangle_order.len());
        let max_nodes = 2 * (PAIR_MASK as usize + 1) + FIRST_PAIR as usize;
        if built.len() > max_nodes || slots > MAX_SLOTS {
            return Err(BuildError::TooLarge {
                format: FORMAT,
                needed: built.len().max(slots),
                max: max_nodes.min(MAX_SLOTS),
            });
        }
        let Some(root) = built.first() else {
            return Ok(Self::default());
        };
        let (origin, step) = grid_over(&root.bounds);
        let mut nodes = Vec::with_capacity(built.len());
        for n in built {
            let q = |axis: usize| {
                (
                    quantize_down(origin[axis], step[axis], n.bounds.min[axis]),
                    quantize_up(origin[axis], step[axis], n.bounds.max[axis]),
                )
            };
            let (qx, qy, qz) = (q(0), q(1), q(2));
            let word = if n.first_child == 0 {
                leaf_word::pack(n.first, n.count)
            } else {
                ((n.order as u32) << PAIR_BITS) | ((n.first_child - FIRST_PAIR) / 2)
            };
            nodes.push(QuantizedNode {
                qmin: [qx.0, qy.0, qz.0],
                qmax: [qx.1, qy.1, qz.1],
                word,
            });
        }
        Ok(Self {
            nodes,
            origin,
            step,
        })
    }

    fn node_count(&self) -> usize {
        self.nodes.len()
    }

    fn heap_bytes(&self) -> usize {
        self.nodes.len() * size_of::<QuantizedNode>()
    }

    #[inline(always)]
    fn bounds(&self, index: u32) -> Aabb {
        let n = &self.nodes[index as usize];
        let (o, s) = (self.origin, self.step);
        Aabb::new(
            Vec3::new(
                dequantize(o.x, s.x, n.qmin[0]),
                dequantize(o.y, s.y, n.qmin[1]),
                dequantize(o.z, s.z, n.qmin[2]),
            ),
            Vec3::new(
                dequantize(o.x, s.x, n.qmax[0]),
                dequantize(o.y, s.y, n.qmax[1]),
                dequantize(o.z, s.z, n.qmax[2]),
            ),
        )
    }

    #[inline(always)]
    fn node(&self, index: u32) -> Node {
        let word = self.nodes[index as usize].word;
        if leaf_word::is_leaf(word) {
            let (first, count) = leaf_word::unpack(word);
            Node::leaf(first, count)
        } else {
            Node::internal(
                2 * (word & PAIR_MASK) + FIRST_PAIR,
                (word >> PAIR_BITS) as u8,
            )
        }
    }
}

/// Origin and step of a grid whose 65535 steps cover `root` on every axis. The step is nudged up
/// until the last grid line reaches the root's max, so every coordinate is representable.
fn grid_over(root: &Aabb) -> (Vec3, Vec3) {
    let origin = root.min;
    let mut step = Vec3::ZERO;
    for axis in 0..3 {
        let extent = root.max[axis] - root.min[axis];
        let mut s = (extent / STEPS).max(f32::MIN_POSITIVE);
        while dequantize(origin[axis], s, u16::MAX) < root.max[axis] {
            s = s.next_up();
        }
        step[axis] = s;
    }
    (origin, step)
}

/// The largest grid value `q` with `dequantize(q) <= value`.
fn quantize_down(origin: f32, step: f32, value: f32) -> u16 {
    let mut q = ((value - origin) / step).floor().clamp(0.0, STEPS) as u16;
    while q > 0 && dequantize(origin, step, q) > value {
        q -= 1;
    }
    q
}

/// The smallest grid value `q` with `dequantize(q) >= value`.
fn quantize_up(origin: f32, step: f32, value: f32) -> u16 {
    let mut q = ((value - origin) / step).ceil().clamp(0.0, STEPS) as u16;
    while q < u16::MAX && dequantize(origin, step, q) < value {
        q += 1;
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;

    #[test]
    fn quantized_boxes_contain_the_exact_ones() {
        let root = Aabb::new(
            Vec3::new(1e5, -3.0, 0.1),
            Vec3::new(1e5 + 7.0, 11.0, 0.1000001),
        );
        let (o, s) = grid_over(&root);
        let mut rng = TestRng::new(0x2545_f491);
        for _ in 0..10_000 {
            for axis in 0..3 {
                let f = rng.range(0.0, 1.0);
                let v = root.min[axis] + f * (root.max[axis] - root.min[axis]);
                let v = v.clamp(root.min[axis], root.max[axis]);
                let lo = quantize_down(o[axis], s[axis], v);
                let hi = quantize_up(o[axis], s[axis], v);
                assert!(dequantize(o[axis], s[axis], lo) <= v);
                assert!(dequantize(o[axis], s[axis], hi) >= v);
            }
        }
    }
}
