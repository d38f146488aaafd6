//! A stream of rays down the 4-wide tree once (seed 001, with four children per node).
//!
//! The rays are copied once into an array of [`PreparedRay`]s (one cache line each); the walk
//! then moves only 4-byte ray indices. At a node reached by a list of rays, each ray tests the
//! four child boxes in one SIMD pass ([`WideRay::hits`], the one-ray test) and its index is
//! appended to the list of every child it enters; the node's boxes are read once for the whole
//! list. Child lists are pushed farther child first along the stream's octant diagonal (the
//! precomputed-node-sorting criterion, evaluated once per node visit), so the nearer ones are
//! walked first and closest-hit rays shrink early. A leaf's triangles are fetched once and tested
//! against every ray of its list. Lists shorter than [`BatchOptions::single_ray_below`] finish
//! their subtree with the one-ray loop.
//!
//! The index lists live in one buffer used as a stack: a node's child lists are written above
//! everything pending, and popping a list truncates the buffer back to where its siblings end,
//! so memory stays proportional to the rays times the depth of the walk.
//!
//! [`BatchOptions::single_ray_below`]: crate::batch::BatchOptions::single_ray_below

use glam::Vec3;

use super::node::{WIDTH, WideNode, WideRay};
use super::{WideScratch, WideTree};
use crate::accel::RayStream;
use crate::bvh::build::MAX_LEAF_SIZE;
use crate::bvh::nodes::leaf_word;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::traverse::single::test_triangles;

/// What a box test reads of a ray, in half a cache line: the walk reads it at every node, the
/// full [`PreparedRay`] only at leaves. `tmax` here is the ray's current range end.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct BoxRay {
    origin: Vec3,
    tmin: f32,
    inv_dir: Vec3,
    tmax: f32,
}

/// A list of rays waiting to enter a child: its word, its rays (`ids[start..end]`) and where
/// the buffer ends once it and its siblings are all that is pending above it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pending {
    word: u32,
    start: u32,
    end: u32,
    top: u32,
}

/// Runs every ray of `stream` through the tree.
pub(crate) fn trace_stream<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    stream: &mut RayStream<'_>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    if tree.is_empty() || stream.is_empty() {
        return;
    }
    for first in (0..stream.len()).step_by(BLOCK) {
        let last = (first + BLOCK).min(stream.len());
        trace_block::<K, V>(tree, stream, first..last, scratch, visitor);
    }
}

/// Rays per walk, so that their copies and index lists stay in cache (512 to 32k measured the
/// same on the bunny, by instruction and cache-miss counts).
const BLOCK: usize = 8192;

// `split` counts a node's rays per child in 16-bit fields.
const _: () = assert!(BLOCK <= u16::MAX as usize);

/// Runs rays `range` of the stream through the tree, as one walk.
fn trace_block<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    stream: &mut RayStream<'_>,
    range: std::ops::Range<usize>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    let WideScratch {
        stack,
        rays,
        boxes,
        ids,
        masks,
        pending,
    } = scratch;
    let first = range.start;
    rays.clear();
    rays.extend(range.map(|i| stream.ray(i)));
    boxes.clear();
    boxes.extend(rays.iter().map(|r| BoxRay {
        origin: r.origin,
        tmin: r.tmin,
        inv_dir: r.inv_dir,
        tmax: r.tmax,
    }));
    // The buffer only grows (never zero-filled again); `Walk::top` is its logical end.
    if ids.len() < rays.len() {
        ids.resize(rays.len(), 0);
    }
    let mut top = 0;
    for (i, ray) in rays.iter().enumerate() {
        ids[top] = i as u32;
        top += tree.root_bounds.hit_by(ray, ray.tmax) as usize;
    }
    pending.clear();
    pending.push(Pending {
        word: tree.root,
        start: 0,
        end: top as u32,
        top: top as u32,
    });
    let mut walk = Walk {
        tree,
        diagonal: octant_diagonal(stream.octant_mask()),
        single_ray_below: stream.options().single_ray_below,
        first,
        rays,
        boxes,
        ids,
        top,
        masks,
        pending,
        stack,
    };
    while let Some(list) = walk.pending.pop() {
        walk.top = list.top as usize;
        walk.visit::<K, V>(stream, list, visitor);
    }
    for (i, b) in walk.boxes.iter().enumerate() {
        stream.set_tmax(first + i, b.tmax);
    }
}

/// The state of one stream's walk.
struct Walk<'a> {
    tree: &'a WideTree,
    /// The octant's diagonal (zero when the rays' octants differ: fixed order).
    diagonal: [f32; 3],
    single_ray_below: usize,
    /// The stream position of the block's first ray.
    first: usize,
    /// The block's rays (their `tmax` is not kept up to date: see `boxes`).
    rays: &'a mut Vec<PreparedRay>,
    /// What the box tests read of each ray, with its current range end.
    boxes: &'a mut Vec<BoxRay>,
    /// The index lists.
    ids: &'a mut Vec<u32>,
    /// The end of the lists in use in `ids`.
    top: usize,
    /// Child masks of the rays of the list being split.
    masks: &'a mut Vec<u8>,
    pending: &'a mut Vec<Pending>,
    /// The one-ray loop's stack.
    stack: &'a mut Vec<(u32, f32)>,
}

