//! A stream of rays down the tree, once.
//!
//! An explicit stack holds `(node, count, box)`: rays `0..count` of the stream are the ones that
//! reached the node's parent, and the box was read (or dequantized, or recomputed) once, at the
//! parent, with its sibling's. At each node the box is tested against all of them, and the ones that touch it are moved to the front
//! ([`RayStream::partition`]); only that prefix goes on to the node's triangles and children.
//! Each triangle is loaded once and tested against every surviving ray. A child's partition only
//! reorders the prefix it was given, so when the second child is popped the prefix still holds
//! the same set of rays.
//!
//! All rays of a stream grouped by octant share the octant, so the node's ordering byte applies
//! to the whole stream. The kernel `K` is the very function the single-ray path runs: results
//! are bit-identical.

use glam::Vec3;

use super::avx2::{self, Loop};
use super::single::{test_triangles, trace_below};
use crate::accel::RayStream;
use crate::bvh::ordering::second_child_first;
use crate::bvh::{Bvh, BvhScratch};
use crate::geom::sign_filter::RayQuad;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
#[cfg(target_arch = "x86_64")]
use crate::x86::Avx2;

/// The stream walk's arguments, as a [`Loop`] (the walk is its `run`), to run in the AVX2 copy.
struct Stream<'a, 's, B: Bvh, K, V> {
    tree: &'a B,
    stream: &'a mut RayStream<'s>,
    scratch: &'a mut BvhScratch<B::Cache, B::NodeBox>,
    visitor: &'a mut V,
    kernel: std::marker::PhantomData<K>,
}

/// Runs every ray of `stream` through the tree, in the AVX2 copy where the CPU has AVX2 and
/// the tree wants it ([`Bvh::AVX2_TRAVERSAL`]).
pub(crate) fn trace_stream<B, K, V>(
    tree: &B,
    stream: &mut RayStream<'_>,
    scratch: &mut BvhScratch<B::Cache, B::NodeBox>,
    visitor: &mut V,
) where
    B: Bvh,
    K: TriangleTest,
    V: Visitor,
{
    let task = Stream::<B, K, V> {
        tree,
        stream,
        scratch,
        visitor,
        kernel: std::marker::PhantomData,
    };
    avx2::run(task, B::AVX2_TRAVERSAL)
}

impl<B: Bvh, K: TriangleTest, V: Visitor> Loop for Stream<'_, '_, B, K, V> {
    type Output = ();
    const AVX2: bool = B::AVX2_TRAVERSAL;

    /// Runs every ray of the stream through the tree.
    #[inline(always)]
    fn run(self) {
        let Self {
            tree,
            stream,
            scratch,
            visitor,
            ..
        } = self;
        if tree.is_empty() || stream.is_empty() {
            return;
        }
        let single_ray_below = stream.options().single_ray_below;
        let packet_from = stream.options().packet_from;
        let filter = Filter::detect();
        let mut pending = std::mem::take(&mut scratch.stream_stack);
        pending.clear();
        pending.push((0, stream.len() as u32, tree.root_bounds(&mut scratch.cache)));
        // The root box is the structure's cull box: a culled stream's rays all touch it.
        let root_tested = stream.in_cull_bounds();
        while let Some((index, count, bounds)) = pending.pop() {
            let active = if index == 0 && root_tested {
                count as usize
            } else {
                stream.partition(count as usize, &bounds)
            };
            if active == 0 {
                continue;
            }
            if active < single_ray_below {
                let start = (index, B::keep(&bounds));
                finish_few::<B, K, V>(
                    (filter, packet_from),
                    tree,
                    stream,
                    active,
                    start,
                    scratch,
                    visitor,
                );
                continue;
            }
            let node = tree.node(index);
            let slots = node.first..node.first + node.count;
            test_leaf::<K, V>(
                filter,
                stream,
                active,
                slots,
                |slot| tree.triangle(slot),
                visitor,
            );
            if node.has_children() {
                let [a, b] = node.children;
                let kept = B::keep(&bounds);
                let [ab, bb] = tree.child_bounds(&node, &kept, &mut scratch.cache);
                let (near, far) = if second_child_first(node.order, stream.octant_mask()) {
                    ((b, bb), (a, ab))
                } else {
                    ((a, ab), (b, bb))
                };
                pending.push((far.0, active as u32, far.1));
                pending.push((near.0, active as u32, near.1));
            }
        }
        scratch.stream_stack = pending;
    }
}

/// Most triangles a leaf pass keeps at once; larger triangle ranges go in several passes.
pub(crate) const LEAF_BATCH: usize = 16;

