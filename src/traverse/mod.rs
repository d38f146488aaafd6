//! The engines that walk a binary BVH, written once against [`Bvh`], which make every `Bvh` an
//! [`Accel`]:
//!
//! - `single`: one ray at a time, depth first, nearer child first (the reference);
//! - `avx2`: running a loop in a copy compiled with AVX2, picked at run time (the only
//!   `unsafe` of the traversals);
//! - `dispatch`: the one-ray loop through it;
//! - `stack`: the one-ray loop's stack, the thread's `Vec` or a fixed array on the call stack
//!   (with the traversals' other `unsafe`, one read of a slot it wrote);
//! - `stream`: a stream of rays going down the tree once, partitioned at each node.
//!
//! Beside them, `origin_order`: the stream engine of the structures that walk each ray alone
//! (grids, kd-tree), a stream's rays taken one at a time in Morton order of their origins.

#[allow(unsafe_code)]
pub(crate) mod avx2;
pub(crate) mod dispatch;
pub(crate) mod origin_order;
#[cfg(target_arch = "x86_64")]
pub(crate) mod packet;
pub(crate) mod single;
// One unsafe read, of a slot the stack wrote (see `FixedStack::pop`).
#[allow(unsafe_code)]
pub(crate) mod stack;
pub(crate) mod stream;

use crate::accel::{Accel, RayStream, StreamLayout, trace_with_workspace};
use crate::bvh::build::MAX_DEPTH;
use crate::bvh::{Bvh, BvhScratch};
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::hit::Visitor;
use single::Pending;
use stack::FixedStack;

impl<B: Bvh> Accel for B {
    type Scratch = BvhScratch<B::Cache, B::NodeBox>;
    // The stream engine partitions the rays at every node (`RayStream::partition`).
    const STREAM_LAYOUT: StreamLayout = StreamLayout::Lanes;

    /// The root box, which the one-ray loop tests first (`traverse::single::trace`).
    fn cull_bounds(&self) -> Option<Aabb> {
        if self.is_empty() {
            return None;
        }
        self.root_bounds_uncached()
    }

    #[inline]
    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) -> f32 {
        let BvhScratch { stack, cache, .. } = scratch;
        dispatch::trace::<B, K, V, _>(B::AVX2_TRAVERSAL, self, ray, id, (stack, cache), visitor)
    }

    /// The one-ray loop with a stack of its own on the call stack (made without writing to
    /// it, see `traverse::stack::FixedStack`), not the workspace's, for trees whose boxes
    /// need no cache (an empty one is as good as the thread's) and whose paths fit the stack
    /// (every tree the builders make). The zero-byte trees, whose box cache only pays if it
    /// outlives the ray, and a deeper tree take the thread's scratch.
    #[inline(always)]
    fn trace_alone<K: TriangleTest, V: Visitor>(&self, ray: &PreparedRay, visitor: &mut V) {
        if size_of::<B::Cache>() != 0 || self.depth() > MAX_DEPTH {
            return trace_with_workspace::<Self, K, V>(self, ray, visitor);
        }
        let mut stack = FixedStack::<Pending<B>, MAX_DEPTH>::new();
        let memory = (&mut stack, &mut B::Cache::default());
        dispatch::trace::<B, K, V, _>(B::AVX2_TRAVERSAL, self, ray, 0, memory, visitor);
    }

    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut Self::Scratch,
        visitor: &mut V,
    ) {
        stream::trace_stream::<B, K, V>(self, stream, scratch, visitor)
    }
}
