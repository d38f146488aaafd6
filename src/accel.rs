//! The one interface every acceleration structure implements, and what the queries build on.
//!
//! An [`Accel`] answers two questions: "report every hit of this ray" ([`Accel::trace`]) and
//! "report every hit of each ray of this stream" ([`Accel::trace_stream`], by default one ray
//! at a time). Closest hit, any hit and all hits are visitors ([`crate::hit`]) written once in
//! [`crate::query`] on top of these two methods, so every structure gets all of them, per ray
//! and batched, with the same tie rule and the same exactness contract:
//!
//! - report every hit the kernel `K` finds on a triangle of the structure whose `t` lies in
//!   `[ray.tmin, tmax]`, where `tmax` is the range end the visitor maintains, each triangle at
//!   most once per ray;
//! - never skip a part of the structure that may hold such a hit (so the box tests must be
//!   conservative and compare entry distances with `<=`, see [`crate::hit`]).
//!
//! Every binary BVH ([`crate::bvh::Bvh`]) is an `Accel` through the generic engines in
//! [`crate::traverse`]; a structure with its own walk (a grid, a kd-tree, a scene of instances)
//! implements `Accel` directly. Per-thread state a structure needs (a traversal stack, a box
//! cache, mailboxes) is its [`Accel::Scratch`], kept in the thread's
//! [`crate::workspace::Workspace`] and reused from query to query.

use crate::batch::lanes::Lanes;
use crate::batch::options::BatchOptions;
use crate::batch::partition::Partitioner;
use crate::batch::rays::PreparedRays;
#[cfg(target_arch = "x86_64")]
use crate::geom::sign_filter::RayOctet;
use crate::geom::sign_filter::RayQuad;
use crate::geom::{Aabb, PreparedRay, Ray, TriangleTest};
use crate::hit::Visitor;
use crate::workspace::Workspace;
#[cfg(target_arch = "x86_64")]
use crate::x86::Avx2;

/// An acceleration structure: the traversal every query is written on (see the module docs).
pub trait Accel: Sync + Sized {
    /// Per-thread working memory of this structure's traversals (a stack, a box cache).
    /// Created on first use in each thread's workspace and reused afterwards; shared by every
    /// structure of the same type that the thread queries.
    type Scratch: Default + Send + 'static;

    /// How the batched queries hand this structure its rays ([`StreamLayout`]). Both layouts
    /// answer every [`RayStream`] method; the choice only changes what is cheap.
    const STREAM_LAYOUT: StreamLayout = StreamLayout::Records;

    /// Whether the batched queries group this structure's rays by direction octant, as
    /// [`crate::BatchOptions::ordering`] asks (the default). Structures whose walks take
    /// nothing from the stream's octant (each ray walked alone, in its own order: the grids,
    /// the kd-tree) say `false` and get each chunk as one stream, which keeps rays that start
    /// near each other together for an order by origin (`crate::traverse::origin_order`).
    const GROUP_BY_OCTANT: bool = true;

    /// Whether the octants holding less than a quarter of a chunk's rays share one stream of
    /// mixed octants (their octant mask 0) instead of a stream each: for structures whose walk
    /// tests each ray against its own octant's planes and gains more from long streams than
    /// from one child order per stream (the wide trees, `wide::stream::CHUNK`).
    const MIXES_SMALL_OCTANTS: bool = false;

    /// The largest chunk a batch is cut into for this structure, unless
    /// [`crate::BatchOptions::max_chunk`] says otherwise: by default its layout's
    /// ([`StreamLayout::default_max_chunk`]). The wide trees, which walk a chunk's incoherent
    /// rays as one stream, are fastest on shorter chunks (`wide::stream::CHUNK`).
    const DEFAULT_MAX_CHUNK: usize = Self::STREAM_LAYOUT.default_max_chunk();

    /// The largest chunk the batch `rays` is cut into for this structure, unless
    /// [`crate::BatchOptions::max_chunk`] says otherwise: [`Accel::DEFAULT_MAX_CHUNK`], or
    /// what suits this structure's size and the rays (the wide trees cut incoherent batches
    /// into longer chunks when they are beyond the caches, `WideBvh`'s `LARGE_TREE_CHUNK`).
    fn max_chunk(&self, rays: &[Ray]) -> usize {
        let _ = rays;
        Self::DEFAULT_MAX_CHUNK
    }

