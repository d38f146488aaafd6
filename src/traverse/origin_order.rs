//! A stream's rays walked one at a time in Morton order of their origins.
//!
//! Structures that walk each ray alone (the grids, the kd-tree) share no work between the rays
//! of a batch, but rays that start near each other read the same cells or nodes, references,
//! triangles and vertices. Taken in the caller's order, incoherent rays on a large mesh miss
//! the caches at every step; taken in Morton order of their origins (quantized to 2^10 steps
//! per axis within the structure's bounds), each neighbourhood's first ray pulls in what the
//! next ones read. The walk itself is the one-ray walk, so the answers are the per-ray answers
//! (a ray's answer does not depend on the order rays are taken in).
//!
//! On the 1M-triangle terrain the grid's short rays run about 1.3x as fast in origin order as
//! in the caller's order (docs/benchmarks.md); camera rays, which share one origin, have
//! nothing to gain. The sort costs a few percent of a walk.
//!
//! Taken in that order, the rays' own records are read out of order: a profile of the grid's
//! batched short rays (`perf record`) put a fifth of the time on loading them, so the record of
//! the ray [`PREFETCH_AHEAD`] places on is prefetched.

use crate::accel::{Accel, Footprint, RayStream};
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::mesh::Mesh;

/// Below this many bytes of structure and mesh, the rays are walked in the stream's order: the
/// walks stay in cache anyway, and the sort and the scattered ray reads only cost (bunny, city
/// and a sparse world of 96,000 triangles, all under 16 MiB: 0.68-0.95x sorted against the
/// stream's order). The same threshold as the 4-wide tree's side-by-side walks, for the same reason.
pub(crate) const SORT_ABOVE_BYTES: usize = 16 << 20;

/// Rays taken in origin order are read out of the stream's order, each a cache miss (a fifth
/// of the grid's batched time on the terrain's short rays, `perf`): the record of the ray this
/// many places ahead in the order is prefetched.
const PREFETCH_AHEAD: usize = 8;

/// Quantization steps per axis: 10 bits, so that three interleave into 30 and the ray's index
/// fits beside them in one `u64` key (sorting plain integers is the cheapest sort).
const BITS: u32 = 10;

/// A structure's per-thread scratch that holds an [`OriginOrder`] beside what its walk needs.
pub(crate) trait WithOriginOrder {
    /// The order.
    fn origin_order(&mut self) -> &mut OriginOrder;
}

/// `Accel::trace_stream` for a structure that walks each ray alone (`accel.trace`), over
/// `mesh` within `bounds`: in origin order once structure and mesh pass [`SORT_ABOVE_BYTES`],
/// in the stream's order below.
pub(crate) fn trace_stream<A, K, V>(
    accel: &A,
    (bounds, mesh): (&Aabb, &Mesh),
    stream: &mut RayStream<'_>,
    scratch: &mut A::Scratch,
    visitor: &mut V,
) where
    A: Accel + Footprint,
    A::Scratch: WithOriginOrder,
    K: TriangleTest,
    V: Visitor,
{
    let working_set = accel.heap_bytes() + mesh.heap_bytes();
    // Taken out while the walks borrow the whole scratch, then put back (an empty order holds
    // no allocation).
    let mut order = std::mem::take(scratch.origin_order());
    order.trace((bounds, working_set), stream, |ray, id| {
        accel.trace::<K, V>(ray, id, scratch, visitor)
    });
    *scratch.origin_order() = order;
}

/// The per-thread scratch of [`OriginOrder::trace`]: the sort keys of the last stream.
#[derive(Debug, Default)]
pub(crate) struct OriginOrder {
    keys: Vec<u64>,
}

impl OriginOrder {
    /// Runs `trace(ray, id)` (which returns the ray's final range end) for every ray of
    /// `stream` and stores each final range end in the stream: in Morton order of their
    /// origins within `bounds` (origins outside are clamped to it) when the walks read more
    /// than [`SORT_ABOVE_BYTES`] (`working_set`), in the stream's order otherwise.
    pub(crate) fn trace(
        &mut self,
        place: (&Aabb, usize),
        stream: &mut RayStream<'_>,
        mut trace: impl FnMut(&PreparedRay, u32) -> f32,
    ) {
        let order = self.order(place, stream);
        let mut ahead = order.clone().skip(PREFETCH_AHEAD);
        for i in order {
            if let Some(later) = ahead.next() {
                stream.prefetch_ray(later);
            }
            let ray = stream.ray(i);
            let tmax = trace(&ray, stream.id(i));
            stream.set_tmax(i, tmax);
        }
    }

    /// The indices of the rays of `stream` in the order [`OriginOrder::trace`] takes them:
    /// Morton order of their origins within `bounds` when the walks read more than
    /// [`SORT_ABOVE_BYTES`] (`working_set`), the stream's order otherwise.
    fn order(
        &mut self,
        (bounds, working_set): (&Aabb, usize),
        stream: &RayStream<'_>,
    ) -> impl Iterator<Item = usize> + Clone + use<'_> {
        let (stream_order, sorted) = if working_set <= SORT_ABOVE_BYTES {
            (0..stream.len(), &[][..])
        } else {
            (0..0, self.sorted(bounds, stream))
        };
        stream_order.chain(sorted.iter().map(|&key| key as u32 as usize))
    }

    /// The rays of `stream` in Morton order of their origins within `bounds`: keys whose low 32
    /// bits are the rays' indices in the stream.
    fn sorted(&mut self, bounds: &Aabb, stream: &RayStream<'_>) -> &[u64] {
        let steps = (1u32 << BITS) as f32;
        let extent = bounds.max - bounds.min;
        let scale = extent.map(|e| if e > 0.0 { steps / e } else { 0.0 });
        self.keys.clear();
        self.keys.extend((0..stream.len()).map(|i| {
            let at = (stream.ray(i).origin - bounds.min) * scale;
            morton(at.to_array().map(quantize)) << 32 | i as u64
        }));
        self.keys.sort_unstable();
        &self.keys
    }
}

