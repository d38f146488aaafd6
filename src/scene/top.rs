//! The top-level tree: a binary tree over the instances' world boxes, built with a binned SAH
//! over box centres and kept current when instances move by a refit (boxes recomputed
//! bottom-up, shape kept) or a rebuild. An instance added later is inserted: down the child
//! whose box grows least, then the leaf reached splits in two (as dynamic AABB trees do), so
//! a spawn costs a path, not a rebuild; many insertions leave a worse tree than a rebuild.
//!
//! Nodes are stored parents before children, the two children of a node side by side, so a
//! full refit is one pass over the nodes in reverse. Each node also keeps the union of its
//! instances' filter masks, so a query that filters instances out skips whole subtrees.

use glam::Vec3;

use crate::geom::Aabb;

/// Most instances a leaf holds: an instance visit (a ray transform and a tree walk) costs far
/// more than a box test, so leaves are kept small.
const MAX_LEAF: usize = 2;

/// SAH bins per axis.
const BINS: usize = 16;

/// A node: its box, the union of its instances' masks, and either instances or children.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TopNode {
    pub bounds: Aabb,
    pub mask: u32,
    /// Leaf: first slot in the tree's instance order; inner node: the first child (the second
    /// is the next node).
    pub first: u32,
    /// Leaf: number of instances (at least 1); inner node: 0.
    pub count: u32,
    /// Inner node: the split axis; the first child holds the lower centres on it.
    pub axis: u8,
}

impl TopNode {
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// The tree (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct TopTree {
    pub nodes: Vec<TopNode>,
    /// Instance ids in leaf-slot order.
    pub order: Vec<u32>,
    /// Each node's parent (the root's is itself).
    parent: Vec<u32>,
    /// Each instance's leaf.
    leaf_of: Vec<u32>,
}

impl TopTree {
    /// Builds the tree over `boxes` (one per instance) with their `masks`.
    pub fn build(boxes: &[Aabb], masks: &[u32]) -> Self {
        let mut tree = TopTree {
            order: (0..boxes.len() as u32).collect(),
            leaf_of: vec![0; boxes.len()],
            ..TopTree::default()
        };
        if boxes.is_empty() {
            return tree;
        }
        let centres: Vec<Vec3> = boxes.iter().map(centre).collect();
        tree.push(0);
        let mut pending = vec![(0u32, 0usize, boxes.len())];
        while let Some((index, start, end)) = pending.pop() {
            let items = &mut tree.order[start..end];
            let (bounds, mask) = cover(items, boxes, masks);
            let node = &mut tree.nodes[index as usize];
            node.bounds = bounds;
            node.mask = mask;
            if items.len() <= MAX_LEAF {
                node.first = start as u32;
                node.count = items.len() as u32;
                for &i in items.iter() {
                    tree.leaf_of[i as usize] = index;
                }
                continue;
            }
            let (axis, mid) = split(items, boxes, &centres);
            let first = tree.nodes.len() as u32;
            let node = &mut tree.nodes[index as usize];
            node.first = first;
            node.axis = axis;
            tree.push(index);
            tree.push(index);
            pending.push((first, start, start + mid));
            pending.push((first + 1, start + mid, end));
        }
        tree
    }

    fn push(&mut self, parent: u32) {
        self.nodes.push(TopNode {
            bounds: Aabb::EMPTY,
            mask: 0,
            first: 0,
            count: 0,
            axis: 0,
        });
        self.parent.push(parent);
    }

