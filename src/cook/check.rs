//! The checks a loaded tree's shape passes before any box is computed, and the boxes
//! themselves, recomputed from the mesh.
//!
//! Trees number their nodes so that a child comes after its parent (pair layout for the binary
//! trees, preorder for the wide ones). Given that, "every node but the root has exactly one
//! parent, with a smaller number" makes the nodes one tree reached from the root, with no
//! cycle; boxes are then computed children first by walking the nodes backwards.

use super::CookError;
use crate::bvh::build::MAX_DEPTH;
use crate::geom::{Aabb, is_degenerate};
use crate::mesh::Mesh;

/// Checks that `order` (a tree's slot order) names each triangle of `mesh` at most once, and
/// that every triangle it leaves out is degenerate. That the ones it names are not is checked
/// as their leaves' boxes are made ([`slots_box`]), which reads their corners anyway: together,
/// the slots hold exactly the triangles a build of the mesh keeps.
pub(crate) fn check_slot_order(mesh: &Mesh, order: &[u32]) -> Result<(), CookError> {
    let count = mesh.triangle_count();
    let mut slotted = vec![false; count];
    for &id in order {
        let slot = slotted
            .get_mut(id as usize)
            .ok_or(CookError::Corrupt("a leaf names a triangle past the mesh"))?;
        if std::mem::replace(slot, true) {
            return Err(CookError::Corrupt("a triangle sits in two leaf slots"));
        }
    }
    let mut left_out = (0..count).filter(|&id| !slotted[id]);
    if left_out.any(|id| !mesh.is_degenerate(id as u32)) {
        return Err(CookError::Corrupt("a triangle is in no leaf"));
    }
    Ok(())
}

/// Which slots the leaves cover: each exactly once, in the end.
#[derive(Debug)]
pub(crate) struct SlotCover {
    covered: Vec<bool>,
}

impl SlotCover {
    /// Slots `0..slots`, none covered yet.
    pub(crate) fn new(slots: usize) -> Self {
        Self {
            covered: vec![false; slots],
        }
    }

    /// Covers slots `first..first + count` (a leaf's).
    pub(crate) fn cover(&mut self, first: u32, count: u32) -> Result<(), CookError> {
        let range = first as usize..first as usize + count as usize;
        let slots = self
            .covered
            .get_mut(range)
            .ok_or(CookError::Corrupt("a leaf's slots run past the slot order"))?;
        if slots.iter().any(|&c| c) {
            return Err(CookError::Corrupt("two leaves share a slot"));
        }
        slots.fill(true);
        Ok(())
    }

    /// Fails unless every slot is covered.
    pub(crate) fn finish(self) -> Result<(), CookError> {
        if self.covered.iter().all(|&c| c) {
            Ok(())
        } else {
            Err(CookError::Corrupt("a slot is in no leaf"))
        }
    }
}

/// The parents of a tree's nodes: each node but the root (and nodes left out on purpose)
/// named once, by a node numbered before it.
#[derive(Debug)]
pub(crate) struct NodeRefs {
    named: Vec<bool>,
}

impl NodeRefs {
    /// Nodes `0..nodes`, none named yet.
    pub(crate) fn new(nodes: usize) -> Self {
        Self {
            named: vec![false; nodes],
        }
    }

    /// Node `parent` names node `child` as a child.
    pub(crate) fn name(&mut self, parent: usize, child: u32) -> Result<(), CookError> {
        let child = child as usize;
        if child <= parent {
            return Err(CookError::Corrupt("a child is numbered before its parent"));
        }
        let named = self
            .named
            .get_mut(child)
            .ok_or(CookError::Corrupt("a child is past the last node"))?;
        if std::mem::replace(named, true) {
            return Err(CookError::Corrupt("a node has two parents"));
        }
        Ok(())
    }

    /// Fails unless every node is named, but the root and `unnamed` (nodes no parent names).
    pub(crate) fn finish(self, unnamed: &[usize]) -> Result<(), CookError> {
        let orphan = self
            .named
            .iter()
            .enumerate()
            .any(|(node, &named)| !named && node != 0 && !unnamed.contains(&node));
        if orphan {
            Err(CookError::Corrupt("a node has no parent"))
        } else {
            Ok(())
        }
    }
}

/// The depth of every node, from its parent's (parents come first): no path may be deeper
/// than the walks' stacks are sized for ([`MAX_DEPTH`]).
#[derive(Debug)]
pub(crate) struct Depths {
    depth: Vec<u8>,
}

impl Depths {
    /// The root at depth 1.
    pub(crate) fn new(nodes: usize) -> Self {
        let mut depth = vec![0; nodes];
        if let Some(root) = depth.first_mut() {
            *root = 1;
        }
        Self { depth }
    }

    /// Node `child` is a child of `parent` (numbered before it, see [`NodeRefs::name`]).
    pub(crate) fn child(&mut self, parent: usize, child: u32) -> Result<(), CookError> {
        let depth = self.depth[parent] + 1;
        if usize::from(depth) > MAX_DEPTH {
            return Err(CookError::Corrupt("a path is deeper than the walks allow"));
        }
        self.depth[child as usize] = depth;
        Ok(())
    }

    /// The longest path, in nodes.
    pub(crate) fn max(&self) -> usize {
        self.depth.iter().copied().max().map_or(0, usize::from)
    }
}

/// The box of slots `first..first + count` of `order`, as the build folds a leaf's triangles;
/// `None` if one of them is degenerate (a build leaves those out of every leaf).
pub(crate) fn slots_box(mesh: &Mesh, order: &[u32], first: u32, count: u32) -> Option<Aabb> {
    let slots = &order[first as usize..(first + count) as usize];
    slots.iter().try_fold(Aabb::EMPTY, |b, &id| {
        let corners = mesh.triangle(id);
        (!is_degenerate(&corners)).then(|| b.union(Aabb::from_points(&corners)))
    })
}

/// The error of a leaf holding a degenerate triangle ([`slots_box`] said `None`).
pub(crate) const DEGENERATE_IN_LEAF: CookError =
    CookError::Corrupt("a leaf holds a degenerate triangle");
