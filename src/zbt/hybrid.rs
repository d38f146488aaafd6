//! [`HybridTree`]: an ordinary AABB tree down to chunks of a few hundred triangles, each chunk
//! a zero-byte tree.
//!
//! The top levels, which every ray walks and whose boxes a zero-byte tree would recompute most
//! often, get stored boxes (a 60-byte top node holds both children's boxes, about one top node
//! per chunk: 2.7 bytes per triangle at the default chunk size); below them nothing is stored,
//! and a chunk's root inherits every face of the box its top node stores for it. Zero-byte child
//! offsets are relative, so a chunk's tree works anywhere in the big array, and the 21-bit
//! offset limit bounds the chunk size, not the mesh: the hybrid has no triangle limit (vertex
//! indices must still fit 24 bits).
//!
//! Node numbering: top nodes are `0..top.len()`; the zero-byte node at triangle position `p`
//! is `top.len() + p`. A mesh that fits one chunk has no top node: its root is zero-byte node 0.

use glam::Vec3;

use super::build::RangeBuilder;
use super::cache::BoxCache;
use super::packed::PackedMesh;
use super::stats::ZbtStats;
use super::{MAX_TRIANGLES, Rejected, ZbtError, ZbtOptions, check_common};
use crate::accel::Footprint;
use crate::bvh::build::{Extent, Prim, prims_of, split_in_two};
use crate::bvh::ordering::ordering_byte;
use crate::bvh::{Bvh, Node};
use crate::geom::Aabb;
use crate::mesh::Mesh;
use crate::workspace::StructureId;

/// How to build a [`HybridTree`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HybridOptions {
    /// How each chunk's zero-byte tree is built (and whether boxes are cached).
    pub zbt: ZbtOptions,
    /// Most triangles per chunk (a zero-byte tree); sets above it are split by the SAH.
    pub chunk_size: u32,
}

impl HybridOptions {
    /// The default chunk size: the fastest under 4 bytes per triangle. On the bunny, chunks of
    /// 32 answer single rays at 0.76 times the AABB tree's speed for 2.7 bytes per triangle
    /// (smaller chunks cost twice the memory for little more speed, larger ones are slower;
    /// docs/benchmarks.md).
    pub const DEFAULT_CHUNK_SIZE: u32 = 32;
}

impl Default for HybridOptions {
    fn default() -> Self {
        Self {
            zbt: ZbtOptions::default(),
            chunk_size: Self::DEFAULT_CHUNK_SIZE,
        }
    }
}

/// A top node: its children (top nodes, or zero-byte roots marked by [`ZBT_ROOT`] during the
/// build), their boxes, its ordering byte. Storing the children's boxes here lets a chunk's
/// root inherit every face of its stored box, so it owns no covering triangles.
#[derive(Clone, Copy, Debug)]
struct TopNode {
    boxes: [Aabb; 2],
    children: [u32; 2],
    order: u8,
}

/// During the build, a child that is a zero-byte root at position `p` is `ZBT_ROOT | p`.
const ZBT_ROOT: u32 = 1 << 31;

/// A mesh packed as zero-byte trees, with stored top nodes above them if `TOP_LEVEL`: the one
/// implementation of both public trees. [`HybridTree`] has the top level; [`ZeroByteTree`] is
/// the same type without it (one chunk holding the whole mesh, whose root computes its own
/// box), and `TOP_LEVEL = false` removes the top-node checks from its traversal at compile
/// time.
///
/// [`ZeroByteTree`]: super::ZeroByteTree
#[derive(Debug)]
pub struct PackedTree<const TOP_LEVEL: bool> {
    top: Vec<TopNode>,
    /// The root's box when there are top nodes.
    root_box: Aabb,
    packed: PackedMesh,
    depth: usize,
    node_count: usize,
    id: StructureId,
    /// The options (a zero-byte tree reads `zbt` only).
    pub(super) options: HybridOptions,
}

/// An AABB tree over zero-byte trees (see the module docs).
pub type HybridTree = PackedTree<true>;

/// Ids are positions in the tree's triangle order.
impl<const TOP_LEVEL: bool> crate::accel::Corners for PackedTree<TOP_LEVEL> {
    fn corners(&self, id: u32) -> [Vec3; 3] {
        self.packed.corners_checked(id as usize)
    }
}

