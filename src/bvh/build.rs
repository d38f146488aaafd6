//! Binned SAH build of a binary BVH, shared by every node format.
//!
//! Each step bins the triangle centroids of a node into [`BINS`] slots along all three axes,
//! sweeps the bins to price every candidate plane with the surface area heuristic
//! (cost ~ area(left) * count(left) + area(right) * count(right)), and partitions the triangles
//! in place around the cheapest plane (Wald 2007, "On fast construction of SAH-based BVHs").
//! Binning costs O(n) per level instead of the O(n log n) of a full sweep and loses little
//! quality. Subtrees above [`PARALLEL_THRESHOLD`] triangles are built with `rayon::join`.
//!
//! Robustness: when all centroids coincide, or below depth [`SAH_DEPTH_LIMIT`], the node is
//! split at the median instead, which halves the count, so the depth of the tree stays below
//! [`MAX_DEPTH`] and traversal can use a fixed-size stack.
//!
//! The result is laid out with children in adjacent pairs (`first_child`, `first_child + 1`),
//! pairs in depth-first order so that a subtree is mostly contiguous in memory, each pair
//! aligned to an even index (see [`FIRST_PAIR`]).

use glam::Vec3A;

use crate::geom::Aabb;
use crate::mesh::Mesh;
use crate::parallel;

use super::leaves::LeafCopy;
use super::ordering::{ChildOrdering, ordering_byte};

/// Bins per axis for the SAH sweep.
pub const BINS: usize = 16;
/// Subtrees with more triangles than this are built on two rayon tasks; meshes with more
/// triangles than this gather their triangles' boxes on rayon's pool, and binary trees with
/// more nodes than this make their wide nodes there.
pub const PARALLEL_THRESHOLD: usize = 16 * 1024;
/// Below this depth the builder stops using SAH and splits at the median.
pub const SAH_DEPTH_LIMIT: usize = 64;
/// No tree is deeper than this (median splits halve the count: 64 + 32 levels at most).
pub const MAX_DEPTH: usize = SAH_DEPTH_LIMIT + 33;
/// Largest supported leaf size.
pub const MAX_LEAF_SIZE: u32 = 16;

/// How to build a tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildOptions {
    /// Leaves hold at most this many triangles (1 to [`MAX_LEAF_SIZE`]). The SAH may stop
    /// earlier. 1 gives the classic one-triangle-per-leaf tree.
    pub max_leaf_size: u32,
    /// How each internal node orders its children for traversal.
    pub ordering: ChildOrdering,
    /// Build large subtrees on rayon's thread pool.
    pub parallel: bool,
    /// What the tree copies of its leaves' triangles in leaf order beside the mesh
    /// ([`LeafCopy::Auto`] by default: the vertex indices for [`crate::WideTree`] and
    /// [`crate::WideTree8`], leaf blocks for [`crate::QuantizedWideTree8`] on large trees,
    /// nothing for the others), so that reading a leaf's triangles takes
    /// fewer dependent loads, scattered less over the mesh. The zero-byte trees and the
    /// quantized-vertex tree copy nothing whatever the choice (a copy would undo their saving),
    /// and the index copy needs meshes of at most 2^21 vertices (larger ones copy nothing).
    pub leaf_copy: LeafCopy,
    /// The wide trees (`WideTree`, `WideTree8`, `QuantizedWideTree`, `QuantizedWideTree8`) only: the most triangles a
    /// leaf may hold when their collapse turns a small binary subtree into one leaf, which it
    /// does where the surface area heuristic with a wide node's cost says the leaf is cheaper
    /// (1 to [`MAX_LEAF_SIZE`], the default; at or below `max_leaf_size` nothing is merged, so
    /// 1 gives the binary tree's leaves). See `wide::collapse`.
    pub wide_leaf_size: u32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            max_leaf_size: 4,
            ordering: ChildOrdering::Pns,
            parallel: true,
            leaf_copy: LeafCopy::Auto,
            wide_leaf_size: MAX_LEAF_SIZE,
        }
    }
}

impl BuildOptions {
    /// With [`BuildOptions::max_leaf_size`].
    pub fn with_leaf_size(mut self, max_leaf_size: u32) -> Self {
        self.max_leaf_size = max_leaf_size;
        self
    }

    /// With [`BuildOptions::ordering`].
    pub fn with_ordering(mut self, ordering: ChildOrdering) -> Self {
        self.ordering = ordering;
        self
    }

