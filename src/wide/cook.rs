//! The wide trees in cooked files ([`crate::cook`]): each node's child words, the root word and
//! the slot order, with the leaf copy the tree has. Loading checks them, recomputes every
//! child box from the mesh and makes each node from its children as the collapse does, then
//! lays the leaves out as the build does.
//!
//! ```text
//! copy     u32: the leaf copy (an index into LeafCopy::ALL, never Auto)
//! root     u32: the root's word
//! nodes    count, then WIDTH child words per node (0 for an unused slot)   (u32 each)
//! order    count, then the triangle id of each slot                         (u32 each)
//! ```
//! Leaf words are written as slot ranges. A tree over leaf blocks reads its blocks back in
//! slot order (blocks are laid out so), which gives the slot ranges and the slot order.

use std::sync::Arc;

use super::kind::NodeKind;
use super::leaves::WideLeaves;
use super::{WideBvh, leaves};
use crate::bvh::LeafCopy;
use crate::bvh::build::PARALLEL_THRESHOLD;
use crate::bvh::nodes::leaf_word;
use crate::catalog::AccelKind;
use crate::cook::{
    Cook, CookError, DEGENERATE_IN_LEAF, Depths, NodeRefs, Reader, SlotCover, Writer,
    check_slot_order, slots_box,
};
use crate::geom::Aabb;
use crate::mesh::Mesh;

impl<N: NodeKind> Cook for WideBvh<N> {
    const COOKS: bool = true;

    fn own_mesh(&self) -> Option<&Mesh> {
        Some(self.mesh())
    }

    fn write_body(&self, _kind: AccelKind, out: &mut Writer) -> Result<(), CookError> {
        let (order, first_slots) = match &self.triangles {
            WideLeaves::Slots(slots) => (slots.ids().collect(), None),
            WideLeaves::Blocks(blocks) => {
                let (order, first_slots) = blocks.slot_ranges(self.leaf_words());
                (order, Some(first_slots))
            }
        };
        // A block's leaf word as the slot range it was made from.
        let as_slots = |word: u32| match &first_slots {
            Some(first_slots) if leaf_word::is_leaf(word) => {
                let (block, count) = leaf_word::unpack(word);
                leaf_word::pack(first_slots[&block], count)
            }
            _ => word,
        };
        let copy = LeafCopy::ALL
            .iter()
            .position(|&c| c == leaf_copy(&self.triangles));
        out.u32(copy.expect("every copy is listed") as u32);
        out.u32(as_slots(self.root));
        out.count(self.nodes.len())?;
        for node in &self.nodes {
            (0..N::WIDTH).for_each(|slot| out.u32(as_slots(node.child(slot))));
        }
        out.u32s(&order)
    }

    fn read_body(_kind: AccelKind, mesh: Arc<Mesh>, body: &mut Reader) -> Result<Self, CookError> {
        let copy = match LeafCopy::ALL.get(body.u32()? as usize) {
            None | Some(LeafCopy::Auto) => return Err(CookError::Corrupt("unknown leaf copy")),
            Some(&copy) => copy,
        };
        let mut root = body.u32()?;
        let count = body.count(4 * N::WIDTH)?;
        let words = body.words(count * N::WIDTH)?;
        let order = body.u32s()?;
        check_slot_order(&mesh, &order)?;
        check_shape::<N>(root, &words, order.len())?;
        let (mut nodes, root_bounds) = make_nodes::<N>(root, &words, &mesh, &order)?;
        let triangles = leaves((&mut nodes, &mut root), mesh, order, (copy, true));
        // A saved tree's copy is the one it had, which the same mesh gives again.
        if leaf_copy(&triangles) != copy {
            return Err(CookError::Corrupt("a leaf copy the mesh cannot have"));
        }
        Ok(Self::from_parts(nodes, root, root_bounds, triangles))
    }
}

impl<N: NodeKind> WideBvh<N> {
    /// Every leaf word of the tree (the root's, if the tree is one leaf).
    fn leaf_words(&self) -> impl Iterator<Item = u32> + '_ {
        let lone_root = self.nodes.is_empty().then_some(self.root);
        let children = self
            .nodes
            .iter()
            .flat_map(|node| (0..N::WIDTH).map(|slot| node.child(slot)));
        lone_root
            .into_iter()
            .chain(children)
            .filter(|&word| leaf_word::is_leaf(word))
    }
}

/// The copy `leaves` hold.
fn leaf_copy(leaves: &WideLeaves) -> LeafCopy {
    match leaves {
        WideLeaves::Slots(slots) => slots.copy(),
        WideLeaves::Blocks(_) => LeafCopy::Blocks,
    }
}

