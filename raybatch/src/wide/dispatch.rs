//! The 4-wide one-ray loop in its baseline and AVX2 copies ([`crate::traverse::avx2`]).
//! With AVX2 (and the VEX encoding it brings) the box test and the triangle kernels need fewer
//! register copies; `wide::tests` compares the two copies.

use super::WideTree;
use super::{interleaved, single};
use crate::accel::RayStream;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::traverse::avx2::{self, Loop};

/// One ray through [`single::trace`], as a [`Loop`].
struct OneRay<'a, K, V> {
    tree: &'a WideTree,
    ray: &'a PreparedRay,
    id: u32,
    stack: &'a mut Vec<(u32, f32)>,
    visitor: &'a mut V,
    kernel: std::marker::PhantomData<K>,
}

impl<K: TriangleTest, V: Visitor> Loop for OneRay<'_, K, V> {
    type Output = f32;
    #[inline(always)]
    fn run(self) -> f32 {
        single::trace::<K, V>(self.tree, self.ray, self.id, self.stack, self.visitor)
    }
}

/// [`single::trace`], in the AVX2 copy if `avx2` and the CPU has it, else the baseline copy.
#[inline]
pub(crate) fn trace<K: TriangleTest, V: Visitor>(
    avx2: bool,
    tree: &WideTree,
    ray: &PreparedRay,
    id: u32,
    stack: &mut Vec<(u32, f32)>,
    visitor: &mut V,
) -> f32 {
    let one = OneRay::<K, V> {
        tree,
        ray,
        id,
        stack,
        visitor,
        kernel: std::marker::PhantomData,
    };
    avx2::run(one, avx2)
}

/// A stream through [`interleaved::trace_stream`], as a [`Loop`].
struct Interleaved<'a, 's, K, V> {
    tree: &'a WideTree,
    stream: &'a mut RayStream<'s>,
    stacks: &'a mut [Vec<(u32, f32)>; interleaved::LANES],
    visitor: &'a mut V,
    kernel: std::marker::PhantomData<K>,
}

impl<K: TriangleTest, V: Visitor> Loop for Interleaved<'_, '_, K, V> {
    type Output = ();
    #[inline(always)]
    fn run(self) {
        interleaved::trace_stream::<K, V>(self.tree, self.stream, self.stacks, self.visitor)
    }
}

/// [`interleaved::trace_stream`], in the AVX2 copy if `avx2` and the CPU has it.
#[inline]
pub(crate) fn trace_interleaved<K: TriangleTest, V: Visitor>(
    avx2: bool,
    tree: &WideTree,
    stream: &mut RayStream<'_>,
    stacks: &mut [Vec<(u32, f32)>; interleaved::LANES],
    visitor: &mut V,
) {
    let task = Interleaved::<K, V> {
        tree,
        stream,
        stacks,
        visitor,
        kernel: std::marker::PhantomData,
    };
    avx2::run(task, avx2)
}
