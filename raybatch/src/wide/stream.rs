//! A stream of rays down the 4-wide tree once (seed 001, with four children per node).
//!
//! The rays are the batch's prepared records (one cache line each, holding the ray's current
//! range end: the tree asks for [`crate::accel::StreamLayout::Records`]), walked in place; a
//! stream in lanes (from a scene) is copied out first. The walk moves only 4-byte ray indices. At a node reached by a
//! list of rays, each ray tests the four child boxes in one SIMD pass ([`WideRay::hits`], the
//! one-ray test) and its index is appended to the list of every child it enters; the node's
//! boxes are read once for the whole list. Child lists are pushed in the node's precomputed
//! order for the stream's octant, farther child first, so the nearer ones are walked first and
//! closest-hit rays shrink early. A leaf's triangles are fetched once and tested against every
//! ray of its list. Lists shorter than [`BatchOptions::single_ray_below`] finish their subtree
//! with the one-ray loop.
//!
//! The index lists live in one buffer used as a stack: a node's child lists are written above
//! everything pending, and popping a list moves the buffer's logical end back to where its
//! siblings end, so memory stays proportional to the rays times the depth of the walk.
//!
//! [`BatchOptions::single_ray_below`]: crate::batch::BatchOptions::single_ray_below

use super::node::{WIDTH, WideNode, WideRay};
use super::single::Stack;
use super::{WideScratch, WideTree};
use crate::accel::RayStream;
use crate::bvh::nodes::leaf_word;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::traverse::stream::LeafBatch;

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
#[inline(always)]
pub(crate) fn trace_stream<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    stream: &mut RayStream<'_>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    if tree.is_empty() || stream.is_empty() {
        return;
    }
    let setup = Setup {
        octant_mask: stream.octant_mask(),
        single_ray_below: stream.options().single_ray_below,
    };
    let WideScratch {
        lists,
        copies,
        batch_ids,
        ..
    } = scratch;
    if let Some((rays, ids)) = stream.records() {
        // The tree's own layout (`StreamLayout::Records`): walk the records in place.
        return trace_blocks::<K, V>(tree, setup, rays, ids, lists, visitor);
    }
    // Lanes (a scene's stream): copy the rays out, walk, copy their range ends back.
    copies.clear();
    copies.extend((0..stream.len()).map(|i| stream.ray(i)));
    batch_ids.clear();
    batch_ids.extend((0..stream.len()).map(|i| stream.id(i)));
    trace_blocks::<K, V>(tree, setup, copies, batch_ids, lists, visitor);
    for (i, ray) in copies.iter().enumerate() {
        stream.set_tmax(i, ray.tmax);
    }
}

/// The walk's working memory (per thread, reused from stream to stream).
#[derive(Debug, Default)]
pub(crate) struct Lists {
    /// The one-ray loop's stack, for lists finished one ray at a time.
    stack: Stack,
    /// The lists of ray indices (into the block's rays), used as a stack.
    ids: Vec<u32>,
    /// Child masks of the rays of the list being split.
    masks: Vec<u8>,
    /// The lists waiting.
    pending: Vec<Pending>,
}

/// What a walk takes from the stream besides its rays.
#[derive(Clone, Copy)]
struct Setup {
    /// The rays' octant mask (0 when their octants differ: children in slot order).
    octant_mask: u8,
    single_ray_below: usize,
}

/// Runs `rays` (batch positions `ids`) through the tree in blocks of [`BLOCK`] rays.
#[inline(always)]
fn trace_blocks<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    setup: Setup,
    rays: &mut [PreparedRay],
    ids: &[u32],
    lists: &mut Lists,
    visitor: &mut V,
) {
    for (rays, ids) in rays.chunks_mut(BLOCK).zip(ids.chunks(BLOCK)) {
        trace_block::<K, V>(tree, setup, rays, ids, lists, visitor);
    }
}

/// Rays per walk, so that their index lists stay in cache (512 to 32k measured the same on the
/// bunny, by instruction and cache-miss counts).
const BLOCK: usize = 8192;

// `split` counts a node's rays per child in 16-bit fields.
const _: () = assert!(BLOCK <= u16::MAX as usize);

/// Runs `rays` (batch positions `batch_ids`) through the tree, as one walk.
#[inline(always)]
fn trace_block<K: TriangleTest, V: Visitor>(
    tree: &WideTree,
    setup: Setup,
    rays: &mut [PreparedRay],
    batch_ids: &[u32],
    lists: &mut Lists,
    visitor: &mut V,
) {
    let Lists {
        stack,
        ids,
        masks,
        pending,
    } = lists;
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
        octant_mask: setup.octant_mask,
        single_ray_below: setup.single_ray_below,
        rays,
        batch_ids,
        ids,
        top,
        masks,
        pending,
        stack,
    };
    while let Some(list) = walk.pending.pop() {
        walk.top = list.top as usize;
        walk.visit::<K, V>(list, visitor);
    }
}

