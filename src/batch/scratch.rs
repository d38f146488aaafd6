//! The batched engine's per-thread arrays, reused from call to call (they live in the thread's
//! [`crate::workspace::Workspace`]).

use super::lanes::Lanes;
use super::mixing::MixingJudge;
use super::rays::PreparedRays;
use super::slots::Slots;
use crate::hit::Hit;

/// The batched engine's working arrays.
#[derive(Debug, Default)]
pub(crate) struct BatchScratch {
    /// The chunk's prepared rays, in lanes (for structures that partition them)...
    pub lanes: Lanes,
    /// ...or in records (for the others: [`crate::accel::StreamLayout`]).
    pub rays: PreparedRays,
    /// Where the chunk's rays went (the streams' ray ids are slots).
    pub slots: Slots,
    /// Closest-hit answers of the chunk, by slot.
    pub best: Vec<Hit>,
    /// Any-hit answers of the chunk, by slot.
    pub occluded: Vec<bool>,
    /// Each ray's group while grouping.
    pub keys: Vec<u8>,
    /// Whether this thread's next closest-hit chunk mixes small octants.
    pub mixing: MixingJudge,
}
