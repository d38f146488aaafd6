//! A stream of rays down a wide tree once (with four or eight children per node:
//! the node layout says how one ray and eight rays test its boxes, `kind::layout::Layout`).
//!
//! The rays are the batch's prepared records (one cache line each, holding the ray's current
//! range end: the tree asks for [`crate::accel::StreamLayout::Records`]), walked in place; a
//! stream in lanes (from a scene) is copied out first. A stream holds rays of one direction
//! octant, or of several (the octants that hold few of a chunk's rays, [`CHUNK`] says why). The walk
//! moves only 4-byte ray indices. At a node reached by a list of rays, eight rays at a time
//! test each child box (AVX2; each ray against its own octant's planes, or, in a stream of one
//! octant, the planes picked once per node; the node's one-ray test for the rest) and each
//! ray's index is appended to the list of every child it enters; the node's boxes are read
//! once for the whole list. A stream of one octant pushes child lists in the node's
//! precomputed order for it, farther child first, so the nearer ones are walked first and
//! closest-hit rays shrink early; a mixed stream pushes them in slot order. A leaf's triangles are fetched once and tested against every
//! ray of its list, eight rays at a time through the watertight kernel's sign filter first
//! (AVX2, `geom::sign_filter::RayOctet`; four at a time elsewhere), which proves most misses,
//! so the scalar kernel runs only where a hit is possible (about 14% faster on the fandisk's
//! incoherent rays). Lists shorter than [`BatchOptions::single_ray_below`] finish their
//! subtree with the one-ray loop (any-hit lists: shorter than twice that, `single_ray_below`).
//!
//! Eight children per node (`WideTree8`) take a third fewer levels but test more boxes per ray
//! and level: batched, the 8-wide tree takes about as long as the 4-wide tree on incoherent
//! rays and up to 13% longer on camera rays. The 8-wide tree is the default nonetheless:
//! single rays gain more than batches lose ([`crate::AccelKind::DEFAULT`];
//! docs/benchmarks.md).
//!
//! The index lists live in one buffer used as a stack: a node's child lists are written above
//! everything pending, and popping a list moves the buffer's logical end back to where its
//! siblings end, so memory stays proportional to the rays times the depth of the walk.
//!
//! [`BatchOptions::single_ray_below`]: crate::batch::BatchOptions::single_ray_below

use super::order::order_slots;
use super::ray::{BoxSimd, MAX_WIDTH, WideRay};
use super::stack::Stack;
use super::{NodeKind, WideBvh, WideScratch};
use crate::accel::{RayStream, StreamLayout};
use crate::bvh::nodes::leaf_word;
#[cfg(target_arch = "x86_64")]
use crate::geom::sign_filter::RayOctet;
use crate::geom::sign_filter::RayQuad;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::traverse::stream::{LEAF_BATCH, LeafBatch};

/// A list of rays waiting to enter a child: its word, its rays (`ids[start..end]`) and where
/// the buffer ends once it and its siblings are all that is pending above it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pending {
    word: u32,
    start: u32,
    end: u32,
    top: u32,
}

/// The list length below which the walk of visitor `V` finishes a subtree one ray at a time:
/// the caller's [`crate::BatchOptions::single_ray_below`], doubled when `V` ends rays
/// ([`Visitor::ENDS_RAYS`]). An any-hit stream carries the rays it has ended until a split
/// drops them (23% of the rays entering an 8-wide tree's splits, 17% of a 4-wide tree's,
/// fandisk line of sight), while the one-ray walk stops at a ray's first hit. Doubled (16), it
/// takes up to 7% off the bunny's any-hit line-of-sight batches (`bvh8`); closest-hit walks
/// keep 8, as larger thresholds cost the bunny in calls of 4,096 rays (docs/benchmarks.md).
fn single_ray_below<V: Visitor>(option: usize) -> usize {
    if V::ENDS_RAYS {
        option.saturating_mul(2)
    } else {
        option
    }
}

