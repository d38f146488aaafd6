//! The wide trees' loops (one ray, rays one at a time, nodes shared, side by side) in their
//! baseline and AVX2 copies ([`crate::traverse::avx2`]).
//! With AVX2 (and the VEX encoding it brings) the box test and the triangle kernels need fewer
//! register copies; `wide::tests` compares the two copies.

use super::node::BoxSimd;
use super::stack::Stack;
use super::{NodeKind, WideBvh, WideScratch, WideTree};
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
    kernel: std::marker::PhantomData<K>,
}

impl<N: NodeKind, K: TriangleTest, V: Visitor> Loop for OneRay<'_, N, K, V> {
    type Output = f32;
    #[inline(always)]
    fn run(self) -> f32 {
        let OneRay { tree, ray, id, .. } = self;
        let simd = BoxSimd::detect(self.avx2);
        single::trace::<N, K, V>(tree, ray, id, self.stack, self.visitor, simd)
    }
}

/// [`single::trace`], in the AVX2 copy if `avx2` and the CPU has it, else the baseline copy.
#[inline]
pub(crate) fn trace<N: NodeKind, K: TriangleTest, V: Visitor>(
    avx2: bool,
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
        kernel: std::marker::PhantomData,
    };
    avx2::run(one, avx2)
}

/// How a stream's rays go through the one-ray loop.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Walk {
    /// One ray after the other ([`single::trace`]).
    OneAtATime,
    /// Several at once, taking turns ([`interleaved::trace_stream`]).
    SideBySide,
}

/// Every ray of a stream through the one-ray loop, walked as `walk` says, as a [`Loop`].
struct Rays<'a, 's, N: NodeKind, K, V> {
    tree: &'a WideBvh<N>,
    stream: &'a mut RayStream<'s>,
    scratch: &'a mut WideScratch,
    visitor: &'a mut V,
    walk: Walk,
    /// Whether the 8-wide box test may use AVX2: false in the baseline copy.
    avx2: bool,
    kernel: std::marker::PhantomData<K>,
}

impl<N: NodeKind, K: TriangleTest, V: Visitor> Loop for Rays<'_, '_, N, K, V> {
    type Output = ();
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
        match self.walk {
            Walk::OneAtATime => {
                for i in 0..stream.len() {
                    let (ray, id) = (stream.ray(i), stream.id(i));
                    let stack = &mut scratch.stack;
                    let tmax = single::trace::<N, K, V>(tree, &ray, id, stack, visitor, simd);
                    stream.set_tmax(i, tmax);
                }
            }
            Walk::SideBySide => interleaved::trace_stream::<N, K, V>(
                tree,
                stream,
                &mut scratch.stacks,
                visitor,
                simd,
            ),
        }
    }
}

/// Every ray of `stream` through the one-ray loop, walked as `walk` says, in the AVX2 copy if
/// `avx2` and the CPU has it.
#[inline]
pub(crate) fn trace_rays<N: NodeKind, K: TriangleTest, V: Visitor>(
    (avx2, walk): (bool, Walk),
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
        walk,
        avx2,
        kernel: std::marker::PhantomData,
    };
    avx2::run(task, avx2)
}

/// A stream through [`stream::trace_stream`] (nodes shared by the rays that reach them), as a
/// [`Loop`].
struct Shared<'a, 's, K, V> {
    tree: &'a WideTree,
    stream: &'a mut RayStream<'s>,
    scratch: &'a mut WideScratch,
    visitor: &'a mut V,
    kernel: std::marker::PhantomData<K>,
}

impl<K: TriangleTest, V: Visitor> Loop for Shared<'_, '_, K, V> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        stream::trace_stream::<K, V>(self.tree, self.stream, self.scratch, self.visitor)
    }
}

/// [`stream::trace_stream`], in the AVX2 copy if `avx2` and the CPU has it.
#[inline]
pub(crate) fn trace_shared<K: TriangleTest, V: Visitor>(
    avx2: bool,
    tree: &WideTree,
    stream: &mut RayStream<'_>,
    scratch: &mut WideScratch,
    visitor: &mut V,
) {
    let task = Shared::<K, V> {
        tree,
        stream,
        scratch,
        visitor,
        kernel: std::marker::PhantomData,
    };
    avx2::run(task, avx2)
}