/// Checks the shape of nodes `words` (`WIDTH` a node) and `root` over `slots` slots (see
/// `crate::cook::check`).
fn check_shape<N: NodeKind>(root: u32, words: &[u32], slots: usize) -> Result<(), CookError> {
    let mut cover = SlotCover::new(slots);
    if words.is_empty() {
        match (leaf_word::is_leaf(root), slots) {
            (true, _) => {
                let (first, count) = leaf_word::unpack(root);
                cover.cover(first, count)?;
            }
            (false, 0) if root == 0 => {}
            _ => return Err(CookError::Corrupt("the root of a tree without nodes")),
        }
        return cover.finish();
    }
    if root != 0 {
        return Err(CookError::Corrupt("the root is not node 0"));
    }
    let count = words.len() / N::WIDTH;
    let mut refs = NodeRefs::new(count);
    let mut depths = Depths::new(count);
    for (index, node) in words.chunks_exact(N::WIDTH).enumerate() {
        let used = node.iter().take_while(|&&w| w != 0).count();
        if used == 0 || node[used..].iter().any(|&w| w != 0) {
            return Err(CookError::Corrupt(
                "a node's slots are not filled from the first",
            ));
        }
        for &word in &node[..used] {
            if leaf_word::is_leaf(word) {
                let (first, count) = leaf_word::unpack(word);
                cover.cover(first, count)?;
            } else {
                refs.name(index, word)?;
                depths.child(index, word)?;
            }
        }
    }
    refs.finish(&[])?;
    cover.finish()
}

/// The nodes of `words` (checked) with their child boxes from the mesh, and the root's box.
/// Leaf boxes (a pass over the triangles) and nodes (their octant orders) are made on rayon's
/// pool on large trees; node boxes between the two, last node first, since children come after
/// their parents. Fails if a leaf holds a degenerate triangle.
fn make_nodes<N: NodeKind>(
    root: u32,
    words: &[u32],
    mesh: &Mesh,
    order: &[u32],
) -> Result<(Vec<N>, Aabb), CookError> {
    let leaf_box = |word: u32| {
        let (first, count) = leaf_word::unpack(word);
        slots_box(mesh, order, first, count)
    };
    if words.is_empty() {
        let bounds = match leaf_word::is_leaf(root) {
            true => leaf_box(root).ok_or(DEGENERATE_IN_LEAF)?,
            false => Aabb::EMPTY,
        };
        return Ok((Vec::new(), bounds));
    }
    let nodes: Vec<&[u32]> = words.chunks_exact(N::WIDTH).collect();
    let parallel = nodes.len() > PARALLEL_THRESHOLD / N::WIDTH;
    // Each node's used slots: leaf children with their boxes, node children's boxes to come.
    let mut children: Vec<Children> = crate::parallel::map(parallel, &nodes, |node| {
        let mut slots = Children::default();
        for &word in node.iter().take_while(|&&w| w != 0) {
            let bounds = match leaf_word::is_leaf(word) {
                true => leaf_box(word),
                false => Some(Aabb::EMPTY),
            };
            slots.degenerate |= bounds.is_none();
            slots.slots[slots.used] = (bounds.unwrap_or(Aabb::EMPTY), word);
            slots.used += 1;
        }
        slots
    });
    if children.iter().any(|node| node.degenerate) {
        return Err(DEGENERATE_IN_LEAF);
    }
    let mut boxes = vec![Aabb::EMPTY; nodes.len()];
    for index in (0..nodes.len()).rev() {
        let node = &mut children[index];
        let mut union = Aabb::EMPTY;
        for (bounds, word) in &mut node.slots[..node.used] {
            if !leaf_word::is_leaf(*word) {
                *bounds = boxes[*word as usize];
            }
            union = union.union(*bounds);
        }
        boxes[index] = union;
    }
    let made = crate::parallel::map(parallel, &children, |node| {
        N::from_children(&node.slots[..node.used])
    });
    Ok((made, boxes[0]))
}

/// A node's used slots while its boxes are computed.
#[derive(Clone, Copy)]
struct Children {
    slots: [(Aabb, u32); 8],
    used: usize,
    /// A leaf child holds a degenerate triangle.
    degenerate: bool,
}

impl Default for Children {
    fn default() -> Self {
        Self {
            slots: [(Aabb::EMPTY, 0); 8],
            used: 0,
            degenerate: false,
        }
    }
}