/// Runs every ray of `stream` through the tree.
#[inline(always)]
pub(crate) fn trace_stream<N: NodeKind, K: TriangleTest, V: Visitor>(
    tree: &WideBvh<N>,
    stream: &mut RayStream<'_>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    if tree.is_empty() || stream.is_empty() {
        return;
    }
    let setup = Setup {
        octant_mask: stream.octant_mask(),
        single_ray_below: single_ray_below::<V>(stream.options().single_ray_below),
        root_tested: stream.in_cull_bounds(),
    };
    let WideScratch {
        stack,
        lists,
        copies,
        batch_ids,
        ..
    } = scratch;
    let scratch = (lists, stack);
    if let Some((rays, ids)) = stream.records() {
        // The tree's own layout (`StreamLayout::Records`): walk the records in place.
        return trace_blocks::<N, K, V>(tree, setup, rays, ids, scratch, visitor);
    }
    // Lanes (a scene's stream): copy the rays out, walk, copy their range ends back.
    copies.clear();
    copies.extend((0..stream.len()).map(|i| stream.ray(i)));
    batch_ids.clear();
    batch_ids.extend((0..stream.len()).map(|i| stream.id(i)));
    trace_blocks::<N, K, V>(tree, setup, copies, batch_ids, scratch, visitor);
    for (i, ray) in copies.iter().enumerate() {
        stream.set_tmax(i, ray.tmax);
    }
}

/// The walk's working memory (per thread, reused from stream to stream).
#[derive(Debug)]
pub(crate) struct Lists {
    /// Set if the CPU has AVX2: the split then tests eight rays at a time.
    #[cfg(target_arch = "x86_64")]
    avx2: Option<crate::x86::Avx2>,
    /// The lists of ray indices (into the block's rays), used as a stack.
    ids: Vec<u32>,
    /// Child masks of the rays of the list being split, one byte per ray.
    masks: Vec<u8>,
    /// The same, eight rays at a time: one byte per child, one bit per ray.
    group_bits: Vec<u64>,
    /// The lists waiting.
    pending: Vec<Pending>,
}

// Derivable where the AVX2 field is compiled out.
#[cfg_attr(not(target_arch = "x86_64"), allow(clippy::derivable_impls))]
impl Default for Lists {
    fn default() -> Self {
        Self {
            #[cfg(target_arch = "x86_64")]
            avx2: crate::x86::Avx2::detect(),
            ids: Vec::new(),
            masks: Vec::new(),
            group_bits: Vec::new(),
            pending: Vec::new(),
        }
    }
}

/// What a walk takes from the stream besides its rays.
#[derive(Clone, Copy)]
struct Setup {
    /// The rays' octant mask (0 when their octants differ: children in slot order).
    octant_mask: u8,
    single_ray_below: usize,
    /// Every ray touches the root box (the batch preparation culled the others).
    root_tested: bool,
}

/// Runs `rays` (batch positions `ids`) through the tree in blocks of [`BLOCK`] rays, with the
/// thread's lists and its one-ray stack (for lists finished one ray at a time).
#[inline(always)]
fn trace_blocks<N: NodeKind, K: TriangleTest, V: Visitor>(
    tree: &WideBvh<N>,
    setup: Setup,
    rays: &mut [PreparedRay],
    ids: &[u32],
    (lists, stack): (&mut Lists, &mut Stack),
    visitor: &mut V,
) {
    for (rays, ids) in rays.chunks_mut(BLOCK).zip(ids.chunks(BLOCK)) {
        trace_block::<N, K, V>(
            tree,
            setup,
            (rays, ids),
            (&mut *lists, &mut *stack),
            visitor,
        );
    }
}

/// The wide trees' default chunk ([`crate::accel::Accel::DEFAULT_MAX_CHUNK`]), in which the
/// octants holding less than a quarter of the rays share one stream of mixed octants
/// (`Accel::MIXES_SMALL_OCTANTS`: the split tests each ray against its own octant's planes,
/// `simd::stream_masks`, and pushes child lists in slot order).
///
/// Eight octant streams would let the split pick one octant's planes per node and push the
/// child lists in that octant's order; but incoherent rays make eight short streams (about
/// 512 rays for a call of 4,096, which the walk leaves to the one-ray loop after two or three
/// levels), and a large chunk walks its records out of the caches (64 MiB for 1M rays). One
/// stream keeps lists eight times as long for the same records: incoherent rays in mixed
/// chunks of 64k take 0.79-0.94x the time of octant streams of 1M-ray chunks, where longer
/// mixed chunks read their records out of the caches (docs/benchmarks.md).
///
/// Coherent rays keep their octant streams: a camera's rays walked as mixed streams take about
/// 1.6x the time of octant streams of the same chunks, whose child lists come in the right
/// order for every ray.
pub(crate) const CHUNK: usize = 1 << 16;