impl Walk<'_> {
    /// The rays of `list` touch the box of its word: test its triangles, split them among its
    /// children, or finish its subtree one ray at a time when they are few.
    fn visit<K: TriangleTest, V: Visitor>(
        &mut self,
        stream: &RayStream<'_>,
        list: Pending,
        visitor: &mut V,
    ) {
        let (start, end) = (list.start as usize, list.end as usize);
        if leaf_word::is_leaf(list.word) {
            self.test_leaf::<K, V>(stream, list.word, start, end, visitor);
        } else if end - start < self.single_ray_below {
            for k in start..end {
                let i = self.ids[k] as usize;
                let ray = self.rays[i];
                let mut tmax = self.boxes[i].tmax;
                let id = stream.id(self.first + i);
                super::single::trace_from::<K, V>(
                    self.tree, &ray, id, list.word, &mut tmax, self.stack, visitor,
                );
                self.boxes[i].tmax = tmax;
            }
        } else {
            self.split(list.word, start, end);
        }
    }

    /// Tests every ray of the list against the node's four boxes and pushes one list per child
    /// entered, nearest child last (popped first).
    fn split(&mut self, word: u32, start: usize, end: usize) {
        let node = &self.tree.nodes[word as usize];
        // Counts of the four children in 16-bit fields: one add per ray.
        let mut packed = 0u64;
        self.masks.clear();
        for k in start..end {
            let b = &self.boxes[self.ids[k] as usize];
            let (mask, _) = WideRay::from_parts(b.origin, b.inv_dir, b.tmin).hits(node, b.tmax);
            packed += SPREAD[mask as usize & 15];
            self.masks.push(mask as u8);
        }
        let counts = [0, 1, 2, 3].map(|slot| ((packed >> (16 * slot)) & 0xFFFF) as usize);
        // Child lists at the top of the buffer, in slot order. Each ray is written to every
        // list (branch-free) and kept where its mask bit is set, so each list has one spare
        // slot after it for the writes that are not kept.
        let top = self.top;
        let mut cursor = [0usize; WIDTH];
        let mut next = top;
        for slot in 0..WIDTH {
            cursor[slot] = next;
            next += counts[slot] + 1;
        }
        if self.ids.len() < next {
            self.ids.resize(next, 0);
        }
        self.top = next;
        for (k, &mask) in (start..end).zip(self.masks.iter()) {
            let ray = self.ids[k];
            for (slot, at) in cursor.iter_mut().enumerate() {
                self.ids[*at] = ray;
                *at += ((mask >> slot) & 1) as usize;
            }
        }
        let counts = counts.map(|c| c as u32);
        for slot in farthest_first(node, self.diagonal) {
            let (list_end, count) = (cursor[slot] as u32, counts[slot]);
            if count > 0 {
                self.pending.push(Pending {
                    word: node.child[slot],
                    start: list_end - count,
                    end: list_end,
                    top: next as u32,
                });
            }
        }
    }

    /// Tests the leaf's triangles against every ray of the list, fetching each triangle once.
    fn test_leaf<K: TriangleTest, V: Visitor>(
        &mut self,
        stream: &RayStream<'_>,
        word: u32,
        start: usize,
        end: usize,
        visitor: &mut V,
    ) {
        let (first, count) = leaf_word::unpack(word);
        let mut fetched = [(0u32, [Vec3::ZERO; 3]); MAX_LEAF_SIZE as usize];
        for (k, slot) in (first..first + count).enumerate() {
            fetched[k] = self.tree.triangle(slot);
        }
        let triangles = &fetched[..count as usize];
        for k in start..end {
            let i = self.ids[k] as usize;
            let ray = &self.rays[i];
            let mut tmax = self.boxes[i].tmax;
            let id = stream.id(self.first + i);
            let prepared = PreparedRay { tmax, ..*ray };
            test_triangles::<K, V>(&prepared, id, triangles.iter().copied(), &mut tmax, visitor);
            self.boxes[i].tmax = tmax;
        }
    }
}

/// For each 4-bit child mask, a 1 in the 16-bit field of every child it enters.
const SPREAD: [u64; 16] = {
    let mut table = [0u64; 16];
    let mut mask = 0;
    while mask < 16 {
        let mut slot = 0;
        while slot < 4 {
            if mask & (1 << slot) != 0 {
                table[mask] |= 1 << (16 * slot);
            }
            slot += 1;
        }
        mask += 1;
    }
    table
};

/// The diagonal `(+-1, +-1, +-1)` of the octant in `octant_mask`, or zero for mask 0.
fn octant_diagonal(octant_mask: u8) -> [f32; 3] {
    if octant_mask == 0 {
        return [0.0; 3];
    }
    let octant = octant_mask.trailing_zeros();
    [0, 1, 2].map(|axis| if octant & (1 << axis) != 0 { -1.0 } else { 1.0 })
}

/// The node's used slots, farthest first along `diagonal` (so that the nearest is popped
/// first); by slot when the diagonal is zero.
fn farthest_first(node: &WideNode, diagonal: [f32; 3]) -> impl Iterator<Item = usize> {
    let mut order = [(0.0f32, 0usize); WIDTH];
    let mut n = 0;
    for slot in 0..WIDTH {
        let b = node.slot_bounds(slot);
        if b.is_empty() {
            continue;
        }
        let c = b.center();
        let key = -(c.x * diagonal[0] + c.y * diagonal[1] + c.z * diagonal[2]);
        order[n] = (key, slot);
        n += 1;
    }
    order[..n].sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
    order.into_iter().take(n).map(|(_, slot)| slot)
}
