//! Collapsing the binary SAH tree into a wide one (4 or 8 children per node).
//!
//! Each wide node starts from a binary node's two children and repeatedly opens the internal
//! child with the largest surface area (the one a random ray is most likely to enter), putting
//! its two children in its place, until it has its width in children or only leaves (Wald et al. 2008,
//! "Getting rid of packets"). Nodes are numbered in depth-first preorder, so a subtree is
//! contiguous.
//!
//! Leaves: the binary build prices a traversal step like one triangle test, which suits a
//! binary walk, and stops at a few triangles per leaf. A wide walk pays several triangle tests
//! for each node visit (a dependent load of up to four cache lines, a box test of every child,
//! a push), so before collapsing, [`plan_leaves`] prices every binary subtree of at most
//! [`BuildOptions::wide_leaf_size`] triangles both ways with the surface area heuristic, bottom
//! up: as one leaf (area x triangles) or as a node over its children's best (area x
//! [`NODE_COST`] + the children's costs), and keeps the cheaper. A subtree's triangles are
//! contiguous slots (the builder partitions them in place), so a merged leaf is one slot range:
//! the triangles and their order stay the binary tree's, and binary leaves are never split.
//! A wide node with free slots still opens a planned leaf ([`widest_children`]): the slots
//! cost nothing once the node is read, and smaller leaves test fewer triangles (keeping planned
//! leaves closed made `bvh8` per ray 1.04-1.10x slower).
//!
//! [`BuildOptions::wide_leaf_size`]: crate::BuildOptions::wide_leaf_size

use super::NodeKind;
use crate::bvh::build::BuiltTree;
use crate::bvh::nodes::leaf_word;
use crate::geom::Aabb;

/// What the leaf plan charges for a binary node, in triangle tests: the cost of a step of the
/// wide walk against one more triangle in a leaf. Measured (one thread, 1M rays, every
/// variant built once and alternated in one process, best of 4, answers checked equal; time
/// against the unmerged tree, leaves of at most 16): cost 2 / 3 / 4 / 6 / 8, `bvh4` batched
/// closest hit on incoherent rays, fandisk 0.99 / 0.99 / 0.98-0.99 / 1.03 / 1.02, bunny 0.94 /
/// 0.90 / 0.89 / 0.86 / 0.85, teapot 1.00 / 1.03 / 1.02-1.03 / 1.04 / 1.05; `bvh8` per ray,
/// fandisk 0.97 / 0.96 / 0.96-0.97 / 1.01 / 1.04, bunny 1.00 / 0.95 / 0.95-0.97 / 1.00 / 1.02,
/// teapot 0.99 / 1.00 / 1.01 / 1.06 / 1.10. 4 gains where the tree outgrows the caches (the
/// bunny) and costs little elsewhere; higher costs slow the smaller meshes.
const NODE_COST: f32 = 4.0;

/// The wide nodes of `built` and the root's child word: a node index, or a leaf word when the
/// whole tree is one leaf; leaves merged up to `wide_leaf_size` triangles (see the module
/// docs). `None` for an empty tree.
pub(crate) fn collapse<N: NodeKind>(
    built: &BuiltTree,
    wide_leaf_size: u32,
) -> Option<(Vec<N>, u32)> {
    if built.nodes.is_empty() {
        return None;
    }
    let leaves = plan_leaves(built, wide_leaf_size);
    if let Some((first, count)) = leaves.leaf(0) {
        return Some((Vec::new(), leaf_word::pack(first, count)));
    }
    let mut nodes = Vec::with_capacity(built.nodes.len() / (N::WIDTH - 1) + 1);
    let root_word = collapse_node(built, &leaves, 0, &mut nodes);
    Some((nodes, root_word))
}

/// Which binary nodes the wide tree keeps as leaves (see [`plan_leaves`]).
struct LeafPlan {
    /// Per binary node, its slot range `(first, count)`.
    ranges: Vec<(u32, u32)>,
    /// Per binary node: a binary leaf, a subtree priced cheaper as one leaf, or a node inside
    /// such a subtree.
    in_leaf: Vec<bool>,
}

impl LeafPlan {
    /// The slot range of binary node `index` if the wide tree may only hold it as a leaf.
    fn leaf(&self, index: usize) -> Option<(u32, u32)> {
        self.in_leaf[index].then_some(self.ranges[index])
    }
}