    /// Adds instance `instance` (the next one: `boxes` and `masks` already hold it) and refits
    /// its path to the root (see the module docs).
    pub fn insert(&mut self, instance: usize, boxes: &[Aabb], masks: &[u32]) {
        let slot = self.order.len() as u32;
        self.order.push(instance as u32);
        debug_assert_eq!(self.leaf_of.len(), instance, "instances are added in order");
        self.leaf_of.push(0);
        if self.nodes.is_empty() {
            self.push(0);
            self.nodes[0].first = slot;
            self.nodes[0].count = 1;
            self.refit_node(0, boxes, masks);
            return;
        }
        let added = boxes[instance];
        let growth =
            |node: &TopNode| node.bounds.union(added).half_area() - node.bounds.half_area();
        let mut index = 0;
        while !self.nodes[index].is_leaf() {
            let first = self.nodes[index].first as usize;
            let second_grows_less = growth(&self.nodes[first + 1]) < growth(&self.nodes[first]);
            index = first + usize::from(second_grows_less);
        }
        // The leaf becomes an inner node over two new leaves: its instances and the new one,
        // the lower centre first on the axis where the centres differ most.
        let old = self.nodes[index];
        let new = TopNode {
            bounds: added,
            mask: masks[instance],
            first: slot,
            count: 1,
            axis: 0,
        };
        let gap = centre(&added) - centre(&old.bounds);
        let axis = gap.abs().max_position();
        let pair = if gap[axis] < 0.0 {
            [new, old]
        } else {
            [old, new]
        };
        let first = self.nodes.len() as u32;
        for (k, leaf) in pair.into_iter().enumerate() {
            self.push(index as u32);
            self.nodes[first as usize + k] = leaf;
            for &i in &self.order[leaf.first as usize..(leaf.first + leaf.count) as usize] {
                self.leaf_of[i as usize] = first + k as u32;
            }
        }
        let node = &mut self.nodes[index];
        node.first = first;
        node.count = 0;
        node.axis = axis as u8;
        self.refit_instance(instance, boxes, masks);
    }

    /// Recomputes every box and mask bottom-up from the instances' current ones.
    pub fn refit(&mut self, boxes: &[Aabb], masks: &[u32]) {
        for index in (0..self.nodes.len()).rev() {
            self.refit_node(index, boxes, masks);
        }
    }

    /// Recomputes the boxes and masks from `instance`'s leaf up to the root.
    pub fn refit_instance(&mut self, instance: usize, boxes: &[Aabb], masks: &[u32]) {
        let Some(&leaf) = self.leaf_of.get(instance) else {
            return;
        };
        let mut index = leaf as usize;
        loop {
            self.refit_node(index, boxes, masks);
            let parent = self.parent[index] as usize;
            if parent == index {
                break;
            }
            index = parent;
        }
    }

    fn refit_node(&mut self, index: usize, boxes: &[Aabb], masks: &[u32]) {
        let node = self.nodes[index];
        let (bounds, mask) = if node.is_leaf() {
            let slots = node.first as usize..(node.first + node.count) as usize;
            cover(&self.order[slots], boxes, masks)
        } else {
            let [a, b] = [
                self.nodes[node.first as usize],
                self.nodes[node.first as usize + 1],
            ];
            (a.bounds.union(b.bounds), a.mask | b.mask)
        };
        let node = &mut self.nodes[index];
        node.bounds = bounds;
        node.mask = mask;
    }

    /// Bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.nodes.len() * size_of::<TopNode>()
            + (self.order.len() + self.parent.len() + self.leaf_of.len()) * size_of::<u32>()
    }
}

/// A box's centre, or the origin for an empty box (an instance of an empty mesh).
fn centre(b: &Aabb) -> Vec3 {
    if b.is_empty() { Vec3::ZERO } else { b.center() }
}

/// The union of the boxes and masks of `items`.
fn cover(items: &[u32], boxes: &[Aabb], masks: &[u32]) -> (Aabb, u32) {
    items.iter().fold((Aabb::EMPTY, 0), |(b, m), &i| {
        (b.union(boxes[i as usize]), m | masks[i as usize])
    })
}