/// Rays per walk at most: a longer stream (a chunk from [`crate::BatchOptions::max_chunk`], a
/// scene's stream) is walked in parts this long. Longer walks share each node and
/// leaf among more rays, so more of the split and of the leaf tests run eight rays at a time
/// and fewer rays finish alone; their records outgrow the caches, so the split prefetches them
/// (`simd::PREFETCH_GROUPS`): on octant streams of 1M incoherent rays, prefetched walks of 1M
/// take the bunny's closest hits about 28% less time than walks of 64k without the prefetch
/// (docs/benchmarks.md). Copying the rays of a short list next to each other before walking
/// its subtree (so that the deeper splits read the caches) is slower than reading them in
/// place, prefetched.
const BLOCK: usize = StreamLayout::Records.default_max_chunk();

// `split` counts a node's rays per child in 32-bit fields.
const _: () = assert!(BLOCK <= u32::MAX as usize);

/// Runs `rays` (batch positions `batch_ids`) through the tree, as one walk.
#[inline(always)]
fn trace_block<N: NodeKind, K: TriangleTest, V: Visitor>(
    tree: &WideBvh<N>,
    setup: Setup,
    (rays, batch_ids): (&mut [PreparedRay], &[u32]),
    (lists, stack): (&mut Lists, &mut Stack),
    visitor: &mut V,
) {
    let Lists {
        #[cfg(target_arch = "x86_64")]
        avx2,
        ids,
        masks,
        group_bits,
        pending,
    } = lists;
    // The buffer only grows (never zero-filled again); `Walk::top` is its logical end.
    if ids.len() < rays.len() {
        ids.resize(rays.len(), 0);
    }
    let mut top = 0;
    for (i, ray) in rays.iter().enumerate() {
        ids[top] = i as u32;
        top += (setup.root_tested || tree.root_bounds.hit_by(ray, ray.tmax)) as usize;
    }
    pending.clear();
    pending.push(Pending {
        word: tree.root,
        start: 0,
        end: top as u32,
        top: top as u32,
    });
    let mut walk = Walk {
        #[cfg(target_arch = "x86_64")]
        avx2: *avx2,
        tree,
        simd: BoxSimd::detect(true),
        octant_mask: setup.octant_mask,
        single_ray_below: setup.single_ray_below,
        rays,
        batch_ids,
        ids,
        top,
        masks,
        group_bits,
        pending,
        stack,
    };
    while let Some(list) = walk.pending.pop() {
        walk.top = list.top as usize;
        walk.prefetch_pending();
        walk.visit::<K, V>(list, visitor);
    }
}

/// The state of one stream's walk.
struct Walk<'a, N: NodeKind> {
    #[cfg(target_arch = "x86_64")]
    avx2: Option<crate::x86::Avx2>,
    tree: &'a WideBvh<N>,
    /// The one-ray box test (8 lanes with AVX2 where the CPU has it), for the rays the split
    /// does not take eight at a time and the lists finished one ray at a time.
    simd: BoxSimd,
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
    /// The same, eight rays at a time (written and read on x86-64 only).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    group_bits: &'a mut Vec<u64>,
    pending: &'a mut Vec<Pending>,
    /// The one-ray loop's stack.
    stack: &'a mut Stack,
}

