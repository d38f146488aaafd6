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
//! On large trees both passes run on rayon's pool: the pricing splits by subtree (a binary
//! subtree's nodes are contiguous below its root's pair, see [`Pricing`]), and once the wide
//! nodes are numbered each is made from its children alone. The plan and the nodes are those
//! of one thread.
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
use crate::bvh::build::{BuiltTree, PARALLEL_THRESHOLD};
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
/// docs). `None` for an empty tree. The nodes are made on rayon's pool if `parallel`.
pub(crate) fn collapse<N: NodeKind>(
    built: &BuiltTree,
    wide_leaf_size: u32,
    parallel: bool,
) -> Option<(Vec<N>, u32)> {
    if built.nodes.is_empty() {
        return None;
    }
    let plan = Plan::new(built, wide_leaf_size, N::WIDTH, parallel);
    if plan.as_leaf[0] {
        let (first, count) = plan.ranges[0];
        return Some((Vec::new(), leaf_word::pack(first, count)));
    }
    // First the wide nodes' numbers (preorder, which binary node each is made of), then the
    // nodes themselves, each from its children's words, independently of the others.
    let mut binary_of = Vec::with_capacity(built.nodes.len() / (N::WIDTH - 1) + 1);
    let mut wide_of = vec![0u32; built.nodes.len()];
    number(built, &plan, 0, &mut binary_of, &mut wide_of);
    let parallel = parallel && built.nodes.len() > PARALLEL_THRESHOLD;
    let nodes = crate::parallel::map(parallel, 0..binary_of.len(), |wide| {
        let children = plan.children(built, binary_of[wide]);
        let mut slots = [(Aabb::EMPTY, 0u32); MAX_WIDTH];
        for (slot, &child) in slots.iter_mut().zip(children.as_slice()) {
            let word = if plan.as_leaf[child] {
                let (first, count) = plan.ranges[child];
                leaf_word::pack(first, count)
            } else {
                wide_of[child]
            };
            *slot = (built.nodes[child].bounds, word);
        }
        N::from_children(&slots[..children.len])
    });
    Some((nodes, 0))
}

/// How a binary subtree is covered by at most `i` children of a wide node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
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
    /// Prices every binary subtree bottom up and keeps the cheapest choices; on rayon's pool
    /// if `parallel` and the tree is large.
    fn new(built: &BuiltTree, wide_leaf_size: u32, width: usize, parallel: bool) -> Self {
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
        let mut all = Pricing {
            built,
            wide_leaf_size,
            parallel,
            base: 0,
            width,
            ranges: &mut plan.ranges,
            as_leaf: &mut plan.as_leaf,
            covers: &mut plan.covers,
            node_split: &mut plan.node_split,
            costs: &mut costs,
        };
        if count > 1 {
            // The root, the padding node, then the root's children's pair and all below it.
            all.split_at(2).1.price_pair_and_below();
            all.price(1);
        }
        all.price(0);
        plan
    }

    /// The children of the wide node made of binary internal node `index`: the roots of the
    /// cheapest split of its subtree into up to `width` children.
    fn children(&self, built: &BuiltTree, index: usize) -> Children {
        let left = built.nodes[index].first_child as usize;
        let k = usize::from(self.node_split[index]);
        let mut children = Children::default();
        self.roots(built, left, k, &mut children);
        self.roots(built, left + 1, self.width - k, &mut children);
        children
    }

    /// Appends the roots of the best cover of binary node `index` by at most `i` children.
    fn roots(&self, built: &BuiltTree, index: usize, i: usize, out: &mut Children) {
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

/// The plan's entries for binary nodes `base..base + len`, being priced.
struct Pricing<'a> {
    built: &'a BuiltTree,
    wide_leaf_size: u32,
    parallel: bool,
    base: usize,
    width: usize,
    ranges: &'a mut [(u32, u32)],
    as_leaf: &'a mut [bool],
    covers: &'a mut [Cover],
    node_split: &'a mut [u8],
    costs: &'a mut [f32],
}

