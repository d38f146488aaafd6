//! Collapsing the binary SAH tree into a wide one (4 or 8 children per node).
//!
//! The collapse is the surface area heuristic's optimum over the binary tree (Ylitie, Karras
//! and Laine 2017, "Efficient incoherent ray traversal on GPUs through compressed wide
//! BVHs"): bottom up, [`Plan`] prices every binary subtree as one leaf, as one wide node, and
//! as a forest of up to `W` wide-tree children; top down, each wide node takes the cheapest
//! forest of its binary node's subtree. A ray enters a box with odds proportional to its
//! surface area, so a leaf costs `area x triangles` and a wide node `area x NODE_COST` (a
//! dependent load of up to four cache lines, a box test of every child, a push). Nodes are
//! numbered in depth-first preorder, so a subtree is contiguous.
//!
//! Leaves: a binary leaf is always a leaf; a larger subtree of at most
//! [`BuildOptions::wide_leaf_size`] triangles may become one (the binary build prices a step
//! like one triangle test, which suits a binary walk, not a wide one). A subtree's triangles
//! are contiguous slots (the builder partitions them in place), so a merged leaf is one slot
//! range: the triangles and their order stay the binary tree's, and answers those of every
//! other structure. A wide node with free slots opens a merged leaf whenever that is cheaper,
//! which it is as soon as the halves' boxes are smaller than the whole.
//!
//! A greedy collapse (each node opening its largest child until full, Wald et al. 2008) fills
//! every node; the optimum leaves slots free where a leaf or a subtree is cheaper whole, so its
//! trees have more, smaller nodes and leaves (12-21% more memory) but fewer triangle tests:
//! about 10% fewer instructions per ray for `bvh4` in calls of 4,096 rays (docs/benchmarks.md).
//!
//! [`BuildOptions::wide_leaf_size`]: crate::BuildOptions::wide_leaf_size

use super::NodeKind;
use crate::bvh::build::BuiltTree;
use crate::bvh::nodes::leaf_word;
use crate::geom::Aabb;

/// What the plan charges for a wide node, in triangle tests: the cost of a step of the wide
/// walk against one more triangle in a leaf. 4 gains where the tree outgrows the caches (about
/// 11% on the bunny, `bvh4` batched) and costs little elsewhere; higher costs slow the smaller
/// meshes (docs/benchmarks.md).
const NODE_COST: f32 = 4.0;

/// Widest node the plan handles.
const MAX_WIDTH: usize = 8;

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
    let plan = Plan::new(built, wide_leaf_size, N::WIDTH);
    if plan.as_leaf[0] {
        let (first, count) = plan.ranges[0];
        return Some((Vec::new(), leaf_word::pack(first, count)));
    }
    let mut nodes = Vec::with_capacity(built.nodes.len() / (N::WIDTH - 1) + 1);
    let root_word = collapse_node(built, &plan, 0, &mut nodes);
    Some((nodes, root_word))
}

/// How a binary subtree is covered by at most `i` children of a wide node.
#[derive(Clone, Copy, Debug, Default)]
enum Cover {
    /// By one child: the subtree's root itself (a leaf or a wide node, see `Plan::as_leaf`).
    #[default]
    Whole,
    /// By up to `left` children from the left child's subtree and `right` from the right's.
    Split { left: u8, right: u8 },
}

/// The collapse's choices for every binary node (see the module docs).
struct Plan {
    /// The width of the wide nodes.
    width: usize,
    /// Per binary node, its slot range `(first, count)`.
    ranges: Vec<(u32, u32)>,
    /// Per binary node, true if as one child of a wide node it is a leaf (else a wide node).
    as_leaf: Vec<bool>,
    /// Per binary node, its best cover by at most `i` children (`i` in `1..=width`), at
    /// `covers[slot(node, i)]`.
    covers: Vec<Cover>,
    /// Per binary internal node, how many of its wide node's children come from its left half.
    /// (Not read from `covers`: with a zero-area box the node's own price ties its best split,
    /// and the cover at full width is then the node itself.)
    node_split: Vec<u8>,
}

