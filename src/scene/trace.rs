//! How a scene answers rays: the top-level tree walked in world space, and at each instance
//! it reaches, the ray carried into mesh space once and handed to the instance's tree.
//!
//! One ray ([`Accel::trace`]): a depth-first walk of the top-level tree with the conservative
//! slab test on padded boxes ([`crate::scene::instance`]); at a leaf, each instance that passes
//! the filter gets the ray transformed by [`crate::scene::Rigid::ray_to_mesh`] and traced with
//! `K::AnyAxis` (the world ray's kernel may be specialised for a dominant axis the mesh-space
//! ray does not share).
//!
//! A stream ([`Accel::trace_stream`]): the whole stream goes down the top-level tree once
//! (at each node the rays that touch its box move to the front, as in the BVH stream engine);
//! at a leaf, the rays that reached it are transformed once into a second set of lanes and
//! handed to the instance's tree as one stream in mesh space, and their range ends are copied
//! back. Both paths trace the same mesh-space rays with the same kernels and report global ids
//! to the same visitors, so batched answers equal per-ray answers bit for bit.
//!
//! Filters ([`RayFilter`]) enter at three places, the same on both paths: a ray's range is
//! set once before the walk (open ends), the layers and the ignored instance decide which
//! instances a ray visits (a stream tests the union of its rays' layers at top-level nodes,
//! each ray at instances), and back faces are dropped hit by hit ([`FrontFaces`]) in the
//! visits of rays that cull them.

use std::marker::PhantomData;

use glam::Vec3;

use crate::accel::{Accel, Footprint, RayStream, Storage, StreamLayout};
use crate::batch::BatchOptions;
use crate::batch::lanes::Lanes;
use crate::catalog::AnyAccel;
use crate::geom::{Kernel, Ray};
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::{Hit, Ids, RAY_DONE, RenamedTask, Visitor, with_renamed};
use crate::query::{BatchError, BatchQueries, RayQueries};
use crate::scene::filter::{FilteredBatch, RayFilter, SceneView, back_face, seen};
use crate::scene::instance::{Instance, grown, ray_pad};
use crate::scene::top::TopNode;
use crate::scene::world::Scene;

/// Per-thread memory of scene traversals: the top-level stacks, the mesh-space lanes of an
/// instance visit and the meshes' own scratch.
#[derive(Default)]
pub struct SceneScratch {
    stack: Vec<u32>,
    stream_stack: Vec<(u32, u32)>,
    lanes: Lanes,
    /// Per mesh-space lane: the ray's index in the world stream and its id in the batch.
    outer: Vec<(u32, u32)>,
    /// Per mesh-space lane: its direction if the ray culls back faces.
    faces: Vec<Option<Vec3>>,
    /// A batch's per-ray filters by ray id in the stream.
    filters: Vec<RayFilter>,
    inner: <AnyAccel as Accel>::Scratch,
}

/// One ray traced in an instance's mesh space ([`Accel::trace`] on its tree), with the
/// caller's visitor fed global ids.
struct InstanceRay<'a, K> {
    mesh: &'a AnyAccel,
    ray: &'a PreparedRay,
    id: u32,
    scratch: &'a mut <AnyAccel as Accel>::Scratch,
    kernel: PhantomData<K>,
}

impl<K: TriangleTest> RenamedTask for InstanceRay<'_, K> {
    type Output = f32;
    #[inline(always)]
    fn run<W: Visitor>(self, visitor: &mut W) -> f32 {
        self.mesh
            .trace::<K, W>(self.ray, self.id, self.scratch, visitor)
    }
}

/// A stream traced in an instance's mesh space ([`Accel::trace_stream`] on its tree).
struct InstanceStream<'a, 's, K> {
    mesh: &'a AnyAccel,
    stream: &'a mut RayStream<'s>,
    scratch: &'a mut <AnyAccel as Accel>::Scratch,
    kernel: PhantomData<K>,
}

impl<K: TriangleTest> RenamedTask for InstanceStream<'_, '_, K> {
    type Output = ();
    fn run<W: Visitor>(self, visitor: &mut W) {
        self.mesh
            .trace_stream::<K, W>(self.stream, self.scratch, visitor)
    }
}