    /// Reports to `visitor`, as ray number `id`, every hit of `ray` with kernel `K` in
    /// `[ray.tmin, tmax]`, where `tmax` starts at `ray.tmax` and follows what the visitor sets;
    /// returns the final `tmax`.
    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) -> f32;

    /// [`Accel::trace`] for a ray traced alone, as ray number 0, with this thread's scratch
    /// from its [`Workspace`]. A structure whose one-ray walk needs only a stack overrides it
    /// to keep the stack on the call stack, which saves the workspace lookup on every ray
    /// (the wide trees, and the binary trees whose boxes need no cache).
    #[inline(always)]
    fn trace_alone<K: TriangleTest, V: Visitor>(&self, ray: &PreparedRay, visitor: &mut V) {
        trace_with_workspace::<Self, K, V>(self, ray, visitor);
    }

    /// A box every ray that can hit anything touches: a ray that misses it as [`Aabb::hit_by`]
    /// tests it (the prepared ray, its own `tmax`) has no hit from [`Accel::trace`]. The
    /// batched queries answer the rays that miss it while they prepare them (no hit, not
    /// occluded), and those rays never enter a stream. `None` (the default): every valid ray
    /// enters one.
    fn cull_bounds(&self) -> Option<Aabb> {
        None
    }

    /// [`Accel::trace`] for every ray of `stream` (each reported with its id in the batch),
    /// updating each ray's range end in the stream. The default traces the rays one at a time;
    /// structures that can share work between rays (a node fetched once for all rays that reach
    /// it) override it. `K` may differ from the per-ray kernel (the watertight kernel dispatches
    /// on each ray's axis here) but must give the same answers.
    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) {
        for i in 0..stream.len() {
            let ray = stream.ray(i);
            let tmax = self.trace::<K, V>(&ray, stream.id(i), scratch, visitor);
            stream.set_tmax(i, tmax);
        }
    }
}

/// [`Accel::trace_alone`]'s default: [`Accel::trace`] with the thread's scratch, for the
/// overrides' cases that need it.
#[inline(always)]
pub(crate) fn trace_with_workspace<A: Accel, K: TriangleTest, V: Visitor>(
    accel: &A,
    ray: &PreparedRay,
    visitor: &mut V,
) {
    Workspace::with_local(|workspace| {
        accel.trace::<K, V>(ray, 0, workspace.scratch::<A::Scratch>(), visitor);
    });
}

/// The corners of a triangle a structure reported, by the id it reported: what a scene needs
/// to give a hit its normal.
pub(crate) trait Corners {
    /// The corners of triangle `id` (an id this structure's queries report).
    fn corners(&self, id: u32) -> [glam::Vec3; 3];
}

/// What a structure is and what it costs: for tables, reports and the catalog.
pub trait Footprint {
    /// Short name for tables (`aabb`, `quantized`, ...).
    fn name(&self) -> &'static str;

    /// Triangles of the mesh the structure answers for (degenerate ones included).
    fn triangle_count(&self) -> usize;

    /// Nodes (or cells) of the structure.
    fn node_count(&self) -> usize;

    /// Bytes the structure adds to the mesh (nodes, triangle order, copies).
    fn heap_bytes(&self) -> usize;

    /// Bytes kept beside the structure only to report hits in the caller's triangle ids (the
    /// permutation an [`crate::AnyAccel`] keeps beside a zero-byte tree, which reorders the
    /// mesh); 0 for structures that keep the ids.
    fn id_map_bytes(&self) -> usize {
        0
    }

    /// Extra bytes per triangle of the mesh.
    fn bytes_per_triangle(&self) -> f64 {
        self.heap_bytes() as f64 / self.triangle_count().max(1) as f64
    }
}