impl HybridTree {
    /// Builds the tree by reordering `mesh`'s triangles; returns it with the permutation
    /// (`permutation[new id] = original id`). On error the mesh is handed back unchanged.
    pub fn build(mesh: Mesh, options: &HybridOptions) -> Result<(Self, Vec<u32>), Rejected> {
        if let Err(error) = check(&mesh, options) {
            return Err(Rejected { error, mesh });
        }
        Ok(Self::build_checked(
            mesh,
            &options.zbt,
            options.chunk_size as usize,
        ))
    }

    /// The options the tree was built with.
    pub fn options(&self) -> &HybridOptions {
        &self.options
    }

    /// Number of top nodes (stored boxes).
    pub fn top_node_count(&self) -> usize {
        self.top.len()
    }
}

impl<const TOP_LEVEL: bool> PackedTree<TOP_LEVEL> {
    /// The build of a mesh and options that passed the checks. Without a top level the chunk
    /// size is ignored: the whole mesh is one chunk.
    pub(crate) fn build_checked(
        mesh: Mesh,
        zbt: &ZbtOptions,
        chunk_size: usize,
    ) -> (Self, Vec<u32>) {
        let mut prims = prims_of(&mesh, false);
        let mut high = vec![0u32; prims.len()];
        let mut top = Vec::new();
        let root_box = Extent::of(&prims).bounds.aabb();
        let depth = if prims.is_empty() {
            0
        } else {
            let builder = TopBuilder {
                chunk: RangeBuilder::new(zbt),
                chunk_size: if TOP_LEVEL { chunk_size } else { usize::MAX },
            };
            builder.build(&mut prims, &mut high, 0, 0, &mut top).1
        };
        let base = top.len() as u32;
        for node in &mut top {
            for child in &mut node.children {
                if *child & ZBT_ROOT != 0 {
                    *child = base + (*child & !ZBT_ROOT);
                }
            }
        }
        let (packed, permutation) = PackedMesh::pack(mesh, &prims, &high);
        let chunk_nodes = ZbtStats::of(&packed, chunk_roots(&top, base, packed.tree_len())).nodes;
        let tree = Self {
            node_count: top.len() + chunk_nodes,
            top,
            root_box,
            packed,
            depth,
            id: StructureId::new(),
            options: HybridOptions {
                zbt: *zbt,
                chunk_size: chunk_size.min(u32::MAX as usize) as u32,
            },
        };
        (tree, permutation)
    }

    /// The vertex array (unchanged by the build).
    pub fn vertices(&self) -> &[Vec3] {
        self.packed.vertices()
    }

    /// The plain index array in the tree's triangle order (a copy, node data removed).
    pub fn plain_triangles(&self) -> Vec<[u32; 3]> {
        self.packed.plain_triangles()
    }

    /// A copy of the mesh in the tree's triangle order; triangle ids of hits refer to it.
    pub fn to_mesh(&self) -> Mesh {
        self.packed.to_mesh()
    }

    /// The mesh in the tree's triangle order, its arrays reused (the tree is gone).
    pub fn into_mesh(self) -> Mesh {
        self.packed.into_mesh()
    }

    /// The shape of the zero-byte chunks (all of them together).
    pub fn stats(&self) -> ZbtStats {
        let base = self.top.len() as u32;
        ZbtStats::of(
            &self.packed,
            chunk_roots(&self.top, base, self.packed.tree_len()),
        )
    }
}

impl<const TOP_LEVEL: bool> PackedTree<TOP_LEVEL> {
    /// The box of child `k` of `node`, whose box is `node_box`: stored in a top node (which
    /// owns no triangles and names itself in `first`), recomputed below.
    #[inline(always)]
    fn child_box(&self, node: &Node, k: usize, node_box: &Aabb, cache: &mut BoxCache) -> Aabb {
        if TOP_LEVEL && node.count == 0 {
            return self.top[node.first as usize].boxes[k];
        }
        self.zbt_bounds(node.children[k], node_box, node.inherited[k], cache)
    }

    /// The box of zero-byte node `index` (a number past the top nodes), whose parent's box
    /// is `parent`, through the thread's box cache if the options say so.
    #[inline(always)]
    fn zbt_bounds(&self, index: u32, parent: &Aabb, inherited: u8, cache: &mut BoxCache) -> Aabb {
        let base = if TOP_LEVEL { self.top.len() as u32 } else { 0 };
        let p = index - base;
        if self.options.zbt.box_cache {
            cache.get(self.id, index, || self.packed.bounds(p, parent, inherited))
        } else {
            self.packed.bounds(p, parent, inherited)
        }
    }
}

