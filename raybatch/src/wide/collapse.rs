//! Collapsing the binary SAH tree into a wide one (4 or 8 children per node).
//!
//! Each wide node starts from a binary node's two children and repeatedly opens the internal
//! child with the largest surface area (the one a random ray is most likely to enter), putting
//! its two children in its place, until it has its width in children or only leaves (Wald et al. 2008,
//! "Getting rid of packets"). Binary leaves stay leaves, so the triangles and their order are
//! the binary tree's. Nodes are numbered in depth-first preorder, so a subtree is contiguous.

use super::NodeKind;
use crate::bvh::build::BuiltTree;
use crate::bvh::nodes::leaf_word;
use crate::geom::Aabb;

/// The wide nodes of `built` and the root's child word: a node index, or a leaf word when the
/// whole tree is one leaf. `None` for an empty tree.
pub(crate) fn collapse<N: NodeKind>(built: &BuiltTree) -> Option<(Vec<N>, u32)> {
    let root = built.nodes.first()?;
    if root.first_child == 0 {
        return Some((Vec::new(), leaf_word::pack(root.first, root.count)));
    }
    let mut nodes = Vec::with_capacity(built.nodes.len() / (N::WIDTH - 1) + 1);
    let root_word = collapse_node(built, 0, &mut nodes);
    Some((nodes, root_word))
}

/// Appends the wide node for binary internal node `index` (and its subtree); returns its index.
fn collapse_node<N: NodeKind>(built: &BuiltTree, index: u32, nodes: &mut Vec<N>) -> u32 {
    let children = widest_children(built, index, N::WIDTH);
    let wide = nodes.len();
    // A placeholder, so that the node keeps its preorder place before its subtrees.
    nodes.push(N::from_children(&[]));
    let slots: Vec<(Aabb, u32)> = children
        .iter()
        .map(|&child| {
            let node = &built.nodes[child as usize];
            let word = if node.first_child == 0 {
                leaf_word::pack(node.first, node.count)
            } else {
                collapse_node(built, child, nodes)
            };
            (node.bounds, word)
        })
        .collect();
    nodes[wide] = N::from_children(&slots);
    wide as u32
}

/// Up to `width` binary descendants of internal node `index` that together cover it.
fn widest_children(built: &BuiltTree, index: u32, width: usize) -> Vec<u32> {
    let first = built.nodes[index as usize].first_child;
    let mut children = vec![first, first + 1];
    while children.len() < width {
        let largest = children
            .iter()
            .enumerate()
            .filter(|&(_, &c)| built.nodes[c as usize].first_child != 0)
            .max_by(|a, b| {
                let area = |c: u32| built.nodes[c as usize].bounds.half_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(k, _)| k);
        let Some(k) = largest else { break };
        let opened = built.nodes[children[k] as usize].first_child;
        children[k] = opened;
        children.insert(k + 1, opened + 1);
    }
    children
}
