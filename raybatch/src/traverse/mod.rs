//! The two traversals of a binary BVH, written once against [`Bvh`], which make every `Bvh` an
//! [`Accel`]:
//!
//! - `single`: one ray at a time, depth first, nearer child first (the reference);
//! - `avx2`: running a loop in a copy compiled with AVX2, picked at run time (the only
//!   `unsafe` of the traversals);
//! - `dispatch`: the one-ray loop through it;
//! - `stream`: a stream of rays going down the tree once, partitioned at each node (seed 001).

#[allow(unsafe_code)]
pub(crate) mod avx2;
pub(crate) mod dispatch;
#[cfg(target_arch = "x86_64")]
pub(crate) mod packet;
pub(crate) mod single;
pub(crate) mod stream;

use crate::accel::{Accel, RayStream, StreamLayout};
use crate::bvh::{Bvh, BvhScratch};
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::hit::Visitor;

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
        dispatch::trace::<B, K, V>(self, ray, id, scratch, visitor)
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