/// The filters of a query: one for every ray, or one per ray by its id in the stream (a
/// batch's per-ray filters, copied by id once per stream: [`FilteredBatch`]'s `trace_stream`).
#[derive(Clone, Copy)]
enum Filters<'a> {
    Same(RayFilter),
    ById(&'a [RayFilter]),
}

impl Filters<'_> {
    /// The filter of ray `i` of `stream`.
    #[inline(always)]
    fn of(&self, stream: &RayStream<'_>, i: usize) -> RayFilter {
        match self {
            Filters::Same(filter) => *filter,
            Filters::ById(filters) => filters[stream.id(i) as usize],
        }
    }
}

/// Whether rays of the stream's octant visit an inner node's second child first.
#[inline(always)]
fn second_first(node: &TopNode, octant_mask: u8) -> bool {
    octant_mask != 0 && (octant_mask.trailing_zeros() >> node.axis) & 1 == 1
}

/// One ray through the scene's top-level subtree under node `start` (the root for a per-ray
/// query; a node a stream reached with few rays left, see [`trace_stream`]). The ray's range
/// is already the filter's ([`RayFilter::prepare`]).
#[allow(clippy::too_many_arguments)]
fn trace_one<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    filter: &RayFilter,
    ray: &PreparedRay,
    id: u32,
    start: u32,
    scratch: &mut SceneScratch,
    visitor: &mut V,
) -> f32 {
    let mut tmax = ray.tmax;
    let nodes = &scene.top.nodes;
    if nodes.is_empty() {
        return tmax;
    }
    let pad = ray_pad(ray.origin);
    let mut stack = std::mem::take(&mut scratch.stack);
    stack.clear();
    stack.push(start);
    while let Some(index) = stack.pop() {
        let node = &nodes[index as usize];
        // `tmax < tmin` once a visitor ended the ray (any hit sets `-inf`).
        if tmax < ray.tmin {
            break;
        }
        if !seen(node.mask, filter.layers) || !grown(&node.bounds, pad).hit_by(ray, tmax) {
            continue;
        }
        visitor.enter_node(id);
        if node.is_leaf() {
            for slot in node.first..node.first + node.count {
                let index = scene.top.order[slot as usize];
                let instance = &scene.instances[index as usize];
                if filter.admits(index, instance) {
                    let cull = filter.cull_back_faces;
                    let visit = (ray, tmax, id, cull);
                    tmax = trace_instance::<K, V>(scene, instance, visit, scratch, visitor);
                }
            }
        } else {
            let (a, b) = (node.first, node.first + 1);
            let dir_negative = ray.dir[node.axis as usize].is_sign_negative();
            let (near, far) = if dir_negative { (b, a) } else { (a, b) };
            stack.push(far);
            stack.push(near);
        }
    }
    scratch.stack = stack;
    tmax
}

/// One ray (`ray` with range end `tmax`, as ray `id`, culling back faces if `cull`) on one
/// instance, in its mesh space; returns the new range end.
#[inline]
fn trace_instance<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    instance: &Instance,
    (ray, tmax, id, cull): (&PreparedRay, f32, u32, bool),
    scratch: &mut SceneScratch,
    visitor: &mut V,
) -> f32 {
    let Some(local) = instance.transform.prepared_to_mesh(ray, tmax) else {
        return tmax;
    };
    let mesh = &scene.meshes[instance.mesh()];
    // Culling, the mesh's walk sees the ray as number 0 and the filter renames it back.
    let task = InstanceRay::<K::AnyAxis> {
        mesh,
        ray: &local,
        id: if cull { 0 } else { id },
        scratch: &mut scratch.inner,
        kernel: PhantomData,
    };
    if cull {
        let (outer, faces) = ([(0, id)], [Some(local.dir)]);
        let mut front = FrontFaces::new(mesh, instance.first_id, (&outer, &faces), visitor);
        return with_renamed(Ids::Offset(0), None, &mut front, task);
    }
    with_renamed(Ids::Offset(instance.first_id), None, visitor, task)
}