    /// With [`BuildOptions::parallel`].
    pub fn with_parallel(mut self, parallel: bool) -> Self {
        self.parallel = parallel;
        self
    }

    /// [`BuildError::BadLeafSize`] if a leaf size is out of `1..=MAX_LEAF_SIZE` (checked by every
    /// build, whether or not the structure reads that size).
    pub fn validate(&self) -> Result<(), BuildError> {
        for size in [self.max_leaf_size, self.wide_leaf_size] {
            if !(1..=MAX_LEAF_SIZE).contains(&size) {
                return Err(BuildError::BadLeafSize(size));
            }
        }
        Ok(())
    }

    /// With [`BuildOptions::wide_leaf_size`].
    pub fn with_wide_leaf_size(mut self, wide_leaf_size: u32) -> Self {
        self.wide_leaf_size = wide_leaf_size;
        self
    }

    /// With [`BuildOptions::leaf_copy`].
    pub fn with_leaf_copy(mut self, leaf_copy: LeafCopy) -> Self {
        self.leaf_copy = leaf_copy;
        self
    }
}

/// Why a tree could not be built.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BuildError {
    /// `max_leaf_size` or `wide_leaf_size` is 0 or above [`MAX_LEAF_SIZE`].
    BadLeafSize(u32),
    /// An option is out of its range (a NaN density, zero cells, ...).
    BadOption {
        /// The option's name.
        option: &'static str,
        /// The value given.
        value: String,
        /// What the option accepts.
        expected: &'static str,
    },
    /// The mesh needs more nodes or triangle slots than the node format can address.
    TooLarge {
        /// The node format.
        format: &'static str,
        /// Nodes or triangle slots the mesh needs.
        needed: usize,
        /// The most the format can address.
        max: usize,
    },
}

impl std::fmt::Display for BuildError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BuildError::BadLeafSize(n) => {
                write!(f, "leaf size {n} is not in 1..={MAX_LEAF_SIZE}")
            }
            BuildError::BadOption {
                option,
                value,
                expected,
            } => write!(f, "{option} is {value}; it must be {expected}"),
            BuildError::TooLarge {
                format,
                needed,
                max,
            } => write!(
                f,
                "mesh too large for {format}: needs {needed}, supports {max}"
            ),
        }
    }
}

impl std::error::Error for BuildError {}

/// A node of the built tree, before it is packed into a node format.
#[derive(Clone, Copy, Debug)]
pub struct BuiltNode {
    /// Box of everything below the node.
    pub bounds: Aabb,
    /// Index of the first child (the second is right after it); 0 for a leaf.
    pub first_child: u32,
    /// Leaf triangles: slots `first..first + count` of [`BuiltTree::triangle_order`].
    pub first: u32,
    /// Number of leaf triangles (0 for an internal node).
    pub count: u32,
    /// Child ordering byte (see [`super::ordering`]).
    pub order: u8,
}

/// The built tree: nodes in pair layout and the triangle ids in leaf order.
#[derive(Clone, Debug, Default)]
pub struct BuiltTree {
    /// Nodes, root first, children in adjacent pairs.
    pub nodes: Vec<BuiltNode>,
    /// Triangle ids in leaf-slot order.
    pub triangle_order: Vec<u32>,
    /// Longest root-to-leaf path, in nodes.
    pub depth: usize,
}

/// A box in SIMD-friendly form, for the hot loops of the build (binning, partition).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Box3A {
    pub(crate) min: Vec3A,
    pub(crate) max: Vec3A,
}