impl<N: NodeKind> Walk<'_, N> {
    /// Prefetches what the next two lists waiting read first: the node or the leaf's
    /// triangles of the next (the second link of a leaf's read chain, whose first was
    /// prefetched a visit earlier), the first link of the one after. A visit tests many rays,
    /// long enough to hide the wait (about 8% faster on the bunny's incoherent rays, batched).
    #[inline(always)]
    fn prefetch_pending(&self) {
        let n = self.pending.len();
        if let Some(next) = n.checked_sub(1).map(|k| self.pending[k].word) {
            if leaf_word::is_leaf(next) {
                self.tree.prefetch_leaf(next, 1);
            } else {
                self.tree.prefetch_node(next);
            }
        }
        let after = n.checked_sub(2).map(|k| self.pending[k].word);
        if let Some(after) = after.filter(|&word| leaf_word::is_leaf(word)) {
            self.tree.prefetch_leaf(after, 0);
        }
    }

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
                let wide_ray = WideRay::new(ray, self.simd);
                super::single::trace_from::<N, K, V, false>(
                    self.tree,
                    (ray, &wide_ray, id),
                    list.word,
                    &mut tmax,
                    self.stack,
                    visitor,
                );
                ray.tmax = tmax;
            }
        } else {
            self.split(list.word, start, end);
        }
    }

    /// Tests every ray of the list against the node's boxes and pushes one list per child
    /// entered, nearest child last (popped first).
    #[inline(always)]
    fn split(&mut self, word: u32, start: usize, end: usize) {
        let node = &self.tree.nodes[word as usize];
        let (grouped, counts) = self.child_masks(node, start, end);
        // Child lists at the top of the buffer, in slot order. Writes run past a list's end
        // (each ray is written to every list and kept where its mask bit is set; eight rays are
        // written at once), so each list has `SPARE` slots after it.
        let top = self.top;
        let mut cursor = [0usize; MAX_WIDTH];
        let mut next = top;
        for slot in 0..N::WIDTH {
            cursor[slot] = next - top;
            next += counts[slot] as usize + SPARE;
        }
        if self.ids.len() < next {
            self.ids.resize(next, 0);
        }
        self.top = next;
        let (lists, free) = self.ids.split_at_mut(top);
        let rays = &lists[start..end];
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2.filter(|_| grouped > 0) {
            let groups = &self.group_bits[..grouped / 8];
            let cursor = &mut cursor[..N::WIDTH];
            super::simd::write_lists(avx2, &rays[..grouped], groups, cursor, free);
        }
        for (&ray, &mask) in rays[grouped..].iter().zip(&self.masks[grouped..]) {
            for (slot, at) in cursor[..N::WIDTH].iter_mut().enumerate() {
                free[*at] = ray;
                *at += ((mask >> slot) & 1) as usize;
            }
        }
        let order = node.stream_order(self.octant_mask);
        for slot in order_slots(order, N::WIDTH).rev() {
            let (list_end, count) = ((cursor[slot] + top) as u32, counts[slot]);
            if count > 0 {
                self.pending.push(Pending {
                    word: node.child(slot),
                    start: list_end - count,
                    end: list_end,
                    top: next as u32,
                });
            }
        }
    }

    /// Which of the node's boxes each ray enters, and the number of rays entering each child.
    /// Returns how many rays (a multiple of eight) went through the eight-at-a-time test, whose
    /// masks are in `group_bits` (one `u64` per eight rays, one byte per child, one bit per
    /// ray); the others' masks are in `masks[grouped..end - start]` (one byte per ray, one bit
    /// per child). Eight at a time, a stream of one octant takes the planes picked once for
    /// it; a stream of mixed octants, each ray's own (`simd::stream_masks`).
    #[inline(always)]
    fn child_masks(&mut self, node: &N, start: usize, end: usize) -> (usize, [u32; MAX_WIDTH]) {
        let ids = &self.ids[start..end];
        if self.masks.len() < ids.len() {
            self.masks.resize(ids.len(), 0);
        }
        #[cfg(target_arch = "x86_64")]
        let (grouped, counts) = match (self.octant_mask, self.avx2) {
            (mask, Some(avx2)) => {
                if self.group_bits.len() < ids.len() / 8 {
                    self.group_bits.resize(ids.len() / 8, 0);
                }
                let planes = node.stream_planes(planes_octant(mask));
                let bits = &mut *self.group_bits;
                let node = (&planes, node.used_slots(), mask);
                super::simd::stream_masks(avx2, node, self.rays, ids, bits)
            }
            _ => (0, [0; MAX_WIDTH]),
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (grouped, counts) = (0, [0; MAX_WIDTH]);
        let rest = (&ids[grouped..], &mut self.masks[grouped..]);
        let rest = masks_one_by_one(node, self.simd, self.rays, rest);
        (
            grouped,
            std::array::from_fn(|slot| counts[slot] + rest[slot]),
        )
    }

    /// Tests the leaf's triangles against every ray of the list, fetching each triangle once.
    /// With the watertight kernel, rays go four at a time through the sign filter first
    /// ([`LeafBatch::may_hit`]), which proves most misses without the scalar kernel; each ray
    /// still meets its triangles in slot order, so it sees the same hits in the same order.
    #[inline(always)]
    fn test_leaf<K: TriangleTest, V: Visitor>(
        &mut self,
        word: u32,
        start: usize,
        end: usize,
        visitor: &mut V,
    ) {
        let (_, count) = leaf_word::unpack(word);
        for batch in LeafBatch::fetch(0..count, |k| self.tree.triangle(word, k)) {
            let filtered = if K::SIGN_FILTER {
                self.test_quads::<K, V>(&batch, start, end, visitor)
            } else {
                start
            };
            for k in filtered..end {
                let i = self.ids[k] as usize;
                let ray = &mut self.rays[i];
                let mut tmax = ray.tmax;
                batch.test::<K, V>(ray, self.batch_ids[i], &mut tmax, visitor);
                ray.tmax = tmax;
            }
        }
    }

    /// The list's rays through the sign filter, eight at a time with AVX2, then four at a
    /// time, the scalar kernel only where a hit is possible. Returns where the rays it left
    /// (fewer than four) start.
    #[inline(always)]
    fn test_quads<K: TriangleTest, V: Visitor>(
        &mut self,
        batch: &LeafBatch,
        start: usize,
        end: usize,
        visitor: &mut V,
    ) -> usize {
        let mut k = start;
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = self.avx2 {
            while k + 8 <= end {
                let eight: &[u32; 8] = self.ids[k..k + 8].try_into().unwrap();
                let octet = RayOctet::gather(avx2, self.rays, eight);
                let (masks, any) = batch.may_hit_with(|tri| octet.may_hit(avx2, tri));
                let eight = eight.map(|i| i as usize);
                self.test_kept::<K, V>(batch, (&masks, any), &eight, visitor);
                k += 8;
            }
        }
        while k + 4 <= end {
            let four: [usize; 4] = std::array::from_fn(|j| self.ids[k + j] as usize);
            let quad = RayQuad::from_rays(four.map(|i| &self.rays[i]));
            let (masks, any) = batch.may_hit_with(|tri| quad.may_hit(tri));
            self.test_kept::<K, V>(batch, (&masks, any), &four, visitor);
            k += 4;
        }
        k
    }

    /// Runs the scalar kernel for ray `rays[lane]` on the triangles of `batch` whose `masks`
    /// have bit `lane`, for each lane set in `any`.
    #[inline(always)]
    fn test_kept<K: TriangleTest, V: Visitor>(
        &mut self,
        batch: &LeafBatch,
        (masks, any): (&[u32; LEAF_BATCH], u32),
        rays: &[usize],
        visitor: &mut V,
    ) {
        let mut lanes = any;
        while lanes != 0 {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let i = rays[lane];
            let ray = &mut self.rays[i];
            let mut tmax = ray.tmax;
            batch.test_lane::<K, V>((masks, lane), ray, self.batch_ids[i], &mut tmax, visitor);
            ray.tmax = tmax;
        }
    }
}