/// A coordinate in steps, clamped to `0..2^BITS` (`as` saturates, and maps NaN to 0).
fn quantize(steps: f32) -> u32 {
    (steps as u32).min((1 << BITS) - 1)
}

/// The bits of three 10-bit coordinates interleaved: bit `k` of axis `a` goes to bit `3k + a`.
fn morton(cell: [u32; 3]) -> u64 {
    let spread = |v: u32| {
        let mut x = u64::from(v) & 0x3ff;
        x = (x | x << 16) & 0x0300_00ff;
        x = (x | x << 8) & 0x0300_f00f;
        x = (x | x << 4) & 0x030c_30c3;
        (x | x << 2) & 0x0924_9249
    };
    spread(cell[0]) | spread(cell[1]) << 1 | spread(cell[2]) << 2
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::accel::Storage;
    use crate::batch::options::BatchOptions;
    use crate::batch::partition::PartitionKernel;
    use crate::batch::rays::PreparedRays;
    use crate::geom::Ray;
    use crate::test_support::TestRng;

    /// Walks rays `2..n - 3` of `n` records (origins in and around `bounds`, ids `1000 + slot`)
    /// with a working set of `bytes`; returns the order the ids were walked in and the records.
    fn walk(n: usize, bounds: &Aabb, bytes: usize) -> (Vec<u32>, PreparedRays) {
        let mut records = PreparedRays::default();
        records.reserve_slots(n);
        let mut rng = TestRng::new(n as u64);
        for slot in 0..n {
            let origin = rng.vec3(3.0);
            let ray = PreparedRay::new(&Ray::new(origin, rng.vec3(1.0) + Vec3::X * 2.0));
            records.set(slot, ray.expect("a valid ray"), 1000 + slot as u32);
        }
        let options = BatchOptions::default();
        let partitioner = PartitionKernel::Portable.checked();
        let storage = Storage::Records(&mut records);
        let mut stream = RayStream::new(storage, 2, n - 3, 0, partitioner, &options);
        let mut walked = Vec::new();
        OriginOrder::default().trace((bounds, bytes), &mut stream, |ray, id| {
            walked.push(id);
            ray.origin.x + id as f32
        });
        (walked, records)
    }

    /// Above the threshold every ray of the stream is walked once, in Morton order of its
    /// origin, and its range end lands in its own record; below it, in the stream's order.
    #[test]
    fn walks_every_ray_once_in_origin_order() {
        let bounds = Aabb::new(Vec3::splat(-2.0), Vec3::new(2.0, 1.0, 2.5));
        let n = 500;
        let (walked, records) = walk(n, &bounds, SORT_ABOVE_BYTES + 1);
        let mut sorted = walked.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (1002..1000 + n as u32 - 3).collect::<Vec<_>>());
        let code = |id: u32| {
            let origin = records.rays[id as usize - 1000].origin;
            let at = (origin - bounds.min) * ((1 << BITS) as f32 / (bounds.max - bounds.min));
            morton(at.to_array().map(quantize))
        };
        assert!(walked.windows(2).all(|w| code(w[0]) <= code(w[1])));
        assert!(walked.windows(2).any(|w| w[0] > w[1]), "the order changed");
        for &id in &walked {
            let record = &records.rays[id as usize - 1000];
            assert_eq!(record.tmax, record.origin.x + id as f32);
        }
        let (walked, _) = walk(n, &bounds, SORT_ABOVE_BYTES);
        assert_eq!(walked, (1002..1000 + n as u32 - 3).collect::<Vec<_>>());
    }

    /// Against a bit-by-bit interleave, on edge values and a spread of others.
    #[test]
    fn morton_interleaves_bits() {
        let slow = |cell: [u32; 3]| {
            (0..3 * BITS as usize).fold(0u64, |code, bit| {
                code | u64::from(cell[bit % 3] >> (bit / 3) & 1) << bit
            })
        };
        let values = [0, 1, 2, 3, 0x155, 0x2aa, 0x3ff, 617, 1 << 9];
        for &x in &values {
            for &y in &values {
                for &z in &values {
                    assert_eq!(morton([x, y, z]), slow([x, y, z]), "{x} {y} {z}");
                }
            }
        }
    }

    /// Steps are clamped into the grid, NaN goes to 0.
    #[test]
    fn quantize_clamps() {
        assert_eq!(quantize(-3.0), 0);
        assert_eq!(quantize(f32::NAN), 0);
        assert_eq!(quantize(2.5), 2);
        assert_eq!(quantize(1024.0), 1023);
        assert_eq!(quantize(f32::INFINITY), 1023);
    }
}