/// How a batch's rays are laid out in a [`RayStream`] ([`Accel::STREAM_LAYOUT`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamLayout {
    /// Structure-of-arrays lanes: [`RayStream::partition`] tests 8 or 16 rays per instruction
    /// and moves whole rays, so a binary tree's stream finds its rays' constants contiguous at
    /// every node. Preparing them costs a scatter into sixteen columns.
    Lanes,
    /// One prepared record per ray, written once: for structures that keep lists of ray
    /// indices or take rays one at a time (the 4-wide tree, grids, kd-tree). The default.
    Records,
}

impl StreamLayout {
    /// The largest chunk a batch is cut into for a structure of this layout, unless
    /// [`crate::BatchOptions::max_chunk`] says otherwise (a structure may choose its own,
    /// [`Accel::DEFAULT_MAX_CHUNK`]). Records are never moved, so the grids' and kd-tree's
    /// walks, one ray at a time in an order by origin, take chunks of 1,048,576 (the wide
    /// trees' index lists walk faster in chunks of 64k, `wide::stream::CHUNK`). Lanes move
    /// whole rays at every node, and their partitions run faster on chunks that stay nearer the
    /// caches: 131,072 (1M-ray chunks made the binary tree's batched closest hit about 20%
    /// slower, docs/benchmarks.md).
    pub const fn default_max_chunk(self) -> usize {
        match self {
            StreamLayout::Lanes => 1 << 17,
            StreamLayout::Records => 1 << 20,
        }
    }
}

/// Where a stream's rays live (see [`StreamLayout`]).
#[derive(Debug)]
pub(crate) enum Storage<'a> {
    Lanes(&'a mut Lanes),
    Records(&'a mut PreparedRays),
}

impl Storage<'_> {
    /// The same rays, borrowed for a shorter while (a sub-stream, one group of a chunk).
    pub(crate) fn reborrow(&mut self) -> Storage<'_> {
        match self {
            Storage::Lanes(lanes) => Storage::Lanes(lanes),
            Storage::Records(records) => Storage::Records(records),
        }
    }
}

/// The rays of one batch handed to [`Accel::trace_stream`]: prepared once (validated, kernel
/// constants computed) and laid out as the structure asked ([`Accel::STREAM_LAYOUT`]): in
/// structure-of-arrays lanes, so that a box test runs over 8 or 16 rays per instruction and a
/// partition moves them without pointer chasing, or as one record per ray.
///
/// Ray `i` (for `i < len()`) has a position in the caller's batch ([`RayStream::id`]) and a
/// current range end ([`RayStream::tmax`]). If [`RayStream::octant_mask`] is non-zero, all
/// rays share that octant; if it is 0 their octants differ (an unordered batch, a structure
/// that walks one stream per chunk, or the small octants a wide tree's chunk mixes).
pub struct RayStream<'a> {
    pub(crate) storage: Storage<'a>,
    pub(crate) start: usize,
    pub(crate) end: usize,
    pub(crate) octant_mask: u8,
    pub(crate) partitioner: Partitioner,
    pub(crate) options: &'a BatchOptions,
    /// Every ray touches the structure's [`Accel::cull_bounds`]: the batch preparation tested
    /// them, so the walk need not test its root box again.
    pub(crate) in_cull_bounds: bool,
    /// The stream is a dense octant of its chunk ([`RayStream::is_dense_octant`]).
    pub(crate) dense_octant: bool,
    /// By ray id, the ray's position in its chunk, and the chunk's first ray in the batch
    /// ([`RayStream::batch_index`]); empty for a structure's own sub-streams.
    positions: &'a [u32],
    offset: usize,
}

impl<'a> RayStream<'a> {
    /// Rays `start..end` of `storage`.
    pub(crate) fn new(
        storage: Storage<'a>,
        start: usize,
        end: usize,
        octant_mask: u8,
        partitioner: Partitioner,
        options: &'a BatchOptions,
    ) -> Self {
        debug_assert!(start <= end);
        debug_assert!(match &storage {
            Storage::Lanes(lanes) => end <= lanes.len(),
            Storage::Records(records) => end <= records.rays.len(),
        });
        Self {
            storage,
            start,
            end,
            octant_mask,
            partitioner,
            options,
            in_cull_bounds: false,
            dense_octant: false,
            positions: &[],
            offset: 0,
        }
    }

