//! The per-thread memory of a grid walk.

use super::mailbox::Mailbox;
use crate::accel::RayStream;
use crate::batch::origin_order::OriginOrder;
use crate::geom::{Aabb, PreparedRay};

/// What a thread keeps between grid queries (the `Accel::Scratch` of both grids): the mailbox
/// of the current ray's tested triangles, and the order a batch's rays are walked in.
#[derive(Debug, Default)]
pub struct GridScratch {
    pub(crate) mailbox: Mailbox,
    order: OriginOrder,
}

impl GridScratch {
    /// A grid's `trace_stream`: every ray of `stream` walked alone by `walk(ray, id, mailbox)`
    /// (which returns its final range end), in origin order when the grid spanning `bounds`
    /// and its mesh hold more than `working_set` bytes ([`OriginOrder::trace`]).
    pub(crate) fn trace_stream(
        &mut self,
        grid: (&Aabb, usize),
        stream: &mut RayStream<'_>,
        mut walk: impl FnMut(&PreparedRay, u32, &mut Mailbox) -> f32,
    ) {
        let Self { mailbox, order } = self;
        order.trace(grid, stream, |ray, id| walk(ray, id, mailbox));
    }
}