/// The limits of a hybrid tree.
fn check(mesh: &Mesh, options: &HybridOptions) -> Result<(), ZbtError> {
    check_common(mesh, options.zbt.leaf_size)?;
    if !(1..=MAX_TRIANGLES).contains(&(options.chunk_size as usize)) {
        return Err(ZbtError::BadChunkSize(options.chunk_size));
    }
    Ok(())
}

/// Positions of the zero-byte roots the top nodes point to (or the one root of a tree with no
/// top node).
fn chunk_roots(top: &[TopNode], base: u32, tree_len: u32) -> impl Iterator<Item = u32> {
    let single = (top.is_empty() && tree_len > 0).then_some(0);
    top.iter()
        .flat_map(|n| n.children)
        .filter(move |&c| c >= base)
        .map(move |c| c - base)
        .chain(single)
}

/// Builds the top levels down to chunks.
struct TopBuilder {
    chunk: RangeBuilder,
    chunk_size: usize,
}

impl TopBuilder {
    /// Builds the subtree over `prims` (tree positions `position..`), appending top nodes to
    /// `top`; returns the subtree's root reference and its depth in nodes.
    fn build(
        &self,
        prims: &mut [Prim],
        high: &mut [u32],
        position: u32,
        depth: usize,
        top: &mut Vec<TopNode>,
    ) -> (u32, usize) {
        if prims.len() <= self.chunk_size {
            // A chunk under a top node inherits the box stored there; a mesh that is one chunk
            // has no top node and its root computes its own box.
            let chunk_depth = if depth == 0 {
                self.chunk.build(prims, high, depth)
            } else {
                self.chunk.build_inside(prims, high, depth)
            };
            return (ZBT_ROOT | position, chunk_depth);
        }
        let extent = Extent::of(prims);
        let (axis, mid, left, right) = split_in_two(prims, &extent, depth);
        let index = top.len() as u32;
        top.push(TopNode {
            boxes: [left.bounds.aabb(), right.bounds.aabb()],
            children: [0, 0],
            order: ordering_byte(
                self.chunk.ordering,
                &left.bounds.aabb(),
                &right.bounds.aabb(),
                axis,
            ),
        });
        let (lp, rp) = prims.split_at_mut(mid);
        let (lh, rh) = high.split_at_mut(mid);
        let (l, dl) = self.build(lp, lh, position, depth + 1, top);
        let (r, dr) = self.build(rp, rh, position + mid as u32, depth + 1, top);
        top[index as usize].children = [l, r];
        (index, 1 + dl.max(dr))
    }
}

impl<const TOP_LEVEL: bool> Bvh for PackedTree<TOP_LEVEL> {
    type Cache = BoxCache;
    type NodeBox = Aabb;
    const PACKET_WALK: bool = true;

    #[inline(always)]
    fn keep(bounds: &Aabb) -> Aabb {
        *bounds
    }

    fn len(&self) -> usize {
        self.top.len() + self.packed.tree_len() as usize
    }

    fn root_bounds(&self, cache: &mut BoxCache) -> Aabb {
        if !TOP_LEVEL || self.top.is_empty() {
            return self.zbt_bounds(0, &Aabb::EMPTY, 0, cache);
        }
        self.root_box
    }

    /// The same box: the stored one, or the zero-byte root's recomputed (what the cache holds).
    fn root_bounds_uncached(&self) -> Option<Aabb> {
        if !TOP_LEVEL || self.top.is_empty() {
            return Some(self.packed.bounds(0, &Aabb::EMPTY, 0));
        }
        Some(self.root_box)
    }

    /// A top node's children are top nodes (stored boxes) or zero-byte roots (which inherit
    /// nothing); a zero-byte node's children are zero-byte nodes.
    #[inline(always)]
    fn child_bounds(&self, node: &Node, node_box: &Aabb, cache: &mut BoxCache) -> [Aabb; 2] {
        // Two calls of an always-inlined method: a closure or `[0, 1].map(..)` is left out of
        // line by the compiler (measured: +16% instructions per ray).
        [
            self.child_box(node, 0, node_box, cache),
            self.child_box(node, 1, node_box, cache),
        ]
    }

    #[inline(always)]
    fn node(&self, index: u32) -> Node {
        if !TOP_LEVEL {
            return self.packed.node(index, 0);
        }
        let base = self.top.len() as u32;
        match self.top.get(index as usize) {
            Some(n) => Node {
                first: index,
                count: 0,
                children: n.children,
                order: n.order,
                inherited: [0, 0],
            },
            None => self.packed.node(index - base, base),
        }
    }

