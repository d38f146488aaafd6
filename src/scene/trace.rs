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

use std::marker::PhantomData;

use crate::accel::{Accel, Footprint, RayStream, Storage, StreamLayout};
use crate::batch::BatchOptions;
use crate::batch::lanes::Lanes;
use crate::catalog::AnyAccel;
use crate::geom::{Kernel, Ray};
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::{Hit, Ids, RenamedTask, Visitor, with_renamed};
use crate::query::{BatchError, BatchQueries, RayQueries};
use crate::scene::filter::SceneView;
use crate::scene::instance::{ALL_LAYERS, Instance, grown, ray_pad};
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

/// True if an instance on layers `layers` is seen by a query on layers `mask`.
#[inline(always)]
fn seen(layers: u32, mask: u32) -> bool {
    layers & mask != 0
}

/// Whether rays of the stream's octant visit an inner node's second child first.
#[inline(always)]
fn second_first(node: &TopNode, octant_mask: u8) -> bool {
    octant_mask != 0 && (octant_mask.trailing_zeros() >> node.axis) & 1 == 1
}

/// One ray through the scene's top-level subtree under node `start` (the root for a per-ray
/// query; a node a stream reached with few rays left, see [`trace_stream`]).
fn trace_one<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    mask: u32,
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
        if !seen(node.mask, mask) || !grown(&node.bounds, pad).hit_by(ray, tmax) {
            continue;
        }
        visitor.enter_node(id);
        if node.is_leaf() {
            for slot in node.first..node.first + node.count {
                let instance = &scene.instances[scene.top.order[slot as usize] as usize];
                if seen(instance.mask, mask) {
                    tmax = trace_instance::<K, V>(scene, instance, ray, tmax, id, scratch, visitor);
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

/// One ray on one instance, in its mesh space; returns the new range end.
#[inline]
fn trace_instance<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    instance: &Instance,
    ray: &PreparedRay,
    tmax: f32,
    id: u32,
    scratch: &mut SceneScratch,
    visitor: &mut V,
) -> f32 {
    let Some(local) = instance.transform.prepared_to_mesh(ray, tmax) else {
        return tmax;
    };
    let task = InstanceRay::<K::AnyAxis> {
        mesh: &scene.meshes[instance.mesh()],
        ray: &local,
        id,
        scratch: &mut scratch.inner,
        kernel: PhantomData,
    };
    with_renamed(Ids::Offset(instance.first_id), None, visitor, task)
}

/// A stream through the scene (see the module docs).
fn trace_stream<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    mask: u32,
    stream: &mut RayStream<'_>,
    scratch: &mut SceneScratch,
    visitor: &mut V,
) {
    let nodes = &scene.top.nodes;
    if nodes.is_empty() || stream.is_empty() {
        return;
    }
    let pad = stream_pad(stream);
    let octant_mask = stream.octant_mask();
    let mut pending = std::mem::take(&mut scratch.stream_stack);
    pending.clear();
    pending.push((0, stream.len() as u32));
    while let Some((index, count)) = pending.pop() {
        let node = &nodes[index as usize];
        if !seen(node.mask, mask) {
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
                let ray = stream.ray(i);
                let id = stream.id(i);
                let tmax = trace_one::<K, V>(scene, mask, &ray, id, index, scratch, visitor);
                stream.set_tmax(i, tmax);
            }
            continue;
        }
        if node.is_leaf() {
            for slot in node.first..node.first + node.count {
                let instance = &scene.instances[scene.top.order[slot as usize] as usize];
                if seen(instance.mask, mask) {
                    stream_instance::<K, V>(scene, instance, stream, active, scratch, visitor);
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

/// One padding for the whole stream: the largest any of its rays needs, read from the origin
/// columns alone.
fn stream_pad(stream: &RayStream<'_>) -> f32 {
    (0..stream.len()).fold(0.0f32, |m, i| m.max(ray_pad(stream.origin(i))))
}

/// Rays `0..active` of `stream` on one instance: transformed once into mesh-space lanes,
/// traced as one stream, their range ends copied back.
fn stream_instance<K: TriangleTest, V: Visitor>(
    scene: &Scene,
    instance: &Instance,
    stream: &mut RayStream<'_>,
    active: usize,
    scratch: &mut SceneScratch,
    visitor: &mut V,
) {
    let mesh = &scene.meshes[instance.mesh()];
    if instance.transform.is_identity() {
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
        inner,
        ..
    } = scratch;
    // Grow only: the lanes past the stream's end are never read, and shrinking would make the
    // next visit clear them again.
    if lanes.len() < active {
        lanes.reset(active);
    }
    outer.clear();
    for i in 0..active {
        let ray = stream.ray(i);
        if let Some(local) = instance.transform.prepared_to_mesh(&ray, ray.tmax) {
            lanes.set(outer.len(), &local, outer.len() as u32);
            outer.push((i as u32, stream.id(i)));
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
    with_renamed(Ids::Offset(instance.first_id), Some(outer), visitor, task);
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
        trace_one::<K, V>(self.scene, self.mask, ray, id, 0, scratch, visitor)
    }

    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) {
        trace_stream::<K, V>(self.scene, self.mask, stream, scratch, visitor)
    }
}

crate::query::compiled_queries!(SceneView<'_>);

/// The scene's queries are its view's on every layer ([`ALL_LAYERS`]).
impl RayQueries for Scene {
    #[cfg_attr(test, inline)]
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        self.filtered(ALL_LAYERS).cast_ray_with(ray, kernel)
    }
    #[cfg_attr(test, inline)]
    fn cast_ray_visits(&self, ray: &Ray, kernel: Kernel) -> (Option<Hit>, u32) {
        self.filtered(ALL_LAYERS).cast_ray_visits(ray, kernel)
    }
    #[cfg_attr(test, inline)]
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        self.filtered(ALL_LAYERS).occluded_with(ray, kernel)
    }
    #[cfg_attr(test, inline)]
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: &mut dyn FnMut(Hit)) {
        self.filtered(ALL_LAYERS).for_each_hit_with(ray, kernel, f)
    }
    fn visit<V: Visitor>(&self, ray: &Ray, kernel: Kernel, visitor: &mut V)
    where
        Self: Sized,
    {
        self.filtered(ALL_LAYERS).visit(ray, kernel, visitor)
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
        self.filtered(ALL_LAYERS)
            .cast_ray_batch_with(rays, hits, options)
    }
    #[cfg_attr(test, inline)]
    fn occluded_batch_with(
        &self,
        rays: &[Ray],
        occluded: &mut [bool],
        options: &BatchOptions,
    ) -> Result<(), BatchError> {
        self.filtered(ALL_LAYERS)
            .occluded_batch_with(rays, occluded, options)
    }
    #[cfg_attr(test, inline)]
    fn for_each_hit_batch_with(
        &self,
        rays: &[Ray],
        options: &BatchOptions,
        f: &(dyn Fn(usize, Hit) + Sync),
    ) {
        self.filtered(ALL_LAYERS)
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
