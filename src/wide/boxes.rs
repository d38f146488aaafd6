//! The wide trees' walk for the shape queries: every child whose box the query may touch is
//! entered, in no particular order (see [`crate::shape`]).

use super::{NodeKind, WideBvh};
use crate::bvh::build::MAX_DEPTH;
use crate::bvh::nodes::leaf_word;
use crate::shape::{BoxQuery, push_order};

/// Pending children: a pop pushes at most a node's width, and a path is at most
/// [`MAX_DEPTH`] nodes long.
const STACK: usize = 8 * (MAX_DEPTH + 1);

impl<N: NodeKind> WideBvh<N> {
    /// Offers `query` every triangle of a leaf whose box, and whose ancestors' boxes, it
    /// enters, each triangle once, until it asks to stop.
    pub(crate) fn walk_boxes<Q: BoxQuery>(&self, query: &mut Q) {
        if self.is_empty() {
            return;
        }
        let Some(entry) = query.entry(&self.root_bounds) else {
            return;
        };
        let mut stack = [(0u32, 0.0f64); STACK];
        let mut len = 1;
        stack[0] = (self.root, entry);
        while len > 0 {
            len -= 1;
            let (item, entry) = stack[len];
            if !query.still_reaches(entry) {
                continue;
            }
            if leaf_word::is_leaf(item) {
                let (_, count) = leaf_word::unpack(item);
                for k in 0..count {
                    let (id, corners) = self.triangle(item, k);
                    if query.triangle(id, &corners) {
                        return;
                    }
                }
                continue;
            }
            let node = &self.nodes[item as usize];
            let mut entered = [(0u32, 0.0f64); 8];
            let mut count = 0;
            for slot in 0..node.used_slots() {
                if let Some(entry) = query.entry(&node.child_bounds(slot)) {
                    entered[count] = (node.child(slot), entry);
                    count += 1;
                }
            }
            push_order::<_, Q>(&mut entered[..count]);
            stack[len..len + count].copy_from_slice(&entered[..count]);
            len += count;
        }
    }
}
