//! The per-thread memory of a grid walk.

use super::mailbox::Mailbox;
use crate::traverse::origin_order::{OriginOrder, WithOriginOrder};

/// What a thread keeps between grid queries (the `Accel::Scratch` of both grids): the mailbox
/// of the current ray's tested triangles, and the order a batch's rays are walked in.
#[derive(Debug, Default)]
pub struct GridScratch {
    pub(crate) mailbox: Mailbox,
    order: OriginOrder,
}

impl WithOriginOrder for GridScratch {
    fn origin_order(&mut self) -> &mut OriginOrder {
        &mut self.order
    }
}
