//! The kd-tree's SAH build: split planes that cut space, triangles straddling a plane stored
//! on both sides.
//!
//! Each node bins its triangles' boxes along every axis ([`BINS`] bins over the node's box)
//! and prices each bin boundary with the surface area heuristic: `cost = TRAVERSAL + area(below)
//! / area(node) * count(below) + area(above) / area(node) * count(above)`, against `count` for
//! a leaf (Wald and Havran 2006, binned). Cutting off empty space
//! costs nothing in triangles, so the SAH isolates clusters and leaves empty leaves behind.
//!
//! **The side rule** (what the traversal's exactness rests on, see `super::traverse`): a
//! triangle with box `[lo, hi]` along the split axis goes below the plane `s` if `lo <= s` and
//! above if `hi >= s`; one touching or lying in the plane goes to both. So a triangle kept on
//! one side only lies strictly on that side of the plane.

use crate::geom::Aabb;

use super::node::{KdNode, MAX_INDEX};

/// Bins per axis for the SAH.
pub(crate) const BINS: usize = 32;
/// Cost of one traversal step relative to one triangle test.
const TRAVERSAL: f32 = 2.0;

/// How deep the tree may go: `8 + 1.3 log2(n)` (Havran's rule), at most 64.
pub(crate) fn max_depth(triangles: usize) -> usize {
    let log = (triangles.max(1) as f64).log2();
    (8.0 + 1.3 * log).round().min(64.0) as usize
}

/// The built tree: nodes (root first) and the leaves' triangle references.
#[derive(Debug, Default)]
pub(crate) struct Built {
    pub(crate) nodes: Vec<KdNode>,
    /// Triangle ids, leaf after leaf.
    pub(crate) refs: Vec<u32>,
    /// Deepest leaf (the root has depth 0).
    pub(crate) depth: usize,
}

/// Why the build stopped: more nodes or references than a node can address.
#[derive(Debug)]
pub(crate) struct TooManyIndices(pub(crate) usize);

/// What the recursion shares.
struct Builder<'a> {
    /// Each live triangle's id and box.
    boxes: &'a [(u32, Aabb)],
    leaf_size: usize,
    max_depth: usize,
    built: Built,
}

/// Builds the tree over `boxes` (triangle id and box) inside `bounds`, splitting nodes of more
/// than `leaf_size` triangles while the SAH says it pays.
pub(crate) fn build(
    boxes: &[(u32, Aabb)],
    bounds: Aabb,
    leaf_size: usize,
) -> Result<Built, TooManyIndices> {
    let mut builder = Builder {
        boxes,
        leaf_size: leaf_size.max(1),
        max_depth: max_depth(boxes.len()),
        built: Built::default(),
    };
    let all: Vec<u32> = (0..boxes.len() as u32).collect();
    builder.node(all, bounds, 0)?;
    Ok(builder.built)
}

impl Builder<'_> {
    /// Appends the subtree over `items` (indices into `boxes`) in `node_box`.
    fn node(
        &mut self,
        items: Vec<u32>,
        node_box: Aabb,
        depth: usize,
    ) -> Result<(), TooManyIndices> {
        let index = self.built.nodes.len();
        if index > MAX_INDEX {
            return Err(TooManyIndices(index));
        }
        self.built.depth = self.built.depth.max(depth);
        let split = if items.len() > self.leaf_size && depth < self.max_depth {
            best_split(self.boxes, &items, &node_box)
        } else {
            None
        };
        let Some((axis, position)) = split else {
            return self.leaf(&items);
        };
        let (below, above) = partition(self.boxes, &items, axis, position);
        drop(items);
        self.built.nodes.push(KdNode::split(axis, position, 0));
        let (mut below_box, mut above_box) = (node_box, node_box);
        below_box.max[axis] = position;
        above_box.min[axis] = position;
        self.node(below, below_box, depth + 1)?;
        let above_index = self.built.nodes.len();
        if above_index > MAX_INDEX {
            return Err(TooManyIndices(above_index));
        }
        self.built.nodes[index] = KdNode::split(axis, position, above_index as u32);
        self.node(above, above_box, depth + 1)
    }

    /// Appends a leaf holding `items`.
    fn leaf(&mut self, items: &[u32]) -> Result<(), TooManyIndices> {
        let first = self.built.refs.len();
        if first + items.len() > MAX_INDEX {
            return Err(TooManyIndices(first + items.len()));
        }
        self.built
            .refs
            .extend(items.iter().map(|&i| self.boxes[i as usize].0));
        self.built
            .nodes
            .push(KdNode::leaf(first as u32, items.len() as u32));
        Ok(())
    }
}

