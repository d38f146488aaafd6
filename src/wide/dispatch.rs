//! The wide trees' loops (one ray, nodes shared, side by side) in their
//! baseline and AVX2 copies ([`crate::traverse::avx2`]).
//! With AVX2 (and the VEX encoding it brings) the box test and the triangle kernels need fewer
//! register copies; `wide::tests` compares the two copies.

use super::ray::BoxSimd;
use super::stack::Stack;
use super::{NodeKind, WideBvh, WideScratch};
use super::{interleaved, single, stream};
use crate::accel::RayStream;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::traverse::avx2::{self, Loop};

/// One ray through [`single::trace`], as a [`Loop`].
struct OneRay<'a, N: NodeKind, K, V> {
    tree: &'a WideBvh<N>,
    ray: &'a PreparedRay,
    id: u32,
    stack: &'a mut Stack,
    visitor: &'a mut V,
    /// Whether the 8-wide box test may use AVX2: false in the baseline copy.
    avx2: bool,
    /// Whether the loop prefetches the next pending child (`single::trace_from`).
    prefetch: bool,
    kernel: std::marker::PhantomData<K>,
}

impl<N: NodeKind, K: TriangleTest, V: Visitor> Loop for OneRay<'_, N, K, V> {
    type Output = f32;
    const AVX2: bool = !V::COUNTS_NODES;
    #[inline(always)]
    fn run(self) -> f32 {
        let OneRay { tree, ray, id, .. } = self;
        let simd = BoxSimd::detect(self.avx2);
        if self.prefetch {
            single::trace::<N, K, V, true>(tree, ray, id, self.stack, self.visitor, simd)
        } else {
            single::trace::<N, K, V, false>(tree, ray, id, self.stack, self.visitor, simd)
        }
    }
}

/// [`single::trace`], in the AVX2 copy if `avx2` and the CPU has it, else the baseline copy;
/// prefetching pending children if `prefetch`.
#[inline]
pub(crate) fn trace<N: NodeKind, K: TriangleTest, V: Visitor>(
    (avx2, prefetch): (bool, bool),
    tree: &WideBvh<N>,
    ray: &PreparedRay,
    id: u32,
    stack: &mut Stack,
    visitor: &mut V,
) -> f32 {
    let one = OneRay::<N, K, V> {
        tree,
        ray,
        id,
        stack,
        visitor,
        avx2,
        prefetch,
        kernel: std::marker::PhantomData,
    };
    avx2::run(one, avx2)
}

/// Every ray of a stream through the one-ray loop, side by side
/// ([`interleaved::trace_stream`]), as a [`Loop`].
struct Rays<'a, 's, N: NodeKind, K, V> {
    tree: &'a WideBvh<N>,
    stream: &'a mut RayStream<'s>,
    scratch: &'a mut WideScratch,
    visitor: &'a mut V,
    /// Whether the 8-wide box test may use AVX2: false in the baseline copy.
    avx2: bool,
    kernel: std::marker::PhantomData<K>,
}

impl<N: NodeKind, K: TriangleTest, V: Visitor> Loop for Rays<'_, '_, N, K, V> {
    type Output = ();
    const AVX2: bool = true;
    #[inline(always)]
    fn run(self) {
        let Rays {
            tree,
            stream,
            scratch,
            visitor,
            ..
        } = self;
        let simd = BoxSimd::detect(self.avx2);
        interleaved::trace_stream::<N, K, V>(tree, stream, &mut scratch.stacks, visitor, simd)
    }
}

/// Every ray of `stream` through the one-ray loop, side by side, in the AVX2 copy if `avx2`
/// and the CPU has it.
#[inline]
pub(crate) fn trace_side_by_side<N: NodeKind, K: TriangleTest, V: Visitor>(
    avx2: bool,
    tree: &WideBvh<N>,
    stream: &mut RayStream<'_>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    let task = Rays::<N, K, V> {
        tree,
        stream,
        scratch,
        visitor,
        avx2,
        kernel: std::marker::PhantomData,
    };
    avx2::run(task, avx2)
}

/// A stream through [`stream::trace_stream`] (nodes shared by the rays that reach them), as a
/// [`Loop`].
struct Shared<'a, 's, N: NodeKind, K, V> {
    tree: &'a WideBvh<N>,
    stream: &'a mut RayStream<'s>,
    scratch: &'a mut WideScratch,
    visitor: &'a mut V,
    kernel: std::marker::PhantomData<K>,
}

impl<N: NodeKind, K: TriangleTest, V: Visitor> Loop for Shared<'_, '_, N, K, V> {
    type Output = ();
    const AVX2: bool = true;
    #[inline(always)]
    fn run(self) {
        stream::trace_stream::<N, K, V>(self.tree, self.stream, self.scratch, self.visitor)
    }
}

/// [`stream::trace_stream`], in the AVX2 copy if `avx2` and the CPU has it.
#[inline]
pub(crate) fn trace_shared<N: NodeKind, K: TriangleTest, V: Visitor>(
    avx2: bool,
    tree: &WideBvh<N>,
    stream: &mut RayStream<'_>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    let task = Shared::<N, K, V> {
        tree,
        stream,
        scratch,
        visitor,
        kernel: std::marker::PhantomData,
    };
    avx2::run(task, avx2)
}