/// The state of one stream's walk.
struct Walk<'a> {
    tree: &'a WideTree,
    /// The rays' octant mask (0 when their octants differ: children in slot order).
    octant_mask: u8,
    single_ray_below: usize,
    /// The block's rays, with their current range ends.
    rays: &'a mut [PreparedRay],
    /// Their positions in the caller's batch.
    batch_ids: &'a [u32],
    /// The index lists.
    ids: &'a mut Vec<u32>,
    /// The end of the lists in use in `ids`.
    top: usize,
    /// Child masks of the rays of the list being split.
    masks: &'a mut Vec<u8>,
    pending: &'a mut Vec<Pending>,
    /// The one-ray loop's stack.
    stack: &'a mut Stack,
}

impl Walk<'_> {
    /// The rays of `list` touch the box of its word: test its triangles, split them among its
    /// children, or finish its subtree one ray at a time when they are few.
    #[inline(always)]
    fn visit<K: TriangleTest, V: Visitor>(&mut self, list: Pending, visitor: &mut V) {
        let (start, end) = (list.start as usize, list.end as usize);
        if leaf_word::is_leaf(list.word) {
            self.test_leaf::<K, V>(list.word, start, end, visitor);
        } else if end - start < self.single_ray_below {
            for k in start..end {
                let i = self.ids[k] as usize;
                let ray = &mut self.rays[i];
                let id = self.batch_ids[i];
                let mut tmax = ray.tmax;
                super::single::trace_from::<K, V>(
                    self.tree, ray, id, list.word, &mut tmax, self.stack, visitor,
                );
                ray.tmax = tmax;
            }
        } else {
            self.split(list.word, start, end);
        }
    }

    /// Tests every ray of the list against the node's four boxes and pushes one list per child
    /// entered, nearest child last (popped first).
    #[inline(always)]
    fn split(&mut self, word: u32, start: usize, end: usize) {
        let node = &self.tree.nodes[word as usize];
        let counts = match self.octant_mask {
            0 => self.child_masks::<false>(node, 0, start, end),
            // One octant for all: the planes are picked once for the whole list.
            mask => self.child_masks::<true>(node, mask.trailing_zeros(), start, end),
        };
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
        let (lists, free) = self.ids.split_at_mut(top);
        for (&ray, &mask) in lists[start..end].iter().zip(&self.masks[..end - start]) {
            for (slot, at) in cursor.iter_mut().enumerate() {
                free[*at - top] = ray;
                *at += ((mask >> slot) & 1) as usize;
            }
        }
        for slot in node.nearest_first(self.octant_mask).rev() {
            let (list_end, count) = (cursor[slot] as u32, counts[slot] as u32);
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

    /// Each ray's child mask (which of the four boxes it enters), into `masks[..end - start]`,
    /// and the number of rays entering each child. With `ONE_OCTANT` every ray has octant
    /// `octant` and meets the node's planes the same way, so they are picked once.
    #[inline(always)]
    fn child_masks<const ONE_OCTANT: bool>(
        &mut self,
        node: &WideNode,
        octant: u32,
        start: usize,
        end: usize,
    ) -> [usize; WIDTH] {
        let shared = node.planes(octant);
        let ids = &self.ids[start..end];
        if self.masks.len() < ids.len() {
            self.masks.resize(ids.len(), 0);
        }
        // Counts of the four children in 16-bit fields: one add per ray.
        let mut packed = 0u64;
        for (out, &i) in self.masks.iter_mut().zip(ids) {
            let ray = &self.rays[i as usize];
            let wide = WideRay::new(ray);
            let planes = if ONE_OCTANT {
                debug_assert_eq!(wide.octant, octant);
                shared
            } else {
                node.planes(wide.octant)
            };
            let (mask, _) = wide.hits_planes(&planes, ray.tmax);
            packed += SPREAD[mask as usize & 15];
            *out = mask as u8;
        }
        [0, 1, 2, 3].map(|slot| ((packed >> (16 * slot)) & 0xFFFF) as usize)
    }

    /// Tests the leaf's triangles against every ray of the list, fetching each triangle once.
    #[inline(always)]
    fn test_leaf<K: TriangleTest, V: Visitor>(
        &mut self,
        word: u32,
        start: usize,
        end: usize,
        visitor: &mut V,
    ) {
        let (first, count) = leaf_word::unpack(word);
        for batch in LeafBatch::fetch(first..first + count, |slot| self.tree.triangle(slot)) {
            for k in start..end {
                let i = self.ids[k] as usize;
                let ray = &mut self.rays[i];
                let mut tmax = ray.tmax;
                batch.test::<K, V>(ray, self.batch_ids[i], &mut tmax, visitor);
                ray.tmax = tmax;
            }
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