/// The caller's visitor behind a filter that drops hits on back faces, for one instance visit
/// whose walk reports mesh ids and mesh-space ray ids: it renames both for the caller.
struct FrontFaces<'a, V> {
    mesh: &'a AnyAccel,
    first_id: u32,
    /// By mesh-space ray id: the ray's index in the caller's stream and its id there.
    outer: &'a [(u32, u32)],
    /// By mesh-space ray id: the ray's mesh-space direction if it culls back faces.
    faces: &'a [Option<Vec3>],
    inner: &'a mut V,
}

impl<'a, V> FrontFaces<'a, V> {
    fn new(
        mesh: &'a AnyAccel,
        first_id: u32,
        (outer, faces): (&'a [(u32, u32)], &'a [Option<Vec3>]),
        inner: &'a mut V,
    ) -> Self {
        Self {
            mesh,
            first_id,
            outer,
            faces,
            inner,
        }
    }
}

impl<V: Visitor> Visitor for FrontFaces<'_, V> {
    const COUNTS_NODES: bool = V::COUNTS_NODES;
    const ENDS_RAYS: bool = V::ENDS_RAYS;

    #[inline(always)]
    fn visit(&mut self, ray: u32, hit: Hit, tmax: &mut f32) {
        let lane = ray as usize;
        if let Some(dir) = self.faces[lane]
            && back_face(self.mesh.corners(hit.triangle), dir)
        {
            return;
        }
        let triangle = self.first_id + hit.triangle;
        self.inner
            .visit(self.outer[lane].1, Hit { triangle, ..hit }, tmax);
    }

    #[inline(always)]
    fn enter_node(&mut self, ray: u32) {
        self.inner.enter_node(self.outer[ray as usize].1);
    }
}

/// A stream through the scene (see the module docs).
fn trace_stream<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    filters: Filters<'_>,
    stream: &mut RayStream<'_>,
    scratch: &mut SceneScratch,
    visitor: &mut V,
) {
    let nodes = &scene.top.nodes;
    if nodes.is_empty() || stream.is_empty() {
        return;
    }
    let layers = prepare_ranges(filters, stream);
    let pad = stream_pad(stream);
    let octant_mask = stream.octant_mask();
    let mut pending = std::mem::take(&mut scratch.stream_stack);
    pending.clear();
    pending.push((0, stream.len() as u32));
    while let Some((index, count)) = pending.pop() {
        let node = &nodes[index as usize];
        if !seen(node.mask, layers) {
            continue;
        }
        let active = stream.partition(count as usize, &grown(&node.bounds, pad));
        if active == 0 {
            continue;
        }
        if active < stream.options().single_ray_below {
            // Too few rays left for the stream's bookkeeping to pay: finish them one by one
            // from this node, with the per-ray walk (same instances, same answers).
            for i in 0..active {
                let (ray, id, filter) = (stream.ray(i), stream.id(i), filters.of(stream, i));
                let tmax = trace_one::<K, V>(scene, &filter, &ray, id, index, scratch, visitor);
                stream.set_tmax(i, tmax);
            }
            continue;
        }
        if node.is_leaf() {
            for slot in node.first..node.first + node.count {
                let index = scene.top.order[slot as usize];
                let instance = &scene.instances[index as usize];
                let visit = (index, instance, active);
                match filters {
                    Filters::Same(filter) if filter.admits(index, instance) => {
                        stream_instance::<K, V>(scene, visit, stream, filters, scratch, visitor)
                    }
                    Filters::ById(_) if seen(instance.mask, layers) => {
                        stream_instance::<K, V>(scene, visit, stream, filters, scratch, visitor)
                    }
                    _ => {}
                }
            }
        } else {
            let (a, b) = (node.first, node.first + 1);
            let (near, far) = if second_first(node, octant_mask) {
                (b, a)
            } else {
                (a, b)
            };
            pending.push((far, active as u32));
            pending.push((near, active as u32));
        }
    }
    scratch.stream_stack = pending;
}