    /// The same stream, whose ray ids are slots of a batch's chunk: `positions[id]` is the
    /// ray's position in the chunk, which starts at ray `offset` of the batch.
    pub(crate) fn in_batch(self, positions: &'a [u32], offset: usize) -> Self {
        Self {
            positions,
            offset,
            ..self
        }
    }

    /// The index of ray `i` in the rays the caller passed to the batched query, for per-ray
    /// data the caller passed beside them; `None` in a structure's own sub-streams.
    #[inline(always)]
    pub(crate) fn batch_index(&self, i: usize) -> Option<usize> {
        let position = self.positions.get(self.id(i) as usize)?;
        Some(self.offset + *position as usize)
    }

    /// The same stream, marked as holding only rays that touch the structure's
    /// [`Accel::cull_bounds`] (the batch preparation culled the others) if `tested`.
    pub(crate) fn culled(self, tested: bool) -> Self {
        Self {
            in_cull_bounds: tested,
            ..self
        }
    }

    /// The same stream, marked as a dense octant of its chunk if `dense`.
    pub(crate) fn dense_octant(self, dense: bool) -> Self {
        Self {
            dense_octant: dense,
            ..self
        }
    }

    /// True if the stream's rays share one direction octant that holds at least 3/16 of its
    /// chunk's valid rays, where incoherent rays hold about an eighth: coherent rays, such
    /// as a camera's (see `batch::group::is_dense_octant`).
    pub fn is_dense_octant(&self) -> bool {
        self.dense_octant
    }

    /// True if every ray is known to touch the structure's [`Accel::cull_bounds`], which is
    /// its root box: a walk may skip its root test.
    pub(crate) fn in_cull_bounds(&self) -> bool {
        self.in_cull_bounds
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    /// True if the stream holds no ray.
    pub fn is_empty(&self) -> bool {
        self.start == self.end
    }

    /// `1 << octant` when every ray of the stream has that direction octant, 0 when they may
    /// differ (see [`crate::geom::octant`]).
    pub fn octant_mask(&self) -> u8 {
        self.octant_mask
    }

    /// The lane of ray `i`; panics if `i >= len()` (the lanes beyond belong to other streams).
    #[inline(always)]
    fn lane(&self, i: usize) -> usize {
        assert!(i < self.len(), "ray {i} of a stream of {}", self.len());
        self.start + i
    }

    /// Ray `i`, bit for bit as prepared, with its current range end.
    #[inline(always)]
    pub fn ray(&self, i: usize) -> PreparedRay {
        let lane = self.lane(i);
        match &self.storage {
            Storage::Lanes(lanes) => lanes.ray(lane),
            Storage::Records(records) => records.rays[lane],
        }
    }

    /// Prefetches ray `i`'s record and id (records layout; nothing in the lanes layout, whose
    /// walks take the rays in order): for walks that take the rays out of order
    /// (`crate::traverse::origin_order`), where each ray's record would be a cache miss.
    #[inline(always)]
    pub(crate) fn prefetch_ray(&self, i: usize) {
        let lane = self.lane(i);
        if let Storage::Records(records) = &self.storage {
            let ray = &records.rays[lane];
            // One line: a record is 64 bytes, aligned to 64.
            crate::prefetch::prefetch(ray);
            crate::prefetch::prefetch(&records.ids[lane]);
        }
    }

    /// The origin of ray `i`.
    #[inline(always)]
    pub(crate) fn origin(&self, i: usize) -> glam::Vec3 {
        let lane = self.lane(i);
        match &self.storage {
            Storage::Lanes(lanes) => lanes.origin(lane),
            Storage::Records(records) => records.rays[lane].origin,
        }
    }

    /// The sign-filter constants of rays `i..i + 8`, eight at a time with AVX2; panics unless
    /// `i + 8 <= len()`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn octet(&self, avx2: Avx2, i: usize) -> RayOctet {
        assert!(i + 8 <= self.len(), "rays {i}..{} of {}", i + 8, self.len());
        match &self.storage {
            Storage::Lanes(lanes) => lanes.octet(avx2, self.start + i),
            Storage::Records(records) => {
                let slots = std::array::from_fn(|j| (self.start + i + j) as u32);
                RayOctet::gather(avx2, &records.rays, &slots)
            }
        }
    }