impl Box3A {
    pub(crate) const EMPTY: Self = Self {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline(always)]
    pub(crate) fn union(self, other: Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    #[inline(always)]
    pub(crate) fn grow(self, p: Vec3A) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub(crate) fn aabb(self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// One triangle during the build.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prim {
    pub(crate) bounds: Box3A,
    pub(crate) center: Vec3A,
    pub(crate) id: u32,
}

impl Prim {
    /// Triangle `id` of `mesh`.
    pub(crate) fn of(mesh: &Mesh, id: u32) -> Self {
        let bounds = Aabb::from_points(&mesh.triangle(id));
        Prim {
            bounds: Box3A {
                min: bounds.min.into(),
                max: bounds.max.into(),
            },
            center: bounds.center().into(),
            id,
        }
    }
}

/// Every non-degenerate triangle of `mesh`, in id order (degenerate ones are never hit, so no
/// tree holds them); on rayon's pool if `parallel` and the mesh is large.
pub(crate) fn prims_of(mesh: &Mesh, parallel: bool) -> Vec<Prim> {
    // A degenerate triangle is marked by an id past the mesh, then dropped in one pass.
    let end = mesh.triangle_count() as u32;
    let parallel = parallel && end as usize > PARALLEL_THRESHOLD;
    let mut prims = parallel::map(parallel, 0..end as usize, |id| {
        let id = id as u32;
        let prim = Prim::of(mesh, id);
        Prim {
            id: if mesh.is_degenerate(id) { end } else { id },
            ..prim
        }
    });
    prims.retain(|p| p.id != end);
    prims
}

/// A node during the build; children are indices into the same vector.
#[derive(Clone, Copy, Debug)]
struct TempNode {
    bounds: Aabb,
    children: Option<(u32, u32)>,
    split_axis: usize,
    first: u32,
    count: u32,
}

/// Builds the tree over the non-degenerate triangles of `mesh`.
pub fn build(mesh: &Mesh, options: &BuildOptions) -> Result<BuiltTree, BuildError> {
    options.validate()?;
    let mut prims = prims_of(mesh, options.parallel);
    if prims.is_empty() {
        return Ok(BuiltTree::default());
    }
    let builder = Builder {
        options: *options,
        parallel: crate::parallel::enabled(options.parallel),
    };
    let extent = Extent::of(&prims);
    let temp = builder.build_subtree(&mut prims, extent, 0, 0).flatten();
    let triangle_order: Vec<u32> = prims.iter().map(|p| p.id).collect();
    Ok(layout(&temp, &triangle_order, options.ordering))
}

struct Builder {
    options: BuildOptions,
    /// `options.parallel`, and rayon can start threads (see [`crate::parallel`]).
    parallel: bool,
}

/// Where to split a node: prims with `key(p) < threshold` go left.
#[derive(Clone, Copy, Debug)]
enum Split {
    /// SAH plane: bin index along `axis` strictly below `bin` goes left.
    Binned { axis: usize, bin: usize },
    /// Median of the centroids along `axis`.
    Median { axis: usize },
}

impl Builder {
    /// Builds the subtree over `prims` (slots `offset..` of the final order).
    fn build_subtree(&self, prims: &mut [Prim], extent: Extent, offset: u32, depth: usize) -> Part {
        if self.parallel && prims.len() > PARALLEL_THRESHOLD {
            return self.build_parallel(prims, extent, offset, depth);
        }
        let mut out = Vec::with_capacity(2 * prims.len());
        self.build_sequential(prims, extent, offset, depth, &mut out);
        // The capacity is the most a subtree can need; the rest waits for the flattening.
        out.shrink_to_fit();
        Part::Nodes(out)
    }

    fn build_parallel(
        &self,
        prims: &mut [Prim],
        extent: Extent,
        offset: u32,
        depth: usize,
    ) -> Part {
        let bounds = extent.bounds.aabb();
        let Some((split_axis, mid, le, re)) = self.choose_and_partition(prims, &extent, depth)
        else {
            return Part::Nodes(vec![leaf(bounds, offset, prims.len())]);
        };
        let (left, right) = prims.split_at_mut(mid);
        let (l, r) = parallel::join(
            true,
            || self.build_subtree(left, le, offset, depth + 1),
            || self.build_subtree(right, re, offset + mid as u32, depth + 1),
        );
        let root = TempNode {
            bounds,
            children: None,
            split_axis,
            first: 0,
            count: 0,
        };
        Part::Split(root, Box::new((l, r)))
    }

    fn build_sequential(
        &self,
        prims: &mut [Prim],
        extent: Extent,
        offset: u32,
        depth: usize,
        out: &mut Vec<TempNode>,
    ) -> u32 {
        let bounds = extent.bounds.aabb();
        let index = out.len() as u32;
        let Some((split_axis, mid, le, re)) = self.choose_and_partition(prims, &extent, depth)
        else {
            out.push(leaf(bounds, offset, prims.len()));
            return index;
        };
        out.push(TempNode {
            bounds,
            children: None,
            split_axis,
            first: 0,
            count: 0,
        });
        let (left, right) = prims.split_at_mut(mid);
        let l = self.build_sequential(left, le, offset, depth + 1, out);
        let r = self.build_sequential(right, re, offset + mid as u32, depth + 1, out);
        out[index as usize].children = Some((l, r));
        index
    }

    /// Decides between a leaf (`None`) and a split; on a split, partitions `prims` and returns
    /// the split axis, the size of the left part and the extents of both parts.
    fn choose_and_partition(
        &self,
        prims: &mut [Prim],
        extent: &Extent,
        depth: usize,
    ) -> Option<Parts> {
        let (bounds, centers) = (&extent.bounds.aabb(), &extent.centers.aabb());
        let n = prims.len();
        if n <= 1 {
            return None;
        }
        let fits_leaf = n <= self.options.max_leaf_size as usize;
        let split = if depth >= SAH_DEPTH_LIMIT {
            Split::Median {
                axis: centers.extent().max_position(),
            }
        } else {
            match best_binned_split(prims, bounds, centers) {
                Some((split, cost)) => {
                    // Leaf cost n (one unit per triangle) against one traversal step plus the
                    // children's expected triangle tests.
                    if fits_leaf && n as f32 <= 1.0 + cost {
                        return None;
                    }
                    split
                }
                None if fits_leaf => return None,
                None => Split::Median {
                    axis: centers.extent().max_position(),
                },
            }
        };
        Some(partition(prims, centers, split))
    }
}

fn leaf(bounds: Aabb, offset: u32, count: usize) -> TempNode {
    TempNode {
        bounds,
        children: None,
        split_axis: 0,
        first: offset,
        count: count as u32,
    }
}

/// A subtree built on rayon tasks: its nodes in preorder (children indices relative to the
/// subtree's root), or a root over two parts built apart. The parts are flattened once, at
/// the end, so that no node is copied at every parallel level.
enum Part {
    Nodes(Vec<TempNode>),
    Split(TempNode, Box<(Part, Part)>),
}

impl Part {
    /// The nodes in preorder, root at index 0.
    fn flatten(self) -> Vec<TempNode> {
        match self {
            Part::Nodes(nodes) => nodes,
            split => {
                let mut out = Vec::with_capacity(split.len());
                split.append_to(&mut out);
                out
            }
        }
    }

    fn len(&self) -> usize {
        match self {
            Part::Nodes(nodes) => nodes.len(),
            Part::Split(_, parts) => 1 + parts.0.len() + parts.1.len(),
        }
    }

    fn append_to(self, out: &mut Vec<TempNode>) {
        let base = out.len() as u32;
        match self {
            Part::Nodes(nodes) => out.extend(nodes.iter().map(|n| shifted(n, base))),
            Part::Split(root, parts) => {
                let (left, right) = *parts;
                let right_root = base + 1 + left.len() as u32;
                out.push(TempNode {
                    children: Some((base + 1, right_root)),
                    ..root
                });
                left.append_to(out);
                right.append_to(out);
            }
        }
    }
}

fn shifted(node: &TempNode, by: u32) -> TempNode {
    TempNode {
        children: node.children.map(|(l, r)| (l + by, r + by)),
        ..*node
    }
}

/// The box of a set of triangles and the box of their centroids.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Extent {
    pub(crate) bounds: Box3A,
    pub(crate) centers: Box3A,
}

impl Extent {
    const EMPTY: Self = Self {
        bounds: Box3A::EMPTY,
        centers: Box3A::EMPTY,
    };