/// The triangles below and above the plane by the side rule (module docs).
fn partition(boxes: &[(u32, Aabb)], items: &[u32], axis: usize, s: f32) -> (Vec<u32>, Vec<u32>) {
    let below = items
        .iter()
        .copied()
        .filter(|&i| boxes[i as usize].1.min[axis] <= s)
        .collect();
    let above = items
        .iter()
        .copied()
        .filter(|&i| boxes[i as usize].1.max[axis] >= s)
        .collect();
    (below, above)
}

/// The cheapest split plane `(axis, position)` strictly inside `node_box`, if it beats a leaf
/// and separates something.
fn best_split(boxes: &[(u32, Aabb)], items: &[u32], node_box: &Aabb) -> Option<(usize, f32)> {
    let n = items.len();
    let area = node_box.half_area();
    let leaf_cost = n as f32;
    let mut best: Option<(f32, usize, f32)> = None;
    for axis in 0..3 {
        let (lo, hi) = (node_box.min[axis], node_box.max[axis]);
        if hi <= lo {
            continue;
        }
        let scale = BINS as f32 / (hi - lo);
        let bin = |x: f32| (((x - lo) * scale) as i64).clamp(0, BINS as i64 - 1) as usize;
        // starts[b]: boxes whose low end falls in bin b; ends[b]: whose high end does.
        let mut starts = [0u32; BINS];
        let mut ends = [0u32; BINS];
        for &i in items {
            let b = &boxes[i as usize].1;
            starts[bin(b.min[axis])] += 1;
            ends[bin(b.max[axis])] += 1;
        }
        let (mut below, mut above) = (0u32, n as u32);
        for k in 1..BINS {
            below += starts[k - 1];
            above -= ends[k - 1];
            let position = lo + (hi - lo) * (k as f32 / BINS as f32);
            if !(lo < position && position < hi) {
                continue;
            }
            let (mut b_box, mut a_box) = (*node_box, *node_box);
            b_box.max[axis] = position;
            a_box.min[axis] = position;
            let cost = TRAVERSAL
                + (b_box.half_area() * below as f32 + a_box.half_area() * above as f32) / area;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, position));
            }
        }
    }
    let (cost, axis, position) = best?;
    // NaN when the node's box has no area (a segment): a leaf.
    if cost.is_nan() || cost >= leaf_cost {
        return None;
    }
    // A plane every triangle straddles makes no progress.
    let (below, above) = partition(boxes, items, axis, position);
    (below.len() < n || above.len() < n).then_some((axis, position))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::kdtree::node::Decoded;

    fn boxed(min: [f32; 3], max: [f32; 3]) -> Aabb {
        Aabb::new(Vec3::from_array(min), Vec3::from_array(max))
    }

    #[test]
    fn triangles_in_the_split_plane_go_to_both_sides() {
        // Two clusters far apart and one flat triangle box lying in the plane between them.
        let mut boxes: Vec<(u32, Aabb)> = (0..8)
            .map(|i| {
                let x = if i < 4 { 0.0 } else { 9.0 };
                (i, boxed([x, 0.0, 0.0], [x + 1.0, 1.0, 1.0]))
            })
            .collect();
        let bounds = boxes.iter().fold(Aabb::EMPTY, |b, (_, t)| b.union(*t));
        let built = build(&boxes, bounds, 1).unwrap();
        let Decoded::Split { axis, position, .. } = built.nodes[0].decode() else {
            panic!("the clusters are split");
        };
        assert_eq!(axis, 0);
        boxes.push((8, boxed([position, 0.0, 0.0], [position, 1.0, 1.0])));
        let (below, above) = partition(&boxes, &[8], axis, position);
        assert_eq!((below, above), (vec![8], vec![8]));
    }

    #[test]
    fn identical_boxes_make_one_leaf() {
        let boxes: Vec<(u32, Aabb)> = (0..20).map(|i| (i, boxed([0.0; 3], [1.0; 3]))).collect();
        let built = build(&boxes, boxes[0].1, 1).unwrap();
        assert_eq!(built.nodes.len(), 1);
        assert_eq!(built.refs.len(), 20);
    }
}