/// The child masks of the rays `ids` (into `rays`), into `masks`, one ray at a time with the
/// node's one-ray box test: the portable way, and the rays left over by the eight-at-a-time
/// version. Returns the number of rays entering each child.
#[inline(always)]
fn masks_one_by_one<N: NodeKind>(
    node: &N,
    simd: BoxSimd,
    rays: &[PreparedRay],
    (ids, masks): (&[u32], &mut [u8]),
) -> [u32; MAX_WIDTH] {
    let mut counts = [0; MAX_WIDTH];
    for (out, &i) in masks.iter_mut().zip(ids) {
        let ray = &rays[i as usize];
        let mask = node.ray_mask(&WideRay::new(ray, simd), ray.tmax);
        for (slot, count) in counts.iter_mut().enumerate().take(N::WIDTH) {
            *count += (mask >> slot) & 1;
        }
        *out = mask as u8;
    }
    counts
}

/// The octant whose planes the eight-at-a-time split is given for a stream of octant mask
/// `mask`: its octant, or for mixed octants (mask 0) octant 0, whose planes each lane swaps
/// by its own signs (`simd::stream_masks`).
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
fn planes_octant(mask: u8) -> u32 {
    if mask == 0 { 0 } else { mask.trailing_zeros() }
}

/// Slots after each child list for the writes past its end: eight rays are written at once.
const SPARE: usize = 8;

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use glam::Vec3;

    use super::super::node4::WideNode;
    use super::super::node4q::QuantizedWideNode;
    use super::super::node8::WideNode8;
    use super::super::node8q::QuantizedWideNode8;
    use super::super::simd::{self, Avx2};
    use super::*;
    use crate::geom::{Aabb, Ray};
    use crate::test_support::TestRng;

    /// Any-hit walks (whose visitor ends rays) leave lists to the one-ray walk at twice the
    /// caller's threshold, every other walk at the threshold itself, saturating.
    #[test]
    fn ending_visitors_double_the_one_ray_threshold() {
        use crate::hit::{Any, Closest, Sink};
        assert_eq!(single_ray_below::<Any<'static>>(8), 16);
        assert_eq!(single_ray_below::<Any<'static>>(usize::MAX), usize::MAX);
        assert_eq!(single_ray_below::<Sink<'static, true, false>>(8), 16);
        assert_eq!(single_ray_below::<Closest<'static>>(8), 8);
        assert_eq!(single_ray_below::<Sink<'static, false, false>>(8), 8);
    }

    /// A node of `used` random boxes (some flat), ordered.
    fn random_node<N: NodeKind>(rng: &mut TestRng, used: usize) -> (N, Vec<Aabb>) {
        let boxes: Vec<Aabb> = (0..used)
            .map(|slot| {
                let a = rng.vec3(2.0);
                let mut b = a + rng.vec3(1.0).abs();
                if slot == 1 {
                    b.z = a.z;
                }
                Aabb::new(a.min(b), a.max(b))
            })
            .collect();
        let children: Vec<(Aabb, u32)> = boxes.iter().map(|&b| (b, 0)).collect();
        (N::from_children(&children), boxes)
    }

    /// A ray of direction octant `octant`: some components zero (signed by the octant), some
    /// origins on a box's plane, finite and infinite range ends.
    fn random_ray(rng: &mut TestRng, octant: u32, plane_y: f32, k: usize) -> PreparedRay {
        let mut dir = rng.vec3(1.0).abs();
        if k.is_multiple_of(5) {
            dir[k % 3] = 0.0;
        }
        // Negated where the octant says negative (a zero becomes -0.0, of that octant too).
        let mut dir = Vec3::from_array(std::array::from_fn(|a| {
            if (octant >> a) & 1 != 0 {
                -dir[a]
            } else {
                dir[a]
            }
        }));
        if dir == Vec3::ZERO {
            dir.x = if octant & 1 != 0 { -1.0 } else { 1.0 };
        }
        let mut origin = rng.vec3(3.0);
        // On the plane; from `k % 15 == 10` on, also with a zero `y` direction (`k % 5 == 0`,
        // `k % 3 == 1`): `(plane - origin) * inv` is then `0 * inf`, NaN.
        if k.is_multiple_of(7) || k % 15 == 10 {
            origin.y = plane_y;
        }
        let tmax = if k.is_multiple_of(3) {
            f32::INFINITY
        } else {
            rng.range(0.0, 5.0)
        };
        let tmin = if k.is_multiple_of(4) {
            rng.range(0.0, 1.0)
        } else {
            0.0
        };
        PreparedRay::new(&Ray::with_range(origin, dir, tmin, tmax.max(tmin))).unwrap()
    }

    /// The split's eight-at-a-time box tests and list writes (AVX2) give the same masks,
    /// counts and lists as the one-ray-at-a-time loops, on lists of every length, for nodes of
    /// four and of eight children, on streams of one octant and of mixed octants; and the
    /// one-ray masks are the scalar slab test's.
    #[test]
    fn eight_at_a_time_equals_one_at_a_time() {
        let Some(avx2) = Avx2::detect_or_note("the split runs one ray at a time only") else {
            return;
        };
        eight_at_a_time_equals_one_at_a_time_for::<WideNode>(avx2);
        eight_at_a_time_equals_one_at_a_time_for::<WideNode8>(avx2);
        eight_at_a_time_equals_one_at_a_time_for::<QuantizedWideNode>(avx2);
        eight_at_a_time_equals_one_at_a_time_for::<QuantizedWideNode8>(avx2);
    }

    fn eight_at_a_time_equals_one_at_a_time_for<N: NodeKind>(avx2: Avx2) {
        let mut rng = TestRng::new(5);
        for round in 0..3000 {
            let (node, boxes) = random_node::<N>(&mut rng, 1 + round % N::WIDTH);
            assert_eq!(node.used_slots(), boxes.len());
            // Every other run of eight rounds: a stream of rays of every octant (so that both
            // kinds meet every octant and every child count).
            let mixed = (round / 8) % 2 == 1;
            let octant = (round % 8) as u32;
            let rays: Vec<PreparedRay> = (0..64)
                .map(|k| {
                    let octant = if mixed { (k % 8) as u32 } else { octant };
                    random_ray(&mut rng, octant, boxes[0].min.y, k)
                })
                .collect();
            assert!(mixed || rays.iter().all(|r| r.octant_mask == 1 << octant));
            let n = round % 40;
            let ids: Vec<u32> = (0..n).map(|_| rng.range(0.0, 63.99) as u32).collect();

            let mut bits = vec![0u64; n / 8];
            let mask = if mixed { 0 } else { 1 << octant };
            let planes = node.stream_planes(planes_octant(mask));
            let node_planes = (&planes, node.used_slots(), mask);
            let (grouped, counts) = simd::stream_masks(avx2, node_planes, &rays, &ids, &mut bits);
            assert_eq!(grouped, n / 8 * 8);
            let mut masks = vec![0u8; n];
            let one_by_one = (&ids[..grouped], &mut masks[..grouped]);
            let expected = masks_one_by_one(&node, BoxSimd::detect(true), &rays, one_by_one);
            assert_eq!(counts, expected, "counts, round {round}");
            for (j, &mask) in masks[..grouped].iter().enumerate() {
                let group = bits[j / 8];
                let from_bits =
                    (0..N::WIDTH).fold(0, |m, c| m | ((group >> (8 * c + j % 8)) & 1) << c);
                assert_eq!(from_bits, u64::from(mask), "ray {j}, round {round}");
                let ray = &rays[ids[j] as usize];
                let scalar = (0..boxes.len()).fold(0, |m, c| {
                    let bounds = node.child_bounds(c);
                    m | u8::from(bounds.entry(ray, ray.tmax) < f32::INFINITY) << c
                });
                assert_eq!(
                    mask, scalar,
                    "ray {j} against the scalar test, round {round}"
                );
            }

            // Lists: each of the grouped rays to every child it enters, in order.
            let mut cursor = vec![0usize; N::WIDTH];
            let mut next = 0;
            for c in 0..N::WIDTH {
                cursor[c] = next;
                next += counts[c] as usize + SPARE;
            }
            let starts = cursor.clone();
            let mut lists = vec![u32::MAX; next];
            simd::write_lists(avx2, &ids[..grouped], &bits, &mut cursor, &mut lists);
            for c in 0..N::WIDTH {
                let expected: Vec<u32> = (0..grouped)
                    .filter(|&j| masks[j] & (1 << c) != 0)
                    .map(|j| ids[j])
                    .collect();
                assert_eq!(cursor[c] - starts[c], expected.len());
                assert_eq!(
                    lists[starts[c]..cursor[c]],
                    expected,
                    "child {c}, round {round}"
                );
            }
        }
    }
}