    pub(crate) fn of(prims: &[Prim]) -> Self {
        prims.iter().fold(Self::EMPTY, |e, p| e.with(p))
    }

    #[inline(always)]
    fn with(self, p: &Prim) -> Self {
        Self {
            bounds: self.bounds.union(p.bounds),
            centers: self.centers.grow(p.center),
        }
    }
}

/// A split: the axis, the size of the left part and both parts' extents.
pub(crate) type Parts = (usize, usize, Extent, Extent);

/// Splits `prims` (at least 2, with extent `extent`) in two non-empty parts in place: the
/// cheapest SAH plane, or the centroid median below [`SAH_DEPTH_LIMIT`] or where the SAH
/// finds no plane. For builders that decide leaves by their own rule (the zero-byte tree).
pub(crate) fn split_in_two(prims: &mut [Prim], extent: &Extent, depth: usize) -> Parts {
    let (bounds, centers) = (&extent.bounds.aabb(), &extent.centers.aabb());
    let median = Split::Median {
        axis: centers.extent().max_position(),
    };
    let split = if depth >= SAH_DEPTH_LIMIT {
        median
    } else {
        best_binned_split(prims, bounds, centers).map_or(median, |(split, _)| split)
    };
    partition(prims, centers, split)
}

/// The bin of a centroid on one axis: the scaled offset truncated, clamped to the last bin.
/// The build bins through [`bins_of`] and partitions by a float compare; this is the reference
/// both are tested against.
#[cfg(test)]
fn bin_of(center: f32, min: f32, scale: f32) -> usize {
    (((center - min) * scale) as usize).min(BINS - 1)
}

/// [`bin_of`] on all three axes at once: the same products, truncated in one vector step.
/// The products are never negative (no centroid lies below the minimum), so clamping them to
/// the last bin before truncating gives [`bin_of`]'s bins exactly.
#[inline(always)]
fn bins_of(center: Vec3A, min: Vec3A, scale: Vec3A) -> [usize; 3] {
    let bins = ((center - min) * scale).min(Vec3A::splat((BINS - 1) as f32));
    bins.as_uvec3().to_array().map(|b| b as usize)
}

/// The cheapest SAH plane over all axes, with its cost relative to the node's area
/// (`None` if the centroids coincide on every axis).
fn best_binned_split(prims: &[Prim], bounds: &Aabb, centers: &Aabb) -> Option<(Split, f32)> {
    let extent = Vec3A::from(centers.extent());
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(BINS as f32) / extent,
        Vec3A::ZERO,
    );
    let min = Vec3A::from(centers.min);
    let mut bin_bounds = [[Box3A::EMPTY; BINS]; 3];
    let mut bin_counts = [[0u32; BINS]; 3];
    for p in prims {
        for (axis, b) in bins_of(p.center, min, scale).into_iter().enumerate() {
            bin_bounds[axis][b] = bin_bounds[axis][b].union(p.bounds);
            bin_counts[axis][b] += 1;
        }
    }
    let mut best: Option<(Split, f32)> = None;
    for axis in (0..3).filter(|&a| extent[a] > 0.0) {
        let (boxes, counts) = (&bin_bounds[axis], &bin_counts[axis]);
        // Right-to-left sweep stores the cost of each right part; left-to-right finishes. An
        // empty bin changes neither part, so the plane after it prices as the plane before it
        // (which wins the tie): both sweeps skip empty bins.
        let mut right_cost = [0.0f32; BINS];
        let (mut area_box, mut count) = (Box3A::EMPTY, 0u32);
        for b in (1..BINS).rev() {
            if counts[b] != 0 {
                area_box = area_box.union(boxes[b]);
                count += counts[b];
                right_cost[b] = area_box.aabb().half_area() * count as f32;
            } else if b + 1 < BINS {
                right_cost[b] = right_cost[b + 1];
            }
        }
        let (mut area_box, mut count) = (Box3A::EMPTY, 0u32);
        for b in 1..BINS {
            if counts[b - 1] == 0 {
                continue;
            }
            area_box = area_box.union(boxes[b - 1]);
            count += counts[b - 1];
            if count as usize == prims.len() {
                break;
            }
            let cost = area_box.aabb().half_area() * count as f32 + right_cost[b];
            if best.is_none_or(|(_, c)| cost < c) {
                best = Some((Split::Binned { axis, bin: b }, cost));
            }
        }
    }
    let area = bounds.half_area().max(f32::MIN_POSITIVE);
    best.map(|(s, c)| (s, c / area))
}

