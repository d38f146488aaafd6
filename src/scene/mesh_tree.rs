//! What can sit under an instance: [`SceneMesh`] (a structure that knows its mesh-space box),
//! and [`MeshTree`], any tree kind of the catalog chosen per mesh, as one concrete type.
//!
//! [`crate::catalog::AnyAccel`] hides its structure behind a trait object, which cannot be
//! traced with the generic kernel and visitor a scene passes down; `MeshTree` is an enum of
//! the concrete trees instead, so a scene of mixed kinds still runs every tree's own engines
//! (one `match` per instance visit, not per node).

use std::sync::Arc;

use glam::Vec3;

use crate::accel::{Accel, Footprint, RayStream, StreamLayout};
use crate::bvh::{AabbTree, BuildOptions, Bvh, QuantizedAabbTree};
use crate::catalog::{AccelKind, too_large};
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::grid::{GridOptions, SpatialHash, UniformGrid};
use crate::hit::Visitor;
use crate::kdtree::KdTree;
use crate::mesh::Mesh;
use crate::permuted::Permuted;
use crate::scene::error::SceneError;
use crate::wide::{QuantizedWideTree, QuantizedWideTree8, WideTree, WideTree8};
use crate::zbt::{HybridOptions, HybridTree, ZbtOptions, ZeroByteTree};

/// A structure a scene can place as instances: an [`Accel`] over one mesh that knows the
/// mesh-space box of every triangle it can report (the scene turns it into world boxes).
pub trait SceneMesh: Accel + Footprint + Send {
    /// A box holding every triangle the structure may report (empty if none).
    fn mesh_bounds(&self) -> Aabb;
}

/// Any tree kind of [`AccelKind`], chosen per mesh (see the module docs).
#[derive(Debug)]
pub struct MeshTree {
    tree: Tree,
    kind: AccelKind,
    bounds: Aabb,
}

/// The concrete trees.
#[derive(Debug)]
enum Tree {
    Aabb(AabbTree),
    Quantized(QuantizedAabbTree),
    Wide(WideTree),
    Wide8(WideTree8),
    Wide4q(QuantizedWideTree),
    Wide8q(QuantizedWideTree8),
    Zbt(Permuted<ZeroByteTree>),
    Hybrid(Permuted<HybridTree>),
    Grid(UniformGrid),
    Hash(SpatialHash),
    Kd(KdTree),
}

/// Every tree kind's per-thread scratch, side by side.
#[derive(Default)]
pub struct MeshTreeScratch {
    aabb: <AabbTree as Accel>::Scratch,
    quantized: <QuantizedAabbTree as Accel>::Scratch,
    wide: <WideTree as Accel>::Scratch,
    zbt: <ZeroByteTree as Accel>::Scratch,
    hybrid: <HybridTree as Accel>::Scratch,
    grid: <UniformGrid as Accel>::Scratch,
    hash: <SpatialHash as Accel>::Scratch,
    kd: <KdTree as Accel>::Scratch,
}

impl MeshTree {
    /// Builds a tree of kind `kind` over `mesh`, answering in `mesh`'s triangle ids (the
    /// zero-byte trees are wrapped in [`Permuted`], as the catalog does). As in the catalog,
    /// the grid and the hash are built with their default cell options (`options` does not
    /// apply to them) and the kd-tree takes only the leaf size.
    pub fn build(
        kind: AccelKind,
        mesh: impl Into<Arc<Mesh>>,
        options: &BuildOptions,
    ) -> Result<Self, SceneError> {
        let mesh = mesh.into();
        // The zero-byte builds reject a bad leaf size with an error `too_large` does not map.
        options.validate()?;
        let bounds = mesh.bounds();
        let tree = match kind {
            AccelKind::Aabb => Tree::Aabb(AabbTree::build(mesh, options)?),
            AccelKind::Quantized => Tree::Quantized(QuantizedAabbTree::build(mesh, options)?),
            AccelKind::Bvh4 => Tree::Wide(WideTree::build(mesh, options)?),
            AccelKind::Bvh8 => Tree::Wide8(WideTree8::build(mesh, options)?),
            AccelKind::Bvh4q => Tree::Wide4q(QuantizedWideTree::build(mesh, options)?),
            AccelKind::Bvh8q => Tree::Wide8q(QuantizedWideTree8::build(mesh, options)?),
            AccelKind::Bvh8qb => {
                Tree::Wide8q(QuantizedWideTree8::build_with_blocks(mesh, options)?)
            }
            AccelKind::Zbt | AccelKind::ZbtNoCache => {
                let zbt = ZbtOptions {
                    box_cache: kind == AccelKind::Zbt,
                    ..ZbtOptions::from(options)
                };
                let (tree, order) =
                    ZeroByteTree::build(Arc::unwrap_or_clone(mesh), &zbt).map_err(too_large)?;
                Tree::Zbt(Permuted::new(tree, order))
            }
            AccelKind::Hybrid => {
                let hybrid = HybridOptions {
                    zbt: ZbtOptions::from(options),
                    ..HybridOptions::default()
                };
                let (tree, order) =
                    HybridTree::build(Arc::unwrap_or_clone(mesh), &hybrid).map_err(too_large)?;
                Tree::Hybrid(Permuted::new(tree, order))
            }
            AccelKind::Grid => Tree::Grid(UniformGrid::build(mesh, &GridOptions::default())?),
            AccelKind::Hash => {
                Tree::Hash(SpatialHash::build(mesh, &SpatialHash::default_options())?)
            }
            AccelKind::Kd => Tree::Kd(KdTree::build(mesh, options.max_leaf_size)?),
        };
        Ok(Self { tree, kind, bounds })
    }

