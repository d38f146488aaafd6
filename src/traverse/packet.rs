//! Finishing a subtree for the few rays (fewer than eight) a stream brings to it, together: the
//! packet walk, on x86-64 CPUs with AVX2.
//!
//! Below `BatchOptions::single_ray_below` rays the stream's partitions cost more than they
//! share, and the one-ray loop would finish each ray alone, reading every node of the subtree
//! again for each of them: its triangles (tested by the scalar kernel) and, for the zero-byte
//! tree, its children's boxes (recomputed from triangles, or looked up in the box cache). The
//! packet walk reads each node once for all of the rays, held in eight lanes with a bit mask of
//! the ones that reach the node: the children's boxes are tested against the eight lanes at once
//! ([`BoxOctet`]), the node's triangles go through the eight-ray sign filter ([`RayOctet`]) and
//! the scalar kernel runs only where a hit is possible, for each ray with its own range end.
//!
//! Depth first like the one-ray loop, nearer child first by the stream's octant; a pending node
//! keeps its lanes and their entry distances, and a pop drops the lanes whose best hit has
//! moved in front of it (the one-ray loop's `entry <= tmax`). A lane is in a node's mask only
//! if the one-ray loop would visit that node for that ray (or a node it would visit anyway,
//! when the order differs), and the kernel and visitor are the one-ray loop's: answers do not
//! depend on the visiting order, so they are the one-ray loop's bit for bit.

use super::single::test_triangles;
use crate::accel::RayStream;
use crate::bvh::ordering::second_child_first;
use crate::bvh::{Bvh, BvhScratch};
use crate::geom::TriangleTest;
use crate::geom::box_octet::Entries;
use crate::hit::Visitor;
use crate::x86::Avx2;

/// Finishes the subtree under node `start` (whose box rays `0..active` of the stream touch,
/// `active <= 8`) for those rays, together (see the module docs). Returns false, doing
/// nothing, if the stream is not in lanes.
#[inline(always)]
pub(crate) fn finish<B, K, V>(
    avx2: Avx2,
    tree: &B,
    stream: &mut RayStream<'_>,
    active: usize,
    start: (u32, B::NodeBox),
    scratch: &mut BvhScratch<B::Cache, B::NodeBox>,
    visitor: &mut V,
) -> bool
where
    B: Bvh,
    K: TriangleTest,
    V: Visitor,
{
    let Some(block) = stream.block(active) else {
        return false;
    };
    let octet = block.octet(avx2);
    let boxes = block.boxes(avx2);
    let ids = block.ids();
    let mut tmax = block.tmax();
    let octant_mask = match stream.octant_mask() {
        0 => block.ray(0).octant_mask,
        mask => mask,
    };
    // Lanes not finished by the visitor (an any-hit query ends a ray at its first hit).
    let mut live = (1u32 << active) - 1;
    let BvhScratch {
        packet_stack: stack,
        cache,
        ..
    } = scratch;
    stack.clear();
    let (mut index, mut node_box) = start;
    let mut lanes = live;
    'walk: loop {
        // What the one-ray loop reports for each ray that enters the node.
        let mut entering = lanes;
        while entering != 0 {
            visitor.enter_node(ids[entering.trailing_zeros() as usize]);
            entering &= entering - 1;
        }
        let node = tree.node(index);
        for slot in node.first..node.first + node.count {
            let triangle = tree.triangle(slot);
            let mut kept = if K::SIGN_FILTER {
                octet.may_hit(avx2, &triangle.1) & lanes
            } else {
                lanes
            };
            while kept != 0 {
                let lane = kept.trailing_zeros() as usize;
                kept &= kept - 1;
                let ray = block.ray(lane);
                let once = std::iter::once(triangle);
                if test_triangles::<K, V>(&ray, ids[lane], once, &mut tmax[lane], visitor) {
                    live &= !(1 << lane);
                    lanes &= !(1 << lane);
                }
            }
        }
        if node.has_children() && lanes != 0 {
            let [a, b] = node.children;
            let [first_box, second_box] = tree.child_bounds(&node, &node_box, cache);
            let ((near, near_box), (far, far_box)) = if second_child_first(node.order, octant_mask)
            {
                ((b, second_box), (a, first_box))
            } else {
                ((a, first_box), (b, second_box))
            };
            let near_entries = boxes.entries(avx2, near_box.min, near_box.max, &tmax);
            let far_entries = boxes.entries(avx2, far_box.min, far_box.max, &tmax);
            let near_lanes = near_entries.touched(avx2) & lanes;
            let far_lanes = far_entries.touched(avx2) & lanes;
            if far_lanes != 0 {
                if near_lanes != 0 {
                    let entries = far_entries.to_array(avx2);
                    stack.push((far, far_lanes, entries, B::keep(&far_box)));
                    (index, node_box, lanes) = (near, B::keep(&near_box), near_lanes);
                } else {
                    (index, node_box, lanes) = (far, B::keep(&far_box), far_lanes);
                }
                continue;
            }
            if near_lanes != 0 {
                (index, node_box, lanes) = (near, B::keep(&near_box), near_lanes);
                continue;
            }
        }
        // Pop the next pending node that some lane still enters before its best hit.
        loop {
            let Some((pending, pending_lanes, entries, pending_box)) = stack.pop() else {
                break 'walk;
            };
            let entries = Entries::from_array(avx2, &entries);
            let still = pending_lanes & live & entries.within(avx2, &tmax);
            if still != 0 {
                (index, node_box, lanes) = (pending, pending_box, still);
                break;
            }
        }
    }
    for (i, &t) in tmax.iter().enumerate().take(active) {
        stream.set_tmax(i, t);
    }
    true
}