/// Prices every binary subtree as one leaf and as a node over its children's best, bottom up
/// (see the module docs), and marks the subtrees of at most `wide_leaf_size` triangles whose
/// leaf is cheaper.
fn plan_leaves(built: &BuiltTree, wide_leaf_size: u32) -> LeafPlan {
    let count = built.nodes.len();
    let mut ranges = vec![(0u32, 0u32); count];
    let mut in_leaf = vec![false; count];
    // The cheaper of each node's two prices.
    let mut costs = vec![0.0f32; count];
    // Children come after their parent (pairs in depth-first order), so a reverse sweep sees
    // both children of a node before the node.
    for index in (0..count).rev() {
        let node = &built.nodes[index];
        let area = node.bounds.half_area();
        if node.first_child == 0 {
            ranges[index] = (node.first, node.count);
            costs[index] = area * node.count as f32;
            in_leaf[index] = true;
            continue;
        }
        let (left, right) = (node.first_child as usize, node.first_child as usize + 1);
        debug_assert!(left > index, "children follow their parent");
        let ((first, left_count), (right_first, right_count)) = (ranges[left], ranges[right]);
        debug_assert_eq!(
            first + left_count,
            right_first,
            "a subtree's slots are contiguous"
        );
        ranges[index] = (first, left_count + right_count);
        let as_node = area * NODE_COST + costs[left] + costs[right];
        let as_leaf = area * ranges[index].1 as f32;
        in_leaf[index] = ranges[index].1 <= wide_leaf_size && as_leaf <= as_node;
        costs[index] = if in_leaf[index] { as_leaf } else { as_node };
    }
    // Everything below a planned leaf is part of it.
    for index in 0..count {
        let node = &built.nodes[index];
        if in_leaf[index] && node.first_child != 0 {
            in_leaf[node.first_child as usize] = true;
            in_leaf[node.first_child as usize + 1] = true;
        }
    }
    LeafPlan { ranges, in_leaf }
}

/// Appends the wide node for binary internal node `index` (and its subtree); returns its index.
fn collapse_node<N: NodeKind>(
    built: &BuiltTree,
    leaves: &LeafPlan,
    index: u32,
    nodes: &mut Vec<N>,
) -> u32 {
    let children = widest_children(built, index, N::WIDTH);
    let wide = nodes.len();
    // A placeholder, so that the node keeps its preorder place before its subtrees.
    nodes.push(N::from_children(&[]));
    let slots: Vec<(Aabb, u32)> = children
        .iter()
        .map(|&child| {
            let word = match leaves.leaf(child as usize) {
                Some((first, count)) => leaf_word::pack(first, count),
                None => collapse_node(built, leaves, child, nodes),
            };
            (built.nodes[child as usize].bounds, word)
        })
        .collect();
    nodes[wide] = N::from_children(&slots);
    wide as u32
}

/// Up to `width` binary descendants of internal node `index` that together cover it. Nodes
/// planned as leaves are opened too while the wide node has free slots: a slot costs nothing
/// once the node is read, and smaller leaves test fewer triangles.
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::bvh::build::build;
    use crate::test_support::bunny;

    /// The planned leaves cover every slot exactly once, hold at most `wide_leaf_size`
    /// triangles unless they are binary leaves, and never lie inside another planned leaf;
    /// with `wide_leaf_size` 1 they are exactly the binary leaves.
    #[test]
    fn planned_leaves_partition_the_slots() {
        let built = build(&bunny(), &BuildOptions::default()).unwrap();
        for wide_leaf_size in [1, 4, 8, 16] {
            let plan = plan_leaves(&built, wide_leaf_size);
            // Walk from the root, stopping at planned leaves, as the collapse does.
            let mut covered = vec![0u32; built.triangle_order.len()];
            let mut stack = vec![0usize];
            let mut merged = 0;
            while let Some(index) = stack.pop() {
                let node = &built.nodes[index];
                match plan.leaf(index) {
                    Some((first, count)) => {
                        (first..first + count).for_each(|slot| covered[slot as usize] += 1);
                        if node.first_child != 0 {
                            merged += 1;
                            assert!(count <= wide_leaf_size);
                        }
                    }
                    None => {
                        assert_ne!(node.first_child, 0, "a binary leaf is always a leaf");
                        stack.extend([node.first_child as usize, node.first_child as usize + 1]);
                    }
                }
            }
            assert!(covered.iter().all(|&c| c == 1), "size {wide_leaf_size}");
            match wide_leaf_size {
                1 => assert_eq!(merged, 0),
                4 => {}
                _ => assert!(merged > 0, "size {wide_leaf_size}"),
            }
        }
    }
}