/// Splits `items` in two non-empty parts by the cheapest binned-SAH plane over the three
/// axes (or in the middle of the list when every centre coincides); returns the axis and the
/// size of the first part, which holds the lower centres.
fn split(items: &mut [u32], boxes: &[Aabb], centres: &[Vec3]) -> (u8, usize) {
    let span = items
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.grow(centres[i as usize]));
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in [0usize, 1, 2] {
        let (lo, hi) = (span.min[axis], span.max[axis]);
        if hi <= lo {
            continue;
        }
        let bin_of = |i: u32| {
            let x = (centres[i as usize][axis] - lo) / (hi - lo) * BINS as f32;
            (x as usize).min(BINS - 1)
        };
        let mut bins = [(Aabb::EMPTY, 0usize); BINS];
        for &i in items.iter() {
            let bin = &mut bins[bin_of(i)];
            *bin = (bin.0.union(boxes[i as usize]), bin.1 + 1);
        }
        // Suffix sweep (right sides), then prefix sweep (left sides): O(BINS) per axis.
        let mut right = [(Aabb::EMPTY, 0usize); BINS];
        let mut acc = (Aabb::EMPTY, 0usize);
        for cut in (1..BINS).rev() {
            acc = (acc.0.union(bins[cut].0), acc.1 + bins[cut].1);
            right[cut] = acc;
        }
        let mut left = (Aabb::EMPTY, 0usize);
        for cut in 1..BINS {
            left = (left.0.union(bins[cut - 1].0), left.1 + bins[cut - 1].1);
            let ((lb, ln), (rb, rn)) = (left, right[cut]);
            if ln == 0 || rn == 0 {
                continue;
            }
            let cost = lb.half_area() * ln as f32 + rb.half_area() * rn as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, cut));
            }
        }
    }
    let Some((_, axis, cut)) = best else {
        return (0, items.len() / 2);
    };
    let (lo, hi) = (span.min[axis], span.max[axis]);
    let below = |i: &u32| {
        let x = (centres[*i as usize][axis] - lo) / (hi - lo) * BINS as f32;
        (x as usize).min(BINS - 1) < cut
    };
    let mid = partition_in_place(items, below);
    (axis as u8, mid)
}

/// Moves the items satisfying `pred` to the front; returns how many there are.
fn partition_in_place(items: &mut [u32], pred: impl Fn(&u32) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..items.len() {
        if pred(&items[i]) {
            items.swap(mid, i);
            mid += 1;
        }
    }
    mid
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_at(x: f32) -> Aabb {
        Aabb::new(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0))
    }

    #[test]
    fn every_node_holds_its_instances_and_children() {
        let boxes: Vec<Aabb> = (0..37).map(|i| unit_at((i * 7 % 37) as f32)).collect();
        let masks: Vec<u32> = (0..37).map(|i| 1 << (i % 3)).collect();
        let mut tree = TopTree::build(&boxes, &masks);
        let check = |tree: &TopTree, boxes: &[Aabb]| {
            let mut seen = vec![false; boxes.len()];
            for node in &tree.nodes {
                if node.is_leaf() {
                    for &i in &tree.order[node.first as usize..(node.first + node.count) as usize] {
                        assert!(node.bounds.contains(&boxes[i as usize]));
                        assert!(node.mask & masks[i as usize] != 0);
                        seen[i as usize] = true;
                    }
                } else {
                    for c in [node.first, node.first + 1] {
                        assert!(node.bounds.contains(&tree.nodes[c as usize].bounds));
                    }
                }
            }
            assert!(seen.iter().all(|&s| s));
        };
        check(&tree, &boxes);
        let moved: Vec<Aabb> = boxes
            .iter()
            .map(|b| unit_at(b.min.x * 3.0 - 50.0))
            .collect();
        tree.refit(&moved, &masks);
        check(&tree, &moved);
        let mut one = moved.clone();
        one[5] = unit_at(1000.0);
        tree.refit_instance(5, &one, &masks);
        check(&tree, &one);
    }

    #[test]
    fn coincident_centres_still_split() {
        let boxes = vec![unit_at(0.0); 9];
        let tree = TopTree::build(&boxes, &[1; 9]);
        assert!(
            tree.nodes
                .iter()
                .filter(|n| n.is_leaf())
                .all(|n| n.count as usize <= MAX_LEAF)
        );
    }
}