impl Plan {
    /// Prices every binary subtree bottom up and keeps the cheapest choices.
    fn new(built: &BuiltTree, wide_leaf_size: u32, width: usize) -> Self {
        assert!((2..=MAX_WIDTH).contains(&width));
        let count = built.nodes.len();
        let mut plan = Plan {
            width,
            ranges: vec![(0, 0); count],
            as_leaf: vec![false; count],
            covers: vec![Cover::Whole; count * width],
            node_split: vec![0; count],
        };
        // Per binary node, the cost of its best cover by at most `i` children, at
        // `costs[slot(node, i)]` (f32, as the areas: 4 bytes a node and width).
        let mut costs = vec![0.0f32; count * width];
        let slot = |node: usize, i: usize| slot(width, node, i);
        // Children come after their parent (pairs in depth-first order), so a reverse sweep
        // sees both children of a node before the node.
        for index in (0..count).rev() {
            let node = &built.nodes[index];
            let area = node.bounds.half_area();
            if node.first_child == 0 {
                plan.ranges[index] = (node.first, node.count);
                plan.as_leaf[index] = true;
                costs[slot(index, 1)..=slot(index, width)].fill(area * node.count as f32);
                continue;
            }
            let (left, right) = (node.first_child as usize, node.first_child as usize + 1);
            debug_assert!(left > index, "children follow their parent");
            let ((first, left_count), (right_first, right_count)) =
                (plan.ranges[left], plan.ranges[right]);
            debug_assert_eq!(first + left_count, right_first, "slots are contiguous");
            plan.ranges[index] = (first, left_count + right_count);
            // Per `i` in 2..=width, the best split of `i` children between the two halves: its
            // cost and the left half's share.
            let split = |i: usize| {
                (1..i)
                    .map(|k| (costs[slot(left, k)] + costs[slot(right, i - k)], k))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .expect("i >= 2")
            };
            let splits: [(f32, usize); MAX_WIDTH] = std::array::from_fn(|i| {
                if i >= 1 && i < width {
                    split(i + 1)
                } else {
                    (0.0, 0)
                }
            });
            let (children_cost, k) = splits[width - 1];
            plan.node_split[index] = k as u8;
            let triangles = left_count + right_count;
            let as_node = area * NODE_COST + children_cost;
            let as_leaf = area * triangles as f32;
            plan.as_leaf[index] = triangles <= wide_leaf_size && as_leaf <= as_node;
            let mut best = if plan.as_leaf[index] {
                as_leaf
            } else {
                as_node
            };
            costs[slot(index, 1)] = best;
            for (i, &(cost, k)) in splits.iter().enumerate().take(width).skip(1) {
                let i = i + 1;
                if cost < best {
                    best = cost;
                    let (left, right) = (k as u8, (i - k) as u8);
                    plan.covers[slot(index, i)] = Cover::Split { left, right };
                } else {
                    plan.covers[slot(index, i)] = plan.covers[slot(index, i - 1)];
                }
                costs[slot(index, i)] = best;
            }
        }
        plan
    }

    /// The children of the wide node made of binary internal node `index`: the roots of the
    /// cheapest split of its subtree into up to `width` children.
    fn children(&self, built: &BuiltTree, index: usize) -> Vec<usize> {
        let left = built.nodes[index].first_child as usize;
        let k = usize::from(self.node_split[index]);
        let mut children = Vec::with_capacity(self.width);
        self.roots(built, left, k, &mut children);
        self.roots(built, left + 1, self.width - k, &mut children);
        children
    }

    /// Appends the roots of the best cover of binary node `index` by at most `i` children.
    fn roots(&self, built: &BuiltTree, index: usize, i: usize, out: &mut Vec<usize>) {
        match self.covers[slot(self.width, index, i)] {
            Cover::Whole => out.push(index),
            Cover::Split { left, right } => {
                let first = built.nodes[index].first_child as usize;
                self.roots(built, first, usize::from(left), out);
                self.roots(built, first + 1, usize::from(right), out);
            }
        }
    }
}

/// Where a plan of `width` keeps binary node `node`'s entry for covers by at most `i` children.
fn slot(width: usize, node: usize, i: usize) -> usize {
    node * width + i - 1
}