/// Partitions in place; returns the split axis, the number of prims on the left (never 0 nor
/// all: a plane that separates nothing falls back to the median) and both parts' extents.
fn partition(prims: &mut [Prim], centers: &Aabb, split: Split) -> Parts {
    match split {
        Split::Binned { axis, bin } => {
            let extent = centers.extent()[axis];
            let scale = BINS as f32 / extent;
            let min = centers.min[axis];
            // `bin_of(x) < bin` compared as floats: the bin is the product truncated (and
            // clamped to the last bin, which is at least `bin`), so for a product `q >= 0` it
            // lies below `bin` exactly when `q < bin`. No conversion per prim.
            let below = bin as f32;
            let (mid, le, re) =
                partition_in_place(prims, |p| (p.center[axis] - min) * scale < below);
            if mid == 0 || mid == prims.len() {
                return partition(prims, centers, Split::Median { axis });
            }
            (axis, mid, le, re)
        }
        Split::Median { axis } => {
            let mid = prims.len() / 2;
            prims.select_nth_unstable_by(mid, |a, b| a.center[axis].total_cmp(&b.center[axis]));
            let (left, right) = prims.split_at(mid);
            (axis, mid, Extent::of(left), Extent::of(right))
        }
    }
}

/// Moves the prims for which `goes_left` holds to the front; returns how many, and the extents
/// of both parts, gathered on the way so that the children need no pass of their own.
fn partition_in_place(
    prims: &mut [Prim],
    goes_left: impl Fn(&Prim) -> bool,
) -> (usize, Extent, Extent) {
    let (mut left, mut right) = (0, prims.len());
    let (mut le, mut re) = (Extent::EMPTY, Extent::EMPTY);
    while left < right {
        if goes_left(&prims[left]) {
            le = le.with(&prims[left]);
            left += 1;
        } else {
            right -= 1;
            prims.swap(left, right);
            re = re.with(&prims[right]);
        }
    }
    (left, le, re)
}