/// Gives each ray of `stream` its filter's range ([`RayFilter::range`]; a ray whose range
/// holds no float is ended) and returns the union of the rays' layers.
fn prepare_ranges(filters: Filters<'_>, stream: &mut RayStream<'_>) -> u32 {
    if let Filters::Same(filter) = filters
        && filter.include_ends
    {
        return filter.layers;
    }
    let mut layers = 0;
    for i in 0..stream.len() {
        let filter = filters.of(stream, i);
        layers |= filter.layers;
        if filter.include_ends {
            continue;
        }
        let ray = stream.ray(i);
        if let Some((tmin, tmax)) = filter.range(ray.tmin, ray.tmax) {
            stream.set_tmin(i, tmin);
            stream.set_tmax(i, tmax);
        } else {
            stream.set_tmax(i, RAY_DONE);
        }
    }
    layers
}

/// One padding for the whole stream: the largest any of its rays needs, read from the origin
/// columns alone.
fn stream_pad(stream: &RayStream<'_>) -> f32 {
    (0..stream.len()).fold(0.0f32, |m, i| m.max(ray_pad(stream.origin(i))))
}

/// Rays `0..active` of `stream` on instance number `index`: those its filter admits,
/// transformed once into mesh-space lanes, traced as one stream, their range ends copied
/// back.
fn stream_instance<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    (index, instance, active): (u32, &Instance, usize),
    stream: &mut RayStream<'_>,
    filters: Filters<'_>,
    scratch: &mut SceneScratch,
    visitor: &mut V,
) {
    let mesh = &scene.meshes[instance.mesh()];
    // Most rays of a batch take part in most instances they reach: one pass may spare the
    // copy.
    let as_is = instance.transform.is_identity()
        && match filters {
            Filters::Same(filter) => !filter.cull_back_faces,
            Filters::ById(_) => (0..active).all(|i| {
                let filter = filters.of(stream, i);
                filter.admits(index, instance) && !filter.cull_back_faces
            }),
        };
    if as_is {
        // Mesh space is world space: the stream's own rays go down the mesh's tree as they
        // are (the tree only reorders them within the prefix, which keeps the set).
        let mut local = stream.prefix(active);
        let task = InstanceStream::<K::AnyAxis> {
            mesh,
            stream: &mut local,
            scratch: &mut scratch.inner,
            kernel: PhantomData,
        };
        with_renamed(Ids::Offset(instance.first_id), None, visitor, task);
        return;
    }
    let SceneScratch {
        lanes,
        outer,
        faces,
        inner,
        ..
    } = scratch;
    // Grow only: the lanes past the stream's end are never read, and shrinking would make the
    // next visit clear them again.
    if lanes.len() < active {
        lanes.reset(active);
    }
    outer.clear();
    faces.clear();
    let mut culls = false;
    for i in 0..active {
        let filter = filters.of(stream, i);
        if !filter.admits(index, instance) {
            continue;
        }
        let ray = stream.ray(i);
        if let Some(local) = instance.transform.prepared_to_mesh(&ray, ray.tmax) {
            lanes.set(outer.len(), &local, outer.len() as u32);
            outer.push((i as u32, stream.id(i)));
            faces.push(filter.cull_back_faces.then_some(local.dir));
            culls |= filter.cull_back_faces;
        }
    }
    let n = outer.len();
    if n == 0 {
        return;
    }
    let storage = Storage::Lanes(lanes);
    let mut local = RayStream::new(storage, 0, n, 0, stream.partitioner, stream.options);
    let task = InstanceStream::<K::AnyAxis> {
        mesh,
        stream: &mut local,
        scratch: inner,
        kernel: PhantomData,
    };
    if culls {
        let mut front = FrontFaces::new(mesh, instance.first_id, (outer, faces), visitor);
        with_renamed(Ids::Offset(0), None, &mut front, task);
    } else {
        with_renamed(Ids::Offset(instance.first_id), Some(outer), visitor, task);
    }
    for lane in 0..n {
        let (i, _) = outer[lanes.id(lane) as usize];
        stream.set_tmax(i as usize, lanes.tmax(lane));
    }
}

