//! [`Permuted`]: a structure that reordered the mesh's triangles (the zero-byte trees),
//! answering in the original triangle ids.
//!
//! The zero-byte trees hand the permutation to their caller instead of keeping it (it would cost
//! 4 bytes per triangle). Where answers must be in the original ids anyway (the catalog, so
//! that every structure answers alike; tools that write hit files), this adapter keeps it and
//! maps each hit's id *before* the query's visitor sees it (through [`crate::hit::Renamed`], so
//! the wrapped walks are compiled once per kind of visitor, not once per query). The tie rule (lowest id on equal
//! `t`) is then applied to the original ids, so closest hits equal those of any other
//! structure over the original mesh, ties included.

use std::marker::PhantomData;
use std::sync::OnceLock;

use crate::accel::{Accel, Corners, Footprint, RayStream, StreamLayout};
use crate::geom::{PreparedRay, Ray, TriangleTest};
use crate::hit::{Ids, RenamedTask, Visitor, with_renamed};

/// A structure over a reordered mesh and the permutation back to the original ids.
#[derive(Debug)]
pub struct Permuted<A> {
    inner: A,
    to_original: Vec<u32>,
    /// The inverse permutation, made the first time a hit's corners are asked for (scenes
    /// giving hits their normals), so that trees never asked pay nothing; from then on it
    /// counts in `id_map_bytes`.
    to_inner: OnceLock<Vec<u32>>,
}

impl<A: Footprint> Permuted<A> {
    /// Wraps `inner`, whose triangle `i` is triangle `to_original[i]` of the original mesh.
    /// Panics if the permutation does not cover the structure's triangles (a caller bug: both
    /// come from the same build).
    pub fn new(inner: A, to_original: Vec<u32>) -> Self {
        assert_eq!(inner.triangle_count(), to_original.len());
        Self {
            inner,
            to_original,
            to_inner: OnceLock::new(),
        }
    }
}

/// One ray through the wrapped structure ([`Accel::trace`]).
struct Ray1<'a, A: Accel, K> {
    inner: &'a A,
    ray: &'a PreparedRay,
    id: u32,
    scratch: &'a mut A::Scratch,
    kernel: PhantomData<K>,
}

impl<A: Accel, K: TriangleTest> RenamedTask for Ray1<'_, A, K> {
    type Output = f32;
    #[inline(always)]
    fn run<W: Visitor>(self, visitor: &mut W) -> f32 {
        self.inner
            .trace::<K, W>(self.ray, self.id, self.scratch, visitor)
    }
}

/// A stream through the wrapped structure ([`Accel::trace_stream`]).
struct Stream<'a, 's, A: Accel, K> {
    inner: &'a A,
    stream: &'a mut RayStream<'s>,
    scratch: &'a mut A::Scratch,
    kernel: PhantomData<K>,
}

impl<A: Accel, K: TriangleTest> RenamedTask for Stream<'_, '_, A, K> {
    type Output = ();
    fn run<W: Visitor>(self, visitor: &mut W) {
        self.inner
            .trace_stream::<K, W>(self.stream, self.scratch, visitor)
    }
}

impl<A: Accel> Accel for Permuted<A> {
    type Scratch = A::Scratch;
    const STREAM_LAYOUT: StreamLayout = A::STREAM_LAYOUT;
    const GROUP_BY_OCTANT: bool = A::GROUP_BY_OCTANT;
    const MIXES_SMALL_OCTANTS: bool = A::MIXES_SMALL_OCTANTS;
    const DEFAULT_MAX_CHUNK: usize = A::DEFAULT_MAX_CHUNK;

    fn max_chunk(&self, rays: &[Ray]) -> usize {
        self.inner.max_chunk(rays)
    }

    #[inline]
    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) -> f32 {
        let task = Ray1::<A, K> {
            inner: &self.inner,
            ray,
            id,
            scratch,
            kernel: PhantomData,
        };
        with_renamed(Ids::Table(&self.to_original), None, visitor, task)
    }

    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) {
        let task = Stream::<A, K> {
            inner: &self.inner,
            stream,
            scratch,
            kernel: PhantomData,
        };
        with_renamed(Ids::Table(&self.to_original), None, visitor, task)
    }
}

impl<A: Corners> Corners for Permuted<A> {
    fn corners(&self, id: u32) -> [glam::Vec3; 3] {
        let to_inner = self.to_inner.get_or_init(|| {
            let mut to_inner = vec![0; self.to_original.len()];
            for (inner, &original) in self.to_original.iter().enumerate() {
                to_inner[original as usize] = inner as u32;
            }
            to_inner
        });
        self.inner.corners(to_inner[id as usize])
    }
}

impl<A: Footprint> Footprint for Permuted<A> {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn triangle_count(&self) -> usize {
        self.inner.triangle_count()
    }
    fn node_count(&self) -> usize {
        self.inner.node_count()
    }
    fn heap_bytes(&self) -> usize {
        self.inner.heap_bytes()
    }
    fn id_map_bytes(&self) -> usize {
        let inverse = self.to_inner.get().map_or(0, Vec::len);
        self.inner.id_map_bytes() + (self.to_original.len() + inverse) * size_of::<u32>()
    }
}