impl Pricing<'_> {
    /// The entries of the first `n` nodes and those of the rest.
    fn split_at(&mut self, n: usize) -> (Pricing<'_>, Pricing<'_>) {
        let w = self.width;
        let (ranges, ranges_rest) = self.ranges.split_at_mut(n);
        let (as_leaf, as_leaf_rest) = self.as_leaf.split_at_mut(n);
        let (covers, covers_rest) = self.covers.split_at_mut(n * w);
        let (node_split, node_split_rest) = self.node_split.split_at_mut(n);
        let (costs, costs_rest) = self.costs.split_at_mut(n * w);
        let (built, wide_leaf_size, parallel) = (self.built, self.wide_leaf_size, self.parallel);
        let part = |base, ranges, as_leaf, covers, node_split, costs| Pricing {
            built,
            wide_leaf_size,
            parallel,
            base,
            width: w,
            ranges,
            as_leaf,
            covers,
            node_split,
            costs,
        };
        (
            part(self.base, ranges, as_leaf, covers, node_split, costs),
            part(
                self.base + n,
                ranges_rest,
                as_leaf_rest,
                covers_rest,
                node_split_rest,
                costs_rest,
            ),
        )
    }

    /// Prices every node here (none, or a pair of siblings and everything below them). Below a
    /// pair come the left sibling's descendants, then the right's (pairs in depth-first
    /// order), so the two halves are priced apart, in parallel when large.
    fn price_pair_and_below(mut self) {
        let (start, end) = (self.base, self.base + self.ranges.len());
        if !self.parallel || end - start <= PARALLEL_THRESHOLD {
            // Children come after their parent, so a reverse sweep sees both children of a
            // node before the node.
            (start..end).rev().for_each(|index| self.price(index));
            return;
        }
        let right_first = self.built.nodes[start + 1].first_child as usize;
        let right_below = if right_first == 0 { end } else { right_first };
        {
            let (_, mut below) = self.split_at(2);
            let (left, right) = below.split_at(right_below - start - 2);
            crate::parallel::join(
                true,
                || left.price_pair_and_below(),
                || right.price_pair_and_below(),
            );
        }
        self.price(start + 1);
        self.price(start);
    }

    /// Prices binary node `index` from its children's entries.
    fn price(&mut self, index: usize) {
        let (width, base) = (self.width, self.base);
        let slot = |node: usize, i: usize| slot(width, node - base, i);
        let node = &self.built.nodes[index];
        let area = node.bounds.half_area();
        if node.first_child == 0 {
            self.ranges[index - base] = (node.first, node.count);
            self.as_leaf[index - base] = true;
            self.costs[slot(index, 1)..=slot(index, width)].fill(area * node.count as f32);
            return;
        }
        let (left, right) = (node.first_child as usize, node.first_child as usize + 1);
        debug_assert!(left > index, "children follow their parent");
        let ((first, left_count), (right_first, right_count)) =
            (self.ranges[left - base], self.ranges[right - base]);
        debug_assert_eq!(first + left_count, right_first, "slots are contiguous");
        self.ranges[index - base] = (first, left_count + right_count);
        let costs = &mut *self.costs;
        // Per `i` in 2..=width, the best split of `i` children between the two halves: its
        // cost and the left half's share (the first of equal costs).
        let mut splits = [(0.0f32, 0usize); MAX_WIDTH];
        for (i, split) in splits.iter_mut().enumerate().take(width).skip(1) {
            let i = i + 1;
            *split = (costs[slot(left, 1)] + costs[slot(right, i - 1)], 1);
            for k in 2..i {
                let cost = costs[slot(left, k)] + costs[slot(right, i - k)];
                if cost.total_cmp(&split.0).is_lt() {
                    *split = (cost, k);
                }
            }
        }
        let (children_cost, k) = splits[width - 1];
        self.node_split[index - base] = k as u8;
        let triangles = left_count + right_count;
        let as_node = area * NODE_COST + children_cost;
        let as_leaf = area * triangles as f32;
        let leaf = triangles <= self.wide_leaf_size && as_leaf <= as_node;
        self.as_leaf[index - base] = leaf;
        let mut best = if leaf { as_leaf } else { as_node };
        costs[slot(index, 1)] = best;
        for (i, &(cost, k)) in splits.iter().enumerate().take(width).skip(1) {
            let i = i + 1;
            if cost < best {
                best = cost;
                let (left, right) = (k as u8, (i - k) as u8);
                self.covers[slot(index, i)] = Cover::Split { left, right };
            } else {
                self.covers[slot(index, i)] = self.covers[slot(index, i - 1)];
            }
            costs[slot(index, i)] = best;
        }
    }
}

/// The binary nodes that become a wide node's children (at most [`MAX_WIDTH`]).
#[derive(Default)]
struct Children {
    nodes: [usize; MAX_WIDTH],
    len: usize,
}

impl Children {
    fn push(&mut self, node: usize) {
        self.nodes[self.len] = node;
        self.len += 1;
    }

    fn as_slice(&self) -> &[usize] {
        &self.nodes[..self.len]
    }
}

/// Where a plan of `width` keeps binary node `node`'s entry for covers by at most `i` children.
fn slot(width: usize, node: usize, i: usize) -> usize {
    node * width + i - 1
}

/// Numbers the wide node made of binary internal node `index` and those below it in preorder:
/// appends each one's binary node to `binary_of` and records its number in `wide_of`.
fn number(
    built: &BuiltTree,
    plan: &Plan,
    index: usize,
    binary_of: &mut Vec<usize>,
    wide_of: &mut [u32],
) {
    wide_of[index] = binary_of.len() as u32;
    binary_of.push(index);
    for &child in plan.children(built, index).as_slice() {
        if !plan.as_leaf[child] {
            number(built, plan, child, binary_of, wide_of);
        }
    }
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
        assert!((2..=plan.width).contains(&children.len));
        let below: f64 = children
            .as_slice()
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
                    let plan = Plan::new(&built, leaf_size, width, false);
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

    /// Priced on rayon's pool (the halves below each large pair apart), the plan is the one
    /// priced in one sweep, entry for entry.
    #[test]
    fn the_parallel_plan_is_the_sequential_plan() {
        let built = build(&soup(40_000, 7), &BuildOptions::default()).unwrap();
        assert!(built.nodes.len() > 2 * PARALLEL_THRESHOLD);
        for width in [4, 8] {
            let one = Plan::new(&built, 16, width, false);
            let many = Plan::new(&built, 16, width, true);
            assert_eq!(one.ranges, many.ranges);
            assert_eq!(one.as_leaf, many.as_leaf);
            assert_eq!(one.covers, many.covers);
            assert_eq!(one.node_split, many.node_split);
        }
    }

    /// On the bunny, 4 and 8 wide: every slot covered once, merged leaves no larger than
    /// `wide_leaf_size` (none with size 1: the leaves are then the binary ones).
    #[test]
    fn the_plan_covers_the_bunny() {
        let built = build(&bunny(), &BuildOptions::default()).unwrap();
        for (leaf_size, width) in [1, 4, 16].into_iter().flat_map(|l| [(l, 4), (l, 8)]) {
            let plan = Plan::new(&built, leaf_size, width, false);
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
