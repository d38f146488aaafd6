//! The wide trees' walk for the shape queries: every child whose box the query may touch is
//! entered, nearest first for the sweeps (see [`crate::shape`]).

use super::{NodeKind, WideBvh};
use crate::bvh::nodes::leaf_word;
use crate::shape::{BoxQuery, push_order};
use crate::workspace::Workspace;

/// The walk's pending children (word, entry time), kept per thread: a stack sized for the
/// deepest tree would be cleared on every query, costing a sphere overlap a third of its time.
#[derive(Default)]
struct Pending(Vec<(u32, f64)>);

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
        Workspace::with_local(|workspace| {
            let stack = &mut workspace.scratch::<Pending>().0;
            stack.clear();
            stack.push((self.root, entry));
            self.walk_from(stack, query);
        });
    }

    /// Walks the pending children on `stack` until none are left or the query stops.
    fn walk_from<Q: BoxQuery>(&self, stack: &mut Vec<(u32, f64)>, query: &mut Q) {
        while let Some((item, entry)) = stack.pop() {
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
            let first = stack.len();
            for slot in 0..node.used_slots() {
                if let Some(entry) = query.entry(&node.child_bounds(slot)) {
                    stack.push((node.child(slot), entry));
                }
            }
            push_order::<_, Q>(&mut stack[first..]);
        }
    }
}
