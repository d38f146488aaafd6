//! The binary trees in cooked files ([`crate::cook`]): the build's options, each node's
//! children or triangle slots and ordering byte, and the slot order. Loading checks them and
//! recomputes the boxes, then packs the nodes as the build does.
//!
//! ```text
//! options  max_leaf_size, ordering, parallel, leaf_copy, wide_leaf_size   (u32 each)
//! nodes    count, then per node: first_child, first, count, order           (u32 each)
//! order    count, then the triangle id of each slot                         (u32 each)
//! ```
//! The padding node (node 1, see [`super::build::FIRST_PAIR`]) is written as four zeros.

use std::sync::Arc;

use super::build::{BuiltNode, BuiltTree, FIRST_PAIR, PARALLEL_THRESHOLD};
use super::nodes::NodeFormat;
use super::{AabbTree, BuildOptions, Bvh, ChildOrdering, LeafCopy, MAX_LEAF_SIZE};
use crate::catalog::AccelKind;
use crate::cook::{
    Cook, CookError, DEGENERATE_IN_LEAF, Depths, NodeRefs, Reader, SlotCover, Writer,
    check_slot_order, slots_box,
};
use crate::geom::Aabb;
use crate::mesh::Mesh;

impl<N: NodeFormat> Cook for AabbTree<N> {
    const COOKS: bool = true;

    fn own_mesh(&self) -> Option<&Mesh> {
        Some(self.mesh())
    }

    fn write_body(&self, _kind: AccelKind, out: &mut Writer) -> Result<(), CookError> {
        write_options(out, self.options());
        out.count(self.len())?;
        for index in 0..self.len() as u32 {
            let node = self.node(index);
            let words = match node.children {
                _ if index == 1 => [0; 4],
                [0, 0] => [0, node.first, node.count, 0],
                [first_child, _] => [first_child, 0, 0, u32::from(node.order)],
            };
            words.into_iter().for_each(|w| out.u32(w));
        }
        let order: Vec<u32> = self.triangles.ids().collect();
        out.u32s(&order)
    }

    fn read_body(_kind: AccelKind, mesh: Arc<Mesh>, body: &mut Reader) -> Result<Self, CookError> {
        let options = read_options(body)?;
        let mut nodes = read_nodes(body)?;
        let order = body.u32s()?;
        check_slot_order(&mesh, &order)?;
        let depth = check_shape(&nodes, order.len())?;
        fill_boxes(&mut nodes, &mesh, &order)?;
        let built = BuiltTree {
            nodes,
            triangle_order: order,
            depth,
        };
        let packed = N::pack(&built).map_err(|_| CookError::Corrupt("too many nodes"))?;
        Ok(AabbTree::from_parts(packed, mesh, built, options))
    }
}

/// Writes `options` as five words.
fn write_options(out: &mut Writer, options: &BuildOptions) {
    let ordering = ChildOrdering::ALL
        .iter()
        .position(|&o| o == options.ordering);
    let copy = LeafCopy::ALL.iter().position(|&c| c == options.leaf_copy);
    out.u32(options.max_leaf_size);
    out.u32(ordering.expect("every ordering is listed") as u32);
    out.u32(u32::from(options.parallel));
    out.u32(copy.expect("every copy is listed") as u32);
    out.u32(options.wide_leaf_size);
}

/// Reads options written by [`write_options`], checking each.
fn read_options(body: &mut Reader) -> Result<BuildOptions, CookError> {
    let max_leaf_size = body.u32()?;
    let ordering = *ChildOrdering::ALL
        .get(body.u32()? as usize)
        .ok_or(CookError::Corrupt("unknown child ordering"))?;
    let parallel = match body.u32()? {
        0 => false,
        1 => true,
        _ => return Err(CookError::Corrupt("parallel is neither 0 nor 1")),
    };
    let leaf_copy = *LeafCopy::ALL
        .get(body.u32()? as usize)
        .ok_or(CookError::Corrupt("unknown leaf copy"))?;
    let options = BuildOptions {
        max_leaf_size,
        ordering,
        parallel,
        leaf_copy,
        wide_leaf_size: body.u32()?,
    };
    options
        .validate()
        .map_err(|_| CookError::Corrupt("leaf size out of range"))?;
    Ok(options)
}

/// The nodes of a body, boxes still empty.
fn read_nodes(body: &mut Reader) -> Result<Vec<BuiltNode>, CookError> {
    let count = body.count(16)?;
    let words = body.words(4 * count)?;
    if words
        .chunks_exact(4)
        .any(|node| node[3] > u32::from(u8::MAX))
    {
        return Err(CookError::Corrupt("an order byte above 255"));
    }
    let node = |words: &[u32]| BuiltNode {
        bounds: Aabb::EMPTY,
        first_child: words[0],
        first: words[1],
        count: words[2],
        order: words[3] as u8,
    };
    Ok(words.chunks_exact(4).map(node).collect())
}

/// Checks the nodes' shape against `slots` slots (see `crate::cook::check`); returns the depth.
fn check_shape(nodes: &[BuiltNode], slots: usize) -> Result<usize, CookError> {
    if nodes.is_empty() {
        return if slots == 0 {
            Ok(0)
        } else {
            Err(CookError::Corrupt("slots but no node"))
        };
    }
    let mut refs = NodeRefs::new(nodes.len());
    let mut depths = Depths::new(nodes.len());
    let mut cover = SlotCover::new(slots);
    for (index, node) in nodes.iter().enumerate() {
        if index == 1 {
            let padding = (node.first_child, node.first, node.count, node.order) == (0, 0, 0, 0);
            if !padding {
                return Err(CookError::Corrupt("node 1 is not the padding node"));
            }
        } else if node.first_child == 0 {
            if node.count == 0 || node.count > MAX_LEAF_SIZE || node.order != 0 {
                return Err(CookError::Corrupt("a leaf's triangle count"));
            }
            cover.cover(node.first, node.count)?;
        } else {
            let c = node.first_child;
            if c < FIRST_PAIR || c % 2 != 0 || node.first != 0 || node.count != 0 {
                return Err(CookError::Corrupt("an internal node's children"));
            }
            for child in [c, c + 1] {
                refs.name(index, child)?;
                depths.child(index, child)?;
            }
        }
    }
    refs.finish(&[1])?;
    cover.finish()?;
    Ok(depths.max())
}

/// The box of every node, from the mesh: leaves' from their triangles (on rayon's pool for
/// large trees), then internal nodes' from their children's (which come after them). Fails
/// if a leaf holds a degenerate triangle.
fn fill_boxes(nodes: &mut [BuiltNode], mesh: &Mesh, order: &[u32]) -> Result<(), CookError> {
    let parallel = nodes.len() > PARALLEL_THRESHOLD;
    let leaf_boxes = crate::parallel::map(parallel, &*nodes, |node| match node.first_child {
        0 if node.count > 0 => slots_box(mesh, order, node.first, node.count),
        _ => Some(Aabb::EMPTY),
    });
    for index in (0..nodes.len()).rev() {
        nodes[index].bounds = match nodes[index].first_child {
            0 => leaf_boxes[index].ok_or(DEGENERATE_IN_LEAF)?,
            c => nodes[c as usize].bounds.union(nodes[c as usize + 1].bounds),
        };
    }
    Ok(())
}