/// The widest sign filter this CPU runs, checked once per stream (not at every leaf).
#[derive(Clone, Copy)]
enum Filter {
    /// Four rays at a time ([`RayQuad`]: SSE2, NEON or scalar through glam).
    Four,
    /// Eight rays at a time with AVX2 (`RayOctet`).
    #[cfg(target_arch = "x86_64")]
    Eight(Avx2),
}

impl Filter {
    fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = Avx2::detect() {
            return Filter::Eight(avx2);
        }
        Filter::Four
    }
}

/// Up to [`LEAF_BATCH`] triangles of a leaf, fetched once to be tested against many rays: what
/// every stream engine does at a leaf.
pub(crate) struct LeafBatch {
    triangles: [(u32, [Vec3; 3]); LEAF_BATCH],
    len: usize,
}

impl LeafBatch {
    /// The triangles of `slots` (read with `triangle`), [`LEAF_BATCH`] at a time.
    pub(crate) fn fetch(
        slots: std::ops::Range<u32>,
        triangle: impl Fn(u32) -> (u32, [Vec3; 3]),
    ) -> impl Iterator<Item = LeafBatch> {
        let end = slots.end;
        slots.step_by(LEAF_BATCH).map(move |first| {
            let mut batch = LeafBatch {
                triangles: [(0, [Vec3::ZERO; 3]); LEAF_BATCH],
                len: (end - first).min(LEAF_BATCH as u32) as usize,
            };
            for (k, slot) in (first..).take(batch.len).enumerate() {
                batch.triangles[k] = triangle(slot);
            }
            batch
        })
    }

    /// For each triangle, the lanes of `quad` that may hit it (bit `k`: ray `k`), and the
    /// union: the watertight sign filter ([`crate::geom::sign_filter`]) proves the rest miss.
    #[inline(always)]
    pub(crate) fn may_hit(&self, quad: &RayQuad) -> ([u32; LEAF_BATCH], u32) {
        self.may_hit_with(|corners| quad.may_hit(corners))
    }

    /// [`LeafBatch::may_hit`] with any filter: `filter(corners)` gives the lanes that may hit.
    #[inline(always)]
    pub(crate) fn may_hit_with(
        &self,
        filter: impl Fn(&[Vec3; 3]) -> u32,
    ) -> ([u32; LEAF_BATCH], u32) {
        let mut masks = [0u32; LEAF_BATCH];
        let mut any = 0;
        for (mask, (_, corners)) in masks.iter_mut().zip(&self.triangles[..self.len]) {
            *mask = filter(corners);
            any |= *mask;
        }
        (masks, any)
    }

    /// [`LeafBatch::test`] on the triangles whose `masks` have bit `lane` set, in batch order:
    /// with masks from [`LeafBatch::may_hit`] the visitor sees the same hits in the same order.
    #[inline(always)]
    pub(crate) fn test_lane<K: TriangleTest, V: Visitor>(
        &self,
        (masks, lane): (&[u32; LEAF_BATCH], usize),
        ray: &PreparedRay,
        id: u32,
        tmax: &mut f32,
        visitor: &mut V,
    ) {
        let kept = self.triangles[..self.len]
            .iter()
            .zip(masks)
            .filter(|(_, mask)| *mask & (1 << lane) != 0)
            .map(|(triangle, _)| *triangle);
        test_triangles::<K, V>(ray, id, kept, tmax, visitor);
    }

    /// Tests rays `0..active` of `stream` against the batch through the sign filter, eight
    /// rays at a time where `filter` allows and there are at least eight, else four at a time,
    /// the scalar kernel only where a hit is possible. The last, partial group is filtered too,
    /// as the last full window of rays with the lanes already tested masked off (a remainder
    /// tested without the filter cost more than the whole window). Returns how many rays it
    /// handled: all of them, unless there are fewer than four; the rest are the caller's.
    #[inline]
    fn test_filtered<K: TriangleTest, V: Visitor>(
        &self,
        filter: Filter,
        stream: &mut RayStream<'_>,
        active: usize,
        visitor: &mut V,
    ) -> usize {
        #[cfg(target_arch = "x86_64")]
        if let Filter::Eight(avx2) = filter
            && active >= 8
        {
            return self.test_windows::<8, K, V>(
                stream,
                active,
                visitor,
                #[inline(always)]
                |stream, i| {
                    let octet = stream.octet(avx2, i);
                    self.may_hit_with(
                        #[inline(always)]
                        |corners| octet.may_hit(avx2, corners),
                    )
                },
            );
        }
        let _ = filter;
        self.test_windows::<4, K, V>(stream, active, visitor, |stream, i| {
            self.may_hit(&stream.quad(i))
        })
    }