/// Index of the first child pair. Node 1 is padding, so that every pair starts at an even
/// index: with 32-byte nodes a pair then fills one 64-byte cache line instead of straddling
/// two (with 16-byte nodes, half a line).
pub const FIRST_PAIR: u32 = 2;

/// Packs the temporary tree into pair layout (children adjacent, pairs depth-first) and
/// computes each internal node's ordering byte.
fn layout(temp: &[TempNode], triangle_order: &[u32], ordering: ChildOrdering) -> BuiltTree {
    let padding = if temp.len() > 1 { 1 } else { 0 };
    // The padding node is an empty leaf: no parent points to it, and its empty box rejects
    // every ray anyway.
    let mut nodes = vec![
        BuiltNode {
            bounds: Aabb::EMPTY,
            first_child: 0,
            first: 0,
            count: 0,
            order: 0,
        };
        temp.len() + padding
    ];
    let mut next_free = FIRST_PAIR;
    let mut depth = 0;
    // (temp index, final index, depth)
    let mut stack = vec![(0u32, 0u32, 1usize)];
    while let Some((t, f, d)) = stack.pop() {
        depth = depth.max(d);
        let node = &temp[t as usize];
        let out = &mut nodes[f as usize];
        out.bounds = node.bounds;
        out.first = node.first;
        out.count = node.count;
        if let Some((l, r)) = node.children {
            let first_child = next_free;
            next_free += 2;
            out.first_child = first_child;
            let (lb, rb) = (&temp[l as usize].bounds, &temp[r as usize].bounds);
            out.order = ordering_byte(ordering, lb, rb, node.split_axis);
            // Push the right child first so that the left subtree is laid out first.
            stack.push((r, first_child + 1, d + 1));
            stack.push((l, first_child, d + 1));
        }
    }
    debug_assert!(temp.len() == 1 || next_free as usize == nodes.len());
    BuiltTree {
        nodes,
        triangle_order: triangle_order.to_vec(),
        depth,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;

    /// The partition's float compare sends a prim left exactly when its bin lies below the
    /// plane's, and the vector binning finds the scalar bins, on random centroids of random
    /// node extents (centroids at bin edges and at the top of the range included).
    #[test]
    fn bins_and_partition_compare_agree() {
        let mut rng = TestRng::new(31);
        for round in 0..50_000 {
            let min = rng.range(-1e3, 1e3);
            let extent = rng.range(1e-6, 1e3);
            let scale = BINS as f32 / extent;
            let center = match round % 4 {
                0 => min + extent,
                1 => min + rng.range(0.0, BINS as f32).floor() / scale,
                _ => min + rng.range(0.0, extent),
            };
            if center < min {
                continue;
            }
            let bin = bin_of(center, min, scale);
            let q = (center - min) * scale;
            for plane in 1..BINS {
                assert_eq!(
                    bin < plane,
                    q < plane as f32,
                    "{center} {min} {scale} {plane}"
                );
            }
            let lanes = bins_of(Vec3A::splat(center), Vec3A::splat(min), Vec3A::splat(scale));
            assert_eq!(lanes, [bin; 3]);
        }
    }
}