/// A view answers the queries; the scene is its view on every layer.
impl Accel for SceneView<'_> {
    type Scratch = SceneScratch;
    // The top level partitions the stream at each of its nodes.
    const STREAM_LAYOUT: StreamLayout = StreamLayout::Lanes;

    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) -> f32 {
        let Some(ray) = self.filter.prepare(ray) else {
            return ray.tmax;
        };
        trace_one::<K, V>(self.scene, &self.filter, &ray, id, 0, scratch, visitor)
    }

    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) {
        let filters = Filters::Same(self.filter);
        trace_stream::<K, V>(self.scene, filters, stream, scratch, visitor)
    }
}

/// A batch with a filter per ray: only ever traced as the batched queries' streams, whose rays
/// know their batch index (a per-ray query goes through [`Scene::filtered`]).
impl Accel for FilteredBatch<'_> {
    type Scratch = SceneScratch;
    const STREAM_LAYOUT: StreamLayout = StreamLayout::Lanes;

    /// Ray `id` is the ray of index `id` in the batch.
    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) -> f32 {
        self.filtered(id as usize)
            .trace::<K, V>(ray, id, scratch, visitor)
    }

    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) {
        // The filters by the rays' ids, which the walk reads with one lookup less than by
        // batch index.
        let mut by_id = std::mem::take(&mut scratch.filters);
        for i in 0..stream.len() {
            let id = stream.id(i) as usize;
            let index = stream
                .batch_index(i)
                .expect("a stream of the batch's own rays");
            if by_id.len() <= id {
                by_id.resize(id + 1, RayFilter::ALL);
            }
            by_id[id] = self.filters[index];
        }
        let filters = Filters::ById(&by_id);
        trace_stream::<K, V>(self.scene, filters, stream, scratch, visitor);
        scratch.filters = by_id;
    }
}

crate::query::compiled_queries!(SceneView<'_>);

/// The scene's queries are its view through [`RayFilter::ALL`].
impl RayQueries for Scene {
    #[cfg_attr(test, inline)]
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        self.filtered(RayFilter::ALL).cast_ray_with(ray, kernel)
    }
    #[cfg_attr(test, inline)]
    fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32) {
        self.filtered(RayFilter::ALL).cast_ray_visits(ray, kernel)
    }
    #[cfg_attr(test, inline)]
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        self.filtered(RayFilter::ALL).occluded_with(ray, kernel)
    }
    #[cfg_attr(test, inline)]
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit)) {
        self.filtered(RayFilter::ALL)
            .for_each_hit_with(ray, kernel, f)
    }
    fn visit<V: Visitor>(&self, ray: &Ray, kernel: Kernel, visitor: &mut V)
    where
        Self: Sized,
    {
        self.filtered(RayFilter::ALL).visit(ray, kernel, visitor)
    }
}

impl BatchQueries for Scene {
    #[cfg_attr(test, inline)]
    fn cast_ray_batch_with(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        self.filtered(RayFilter::ALL)
            .cast_ray_batch_with(rays, hits, options)
    }
    #[cfg_attr(test, inline)]
    fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        self.filtered(RayFilter::ALL)
            .occluded_batch_with(rays, occluded, options)
    }
    #[cfg_attr(test, inline)]
    fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: &(dyn Fn(usize, Hit) + Sync),
    ) {
        self.filtered(RayFilter::ALL)
            .for_each_hit_batch_with(rays, options, f)
    }
}

impl Footprint for Scene {
    fn name(&self) -> &'static str {
        "scene"
    }
    fn triangle_count(&self) -> usize {
        Scene::triangle_count(self)
    }
    fn node_count(&self) -> usize {
        self.top.nodes.len() + self.meshes.iter().map(|m| m.node_count()).sum::<usize>()
    }
    fn heap_bytes(&self) -> usize {
        self.scene_bytes() + self.meshes.iter().map(|m| m.heap_bytes()).sum::<usize>()
    }
    fn id_map_bytes(&self) -> usize {
        self.meshes.iter().map(|m| m.id_map_bytes()).sum()
    }
}