    /// [`LeafBatch::test_filtered`] with windows of `N` rays: `filter(stream, i)` gives the masks
    /// of rays `i..i + N`.
    #[inline(always)]
    fn test_windows<const N: usize, K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        active: usize,
        visitor: &mut V,
        filter: impl Fn(&RayStream<'_>, usize) -> ([u32; LEAF_BATCH], u32),
    ) -> usize {
        if active < N {
            return 0;
        }
        let mut i = 0;
        while i + N <= active {
            let filtered = filter(stream, i);
            self.test_kept::<K, V>(stream, i, filtered, visitor);
            i += N;
        }
        if i < active {
            let window = active - N;
            let (mut masks, any) = filter(stream, window);
            let fresh = !0u32 << (i - window);
            masks.iter_mut().for_each(|mask| *mask &= fresh);
            self.test_kept::<K, V>(stream, window, (masks, any & fresh), visitor);
        }
        active
    }

    /// Runs the scalar kernel for ray `first + lane` of `stream` on the triangles whose
    /// `masks` have bit `lane`, for each lane set in `any`.
    #[inline(always)]
    fn test_kept<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        first: usize,
        (masks, any): ([u32; LEAF_BATCH], u32),
        visitor: &mut V,
    ) {
        let mut lanes = any;
        while lanes != 0 {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let ray = stream.ray(first + lane);
            let mut tmax = ray.tmax;
            let id = stream.id(first + lane);
            self.test_lane::<K, V>((&masks, lane), &ray, id, &mut tmax, visitor);
            stream.set_tmax(first + lane, tmax);
        }
    }

    /// Tests ray `ray` (number `id`, current range end `tmax`) against the batch.
    #[inline(always)]
    pub(crate) fn test<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        tmax: &mut f32,
        visitor: &mut V,
    ) {
        let triangles = self.triangles[..self.len].iter().copied();
        test_triangles::<K, V>(ray, id, triangles, tmax, visitor);
    }
}

/// Tests the triangles in `slots` (read with `triangle`) against rays `0..active` of the
/// stream, through the sign filter `filter` where the kernel has one: each triangle fetched
/// once for all rays, each ray rebuilt from its lane once per batch of triangles.
#[inline(always)]
fn test_leaf<K, V>(
    filter: Filter,
    stream: &mut RayStream<'_>,
    active: usize,
    slots: std::ops::Range<u32>,
    triangle: impl Fn(u32) -> (u32, [Vec3; 3]),
    visitor: &mut V,
) where
    K: TriangleTest,
    V: Visitor,
{
    for batch in LeafBatch::fetch(slots, triangle) {
        let filtered = if K::SIGN_FILTER {
            batch.test_filtered::<K, V>(filter, stream, active, visitor)
        } else {
            0
        };
        for i in filtered..active {
            let ray = stream.ray(i);
            let mut tmax = ray.tmax;
            batch.test::<K, V>(&ray, stream.id(i), &mut tmax, visitor);
            stream.set_tmax(i, tmax);
        }
    }
}

/// Finishes the subtree under node `start` for the few rays `0..active` that touch its box:
/// when only a few rays are left, the per-node cost of the stream (partition, stack) outweighs
/// what they share. Together with the packet walk (`traverse::packet`) where the tree asks for
/// it ([`Bvh::PACKET_WALK`]), the CPU has AVX2 and there are `packet_from..=8` of them
/// ([`crate::batch::BatchOptions::packet_from`]), else one ray at a time: the single-ray loop
/// with each ray's current range gives the same answers (they do not depend on the visiting
/// order).
#[inline(always)]
fn finish_few<B, K, V>(
    (filter, packet_from): (Filter, usize),
    tree: &B,
    stream: &mut RayStream<'_>,
    active: usize,
    start: (u32, B::NodeBox),
    scratch: &mut BvhScratch<B::Cache, B::NodeBox>,
    visitor: &mut V,
) where
    B: Bvh,
    K: TriangleTest,
    V: Visitor,
{
    #[cfg(target_arch = "x86_64")]
    if let Filter::Eight(avx2) = filter
        && B::PACKET_WALK
        && active >= packet_from
        && active <= 8
        && super::packet::finish::<B, K, V>(avx2, tree, stream, active, start, scratch, visitor)
    {
        return;
    }
    let _ = (filter, packet_from);
    let BvhScratch { stack, cache, .. } = scratch;
    for i in 0..active {
        let ray = stream.ray(i);
        let mut tmax = ray.tmax;
        let memory = (&mut *stack, &mut *cache);
        trace_below::<B, K, V, _>(tree, &ray, stream.id(i), start, &mut tmax, memory, visitor);
        stream.set_tmax(i, tmax);
    }
}