    /// The tree's kind.
    pub fn kind(&self) -> AccelKind {
        self.kind
    }

    /// Moves the mesh's vertices to `vertices` (same count, same triangles) and refits the
    /// tree's boxes bottom-up, without a rebuild. Only the full-node AABB tree supports it
    /// (see [`crate::scene::refit`]); on any error the tree is left as it was.
    pub fn refit(&mut self, vertices: Vec<Vec3>) -> Result<(), SceneError> {
        match &mut self.tree {
            Tree::Aabb(tree) => {
                crate::scene::refit::refit(tree, vertices)?;
                self.bounds = tree.mesh().bounds();
                Ok(())
            }
            _ => Err(SceneError::NotRefittable {
                kind: self.kind.name(),
            }),
        }
    }
}

impl SceneMesh for MeshTree {
    fn mesh_bounds(&self) -> Aabb {
        self.bounds
    }
}

impl SceneMesh for AabbTree {
    /// The root's box: it holds every triangle the tree can report (degenerate triangles,
    /// never reported, are left out of the tree).
    fn mesh_bounds(&self) -> Aabb {
        if Bvh::is_empty(self) {
            Aabb::EMPTY
        } else {
            self.root_bounds(&mut ())
        }
    }
}

/// Runs `$body` with `$t` bound to the concrete tree and `$s` to its scratch.
macro_rules! with_tree {
    ($self:expr, $scratch:expr, |$t:ident, $s:ident| $body:expr) => {
        match &$self.tree {
            Tree::Aabb($t) => {
                let $s = &mut $scratch.aabb;
                $body
            }
            Tree::Quantized($t) => {
                let $s = &mut $scratch.quantized;
                $body
            }
            Tree::Wide($t) => {
                let $s = &mut $scratch.wide;
                $body
            }
            // The same scratch type: the wide trees share it.
            Tree::Wide8($t) => {
                let $s = &mut $scratch.wide;
                $body
            }
            Tree::Wide4q($t) => {
                let $s = &mut $scratch.wide;
                $body
            }
            Tree::Wide8q($t) => {
                let $s = &mut $scratch.wide;
                $body
            }
            Tree::Zbt($t) => {
                let $s = &mut $scratch.zbt;
                $body
            }
            Tree::Hybrid($t) => {
                let $s = &mut $scratch.hybrid;
                $body
            }
            Tree::Grid($t) => {
                let $s = &mut $scratch.grid;
                $body
            }
            Tree::Hash($t) => {
                let $s = &mut $scratch.hash;
                $body
            }
            Tree::Kd($t) => {
                let $s = &mut $scratch.kd;
                $body
            }
        }
    };
}

impl Accel for MeshTree {
    type Scratch = MeshTreeScratch;
    // Scenes hand their meshes' trees streams in lanes (they partition at the top level).
    const STREAM_LAYOUT: StreamLayout = StreamLayout::Lanes;

    #[inline]
    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut MeshTreeScratch,
        visitor: &mut V,
    ) -> f32 {
        with_tree!(self, scratch, |t, s| t.trace::<K, V>(ray, id, s, visitor))
    }

    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut MeshTreeScratch,
        visitor: &mut V,
    ) {
        with_tree!(self, scratch, |t, s| t
            .trace_stream::<K, V>(stream, s, visitor))
    }
}

impl Footprint for MeshTree {
    fn name(&self) -> &'static str {
        self.kind.name()
    }
    fn triangle_count(&self) -> usize {
        self.footprint().triangle_count()
    }
    fn node_count(&self) -> usize {
        self.footprint().node_count()
    }
    fn heap_bytes(&self) -> usize {
        self.footprint().heap_bytes()
    }
    fn id_map_bytes(&self) -> usize {
        self.footprint().id_map_bytes()
    }
}

impl MeshTree {
    /// The concrete tree as a [`Footprint`].
    fn footprint(&self) -> &dyn Footprint {
        match &self.tree {
            Tree::Aabb(t) => t,
            Tree::Quantized(t) => t,
            Tree::Wide(t) => t,
            Tree::Wide8(t) => t,
            Tree::Wide4q(t) => t,
            Tree::Wide8q(t) => t,
            Tree::Zbt(t) => t,
            Tree::Hybrid(t) => t,
            Tree::Grid(t) => t,
            Tree::Hash(t) => t,
            Tree::Kd(t) => t,
        }
    }
}