/// Appends the wide node for binary internal node `index` (and its subtree); returns its index.
fn collapse_node<N: NodeKind>(
    built: &BuiltTree,
    plan: &Plan,
    index: usize,
    nodes: &mut Vec<N>,
) -> u32 {
    let wide = nodes.len();
    // A placeholder, so that the node keeps its preorder place before its subtrees.
    nodes.push(N::from_children(&[]));
    let slots: Vec<(Aabb, u32)> = plan
        .children(built, index)
        .into_iter()
        .map(|child| {
            let word = if plan.as_leaf[child] {
                let (first, count) = plan.ranges[child];
                leaf_word::pack(first, count)
            } else {
                collapse_node(built, plan, child, nodes)
            };
            (built.nodes[child].bounds, word)
        })
        .collect();
    nodes[wide] = N::from_children(&slots);
    wide as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::bvh::build::build;
    use crate::mesh::Mesh;
    use crate::test_support::{TestRng, bunny};

    /// The wide children the plan gives binary node `index` (as a child: itself as a leaf, or
    /// the children of its wide node), checked, and the plan's cost of that subtree.
    fn walk(built: &BuiltTree, plan: &Plan, index: usize, covered: &mut [u32]) -> f64 {
        let node = &built.nodes[index];
        let area = f64::from(node.bounds.half_area());
        if plan.as_leaf[index] {
            let (first, count) = plan.ranges[index];
            (first..first + count).for_each(|slot| covered[slot as usize] += 1);
            return area * f64::from(count);
        }
        assert_ne!(node.first_child, 0, "a binary leaf is always a leaf");
        let children = plan.children(built, index);
        assert!((2..=plan.width).contains(&children.len()));
        let below: f64 = children
            .iter()
            .map(|&c| walk(built, plan, c, covered))
            .sum();
        area * f64::from(NODE_COST) + below
    }

    /// Every covering of binary node `index`'s subtree by at most `width` roots, as lists of
    /// roots: the node itself, or a covering of its left half joined with one of its right.
    fn coverings(built: &BuiltTree, index: usize, width: usize) -> Vec<Vec<usize>> {
        let mut all = vec![vec![index]];
        let first = built.nodes[index].first_child as usize;
        if first != 0 {
            for left in coverings(built, first, width) {
                for right in coverings(built, first + 1, width) {
                    if left.len() + right.len() <= width {
                        all.push([left.clone(), right].concat());
                    }
                }
            }
        }
        all
    }

    /// The cheapest tree over binary node `index`'s subtree as one child, by brute force: as a
    /// leaf (if it may be one) or as a wide node over the cheapest of all coverings of its
    /// halves (`known`: the costs found so far, by node).
    fn brute_force(
        built: &BuiltTree,
        index: usize,
        (width, leaf_size): (usize, u32),
        known: &mut [Option<f64>],
    ) -> f64 {
        if let Some(cost) = known[index] {
            return cost;
        }
        let node = &built.nodes[index];
        let area = f64::from(node.bounds.half_area());
        let triangles = f64::from(subtree_triangles(built, index));
        let first = node.first_child as usize;
        if first == 0 {
            return area * triangles;
        }
        let mut best = f64::INFINITY;
        for left in coverings(built, first, width - 1) {
            for right in coverings(built, first + 1, width - left.len()) {
                let cost: f64 = left
                    .iter()
                    .chain(&right)
                    .map(|&c| brute_force(built, c, (width, leaf_size), known))
                    .sum();
                best = best.min(area * f64::from(NODE_COST) + cost);
            }
        }
        if subtree_triangles(built, index) <= leaf_size {
            best = best.min(area * triangles);
        }
        known[index] = Some(best);
        best
    }

    fn subtree_triangles(built: &BuiltTree, index: usize) -> u32 {
        let node = &built.nodes[index];
        match node.first_child as usize {
            0 => node.count,
            first => subtree_triangles(built, first) + subtree_triangles(built, first + 1),
        }
    }

    /// `count` random small triangles in a unit cube.
    fn soup(count: usize, seed: u64) -> Mesh {
        let mut rng = TestRng::new(seed);
        let mut vertices = Vec::new();
        for _ in 0..count {
            let center = rng.vec3(1.0);
            vertices.extend((0..3).map(|_| center + rng.vec3(0.1)));
        }
        let triangles = (0..count as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        Mesh::new(vertices, triangles).unwrap()
    }

    /// The plan covers every slot exactly once, gives every wide node 2 to `width` children,
    /// and its cost is the minimum that brute force finds over every possible collapse of
    /// small trees (binary leaves of one triangle, and of up to four: larger than some
    /// `wide_leaf_size` below, so always leaves).
    #[test]
    fn the_plan_is_the_cheapest_collapse() {
        for seed in 0..12 {
            let mesh = soup(8 + 2 * seed as usize, seed);
            let leaf_size = if seed % 2 == 0 { 1 } else { 4 };
            let options = BuildOptions::default().with_leaf_size(leaf_size);
            let built = build(&mesh, &options).unwrap();
            for width in [2, 4, 8] {
                for leaf_size in [1, 3, 16] {
                    let plan = Plan::new(&built, leaf_size, width);
                    let mut covered = vec![0; built.triangle_order.len()];
                    let cost = walk(&built, &plan, 0, &mut covered);
                    assert!(covered.iter().all(|&c| c == 1));
                    let mut known = vec![None; built.nodes.len()];
                    let best = brute_force(&built, 0, (width, leaf_size), &mut known);
                    // The plan sums in f32, the brute force in f64.
                    assert!(
                        (cost - best).abs() <= 1e-5 * best,
                        "seed {seed} width {width} leaves {leaf_size}: {cost} vs {best}"
                    );
                }
            }
        }
    }

    /// On the bunny, 4 and 8 wide: every slot covered once, merged leaves no larger than
    /// `wide_leaf_size` (none with size 1: the leaves are then the binary ones).
    #[test]
    fn the_plan_covers_the_bunny() {
        let built = build(&bunny(), &BuildOptions::default()).unwrap();
        for (leaf_size, width) in [1, 4, 16].into_iter().flat_map(|l| [(l, 4), (l, 8)]) {
            let plan = Plan::new(&built, leaf_size, width);
            let mut covered = vec![0; built.triangle_order.len()];
            walk(&built, &plan, 0, &mut covered);
            assert!(covered.iter().all(|&c| c == 1), "size {leaf_size}");
            for (index, node) in built.nodes.iter().enumerate() {
                if plan.as_leaf[index] && node.first_child != 0 {
                    assert!(plan.ranges[index].1 <= leaf_size);
                }
            }
        }
    }
}