    #[inline(always)]
    fn triangle(&self, slot: u32) -> (u32, [Vec3; 3]) {
        self.packed.triangle(slot)
    }

    fn depth(&self) -> usize {
        self.depth
    }
}

// Also wrapped in `Permuted`, as the catalog holds them, to answer in the mesh's own ids.
crate::query::compiled_queries!(
    super::ZeroByteTree,
    HybridTree,
    crate::permuted::Permuted<super::ZeroByteTree>,
    crate::permuted::Permuted<HybridTree>,
);

impl<const TOP_LEVEL: bool> Footprint for PackedTree<TOP_LEVEL> {
    fn name(&self) -> &'static str {
        match (TOP_LEVEL, self.options.zbt.box_cache) {
            (true, _) => "hybrid",
            (false, true) => "zbt",
            (false, false) => "zbt-nocache",
        }
    }

    fn triangle_count(&self) -> usize {
        self.packed.triangle_count()
    }

    fn node_count(&self) -> usize {
        self.node_count
    }

    /// The top nodes (none for a zero-byte tree; the zero-byte chunks add nothing; the
    /// per-thread box cache is reported on its own: [`super::cache::BYTES`]).
    fn heap_bytes(&self) -> usize {
        self.top.len() * size_of::<TopNode>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::bunny;

    /// The [`Bvh`] contract the traversals rely on, node by node: every node's box (read as the
    /// engines read it, through the parent's box) holds its own triangles and its children's
    /// boxes.
    fn check<B: Bvh>(name: &str, tree: &B) {
        if tree.is_empty() {
            return;
        }
        let mut cache = B::Cache::default();
        let mut stack = vec![(0u32, tree.root_bounds(&mut cache))];
        let mut visited = 0;
        while let Some((index, bounds)) = stack.pop() {
            visited += 1;
            let node = tree.node(index);
            for slot in node.first..node.first + node.count {
                let (_, corners) = tree.triangle(slot);
                for c in corners {
                    assert!(
                        c.cmpge(bounds.min).all() && c.cmple(bounds.max).all(),
                        "{name}: node {index}: corner {c} outside {bounds:?}"
                    );
                }
            }
            if node.has_children() {
                let kept = B::keep(&bounds);
                let boxes = tree.child_bounds(&node, &kept, &mut cache);
                for (child, child_box) in node.children.into_iter().zip(boxes) {
                    assert!(
                        child_box.min.cmpge(bounds.min).all()
                            && child_box.max.cmple(bounds.max).all(),
                        "{name}: child {child} of {index}: {child_box:?} not in {bounds:?}"
                    );
                    stack.push((child, child_box));
                }
            }
        }
        assert!(visited > 0);
    }

    /// Part of the bunny, the same with every triangle twice, a fan with degenerate triangles,
    /// and the empty mesh.
    fn meshes() -> Vec<(&'static str, Mesh)> {
        let bunny = bunny();
        let vertices = bunny.vertices().to_vec();
        let part = bunny.triangles()[..6000].to_vec();
        let twice = part.iter().flat_map(|&t| [t, t]).collect();
        let fan = Mesh::new(
            vec![
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
                Vec3::new(2.0, 2.0, 1.0),
            ],
            vec![[0, 0, 1], [0, 1, 2], [0, 1, 1], [1, 3, 2], [0, 1, 3]],
        );
        vec![
            ("bunny part", Mesh::new(vertices.clone(), part).unwrap()),
            ("bunny part twice", Mesh::new(vertices, twice).unwrap()),
            ("fan", fan.unwrap()),
            ("empty", Mesh::new(vec![], vec![]).unwrap()),
        ]
    }

    /// Every box holds its triangles and its children's boxes, with faces inherited or not,
    /// for every slack and for the hybrid's chunks.
    #[test]
    fn every_box_holds_its_triangles_and_children() {
        for (mesh_name, mesh) in meshes() {
            for inherit_slack in [0.0, 0.1, 1.0, f32::INFINITY] {
                let options = ZbtOptions {
                    inherit_slack,
                    ..ZbtOptions::default()
                };
                let (tree, _) = super::super::ZeroByteTree::build(mesh.clone(), &options).unwrap();
                check(&format!("zbt {mesh_name} slack {inherit_slack}"), &tree);
                let hybrid = HybridOptions {
                    zbt: options,
                    chunk_size: 16,
                };
                let (tree, _) = HybridTree::build(mesh.clone(), &hybrid).unwrap();
                check(&format!("hybrid {mesh_name} slack {inherit_slack}"), &tree);
            }
        }
    }
}