    /// Rays `0..count` (`1 <= count <= 8`) copied out as eight lanes ([`Lanes::block`]), for
    /// the packet walk; `None` in the records layout. Panics unless `count <= len()`.
    ///
    /// [`Lanes::block`]: crate::batch::lanes::Lanes::block
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn block(&self, count: usize) -> Option<crate::batch::lanes::Block> {
        assert!((1..=8).contains(&count) && count <= self.len());
        match &self.storage {
            Storage::Lanes(lanes) => Some(lanes.block(self.start, count)),
            Storage::Records(_) => None,
        }
    }

    /// The sign-filter constants of rays `i..i + 4`; panics unless `i + 4 <= len()`.
    #[inline(always)]
    pub(crate) fn quad(&self, i: usize) -> RayQuad {
        assert!(i + 4 <= self.len(), "rays {i}..{} of {}", i + 4, self.len());
        match &self.storage {
            Storage::Lanes(lanes) => lanes.quad(self.start + i),
            Storage::Records(records) => records.quad(self.start + i),
        }
    }

    /// The position of ray `i` in the caller's batch (what visitors receive).
    #[inline(always)]
    pub fn id(&self, i: usize) -> u32 {
        let lane = self.lane(i);
        match &self.storage {
            Storage::Lanes(lanes) => lanes.id(lane),
            Storage::Records(records) => records.ids[lane],
        }
    }

    /// Sets the range start of ray `i` (only ever raised, before a walk: see
    /// `crate::scene::RayFilter::include_ends`).
    #[inline(always)]
    pub(crate) fn set_tmin(&mut self, i: usize, tmin: f32) {
        let lane = self.lane(i);
        match &mut self.storage {
            Storage::Lanes(lanes) => lanes.set_tmin(lane, tmin),
            Storage::Records(records) => records.rays[lane].tmin = tmin,
        }
    }

    /// Sets the range end of ray `i`.
    #[inline(always)]
    pub fn set_tmax(&mut self, i: usize, tmax: f32) {
        let lane = self.lane(i);
        match &mut self.storage {
            Storage::Lanes(lanes) => lanes.set_tmax(lane, tmax),
            Storage::Records(records) => records.rays[lane].tmax = tmax,
        }
    }

    /// The stream's rays and batch positions as records, to walk in place; `None` in the
    /// lanes layout.
    pub(crate) fn records(&mut self) -> Option<(&mut [PreparedRay], &[u32])> {
        match &mut self.storage {
            Storage::Lanes(_) => None,
            Storage::Records(records) => Some((
                &mut records.rays[self.start..self.end],
                &records.ids[self.start..self.end],
            )),
        }
    }

    /// Rays `0..count` as a stream of their own (same layout, octant and options).
    pub(crate) fn prefix(&mut self, count: usize) -> RayStream<'_> {
        assert!(
            count <= self.len(),
            "{count} rays of a stream of {}",
            self.len()
        );
        RayStream {
            storage: self.storage.reborrow(),
            start: self.start,
            end: self.start + count,
            octant_mask: self.octant_mask,
            partitioner: self.partitioner,
            options: self.options,
            in_cull_bounds: self.in_cull_bounds,
            dense_octant: self.dense_octant,
            positions: self.positions,
            offset: self.offset,
        }
    }

    /// Tests rays `0..count` against `bounds` with the conservative slab test, moves those that
    /// touch it to the front (keeping their order), and returns how many there are. Panics if
    /// `count > len()`.
    #[inline]
    pub fn partition(&mut self, count: usize, bounds: &Aabb) -> usize {
        assert!(
            count <= self.len(),
            "{count} rays of a stream of {}",
            self.len()
        );
        let (start, end) = (self.start, self.start + count);
        match &mut self.storage {
            Storage::Lanes(lanes) => self.partitioner.run(lanes, bounds, start, end),
            Storage::Records(records) => records.partition(bounds, start, end),
        }
    }

    /// The options of the batched call (tuning knobs a structure may read).
    pub fn options(&self) -> &BatchOptions {
        self.options
    }
}
