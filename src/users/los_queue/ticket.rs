//! What the queue hands out and refuses: [`Ticket`]s and [`QueueError`]s.

use crate::geom::RayError;

/// The receipt for one request (or, from [`super::LosQueue::submit_all`], for a list of them):
/// which queue and frame it belongs to and its place in that frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Ticket {
    /// The queue that issued it (a [`crate::workspace::StructureId`]), so another queue's
    /// ticket is refused.
    pub(super) queue: u64,
    pub(super) frame: u64,
    pub(super) index: u32,
    /// Requests the ticket covers: 1, the length of a list, or 0 for a ticket that names no
    /// request (an [`Ticket::offset`] past its list).
    pub(super) count: u32,
}

impl Ticket {
    /// The request's position in its frame's batch (0 for the first request taken).
    pub fn index(&self) -> usize {
        self.index as usize
    }

    /// The frame the request belongs to: 0 for the requests answered by the queue's first
    /// flush, then one more per flush (for a ticket that names no request, a frame that was
    /// open at about the time it was taken).
    pub fn frame(&self) -> u64 {
        self.frame
    }

    /// The ticket of the `k`-th ray of a [`super::LosQueue::submit_all`] that returned this
    /// ticket. Past the list it names no request: [`super::LosQueue::occluded`] refuses it
    /// with [`QueueError::UnknownTicket`].
    pub fn offset(&self, k: usize) -> Ticket {
        match u32::try_from(k) {
            Ok(k) if k < self.count => Ticket {
                index: self.index + k,
                count: 1,
                ..*self
            },
            _ => Ticket { count: 0, ..*self },
        }
    }
}

/// Why a request or a read was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueueError {
    /// The frame already holds `capacity` requests: flush, or make a larger queue.
    Full {
        /// The queue's capacity.
        capacity: usize,
    },
    /// A sightline that cannot be answered (a NaN or infinite point, or both ends at the same
    /// place): refused, so that a bad position is never reported as a clear view.
    InvalidRay {
        /// Its position in the list submitted (0 for a single request).
        index: usize,
        /// What is wrong with it.
        error: RayError,
    },
    /// The ticket's frame has not been answered yet.
    NotFlushed,
    /// Another flush is running; this one closed nothing (see [`super::LosQueue::flush`]).
    FlushRunning,
    /// The ticket was not issued by this queue (another queue's ticket, or an
    /// [`Ticket::offset`] past the list it was taken for).
    UnknownTicket,
    /// A queue needs room for 1 to [`super::LosQueue::MAX_CAPACITY`] requests.
    BadCapacity {
        /// The capacity asked for.
        requested: usize,
    },
    /// The ticket belongs to a frame older than the last one answered: its answer is gone.
    Stale,
    /// [`super::LosQueue::submit_all_filtered`] got a number of filters other than its
    /// number of rays.
    FilterCount {
        /// Number of rays.
        rays: usize,
        /// Number of filters.
        filters: usize,
    },
}

impl std::fmt::Display for QueueError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            QueueError::Full { capacity } => {
                write!(
                    f,
                    "line-of-sight queue full ({capacity} requests this frame)"
                )
            }
            QueueError::InvalidRay { index, error } => {
                write!(f, "sightline {index} refused: {error}")
            }
            QueueError::NotFlushed => f.write_str("the ticket's frame has not been answered yet"),
            QueueError::UnknownTicket => f.write_str(
                "the ticket names no request of this queue (another queue's, or past its list)",
            ),
            QueueError::FlushRunning => f.write_str("another flush of this queue is running"),
            QueueError::BadCapacity { requested } => write!(
                f,
                "a line-of-sight queue holds 1 to {} requests, not {requested}",
                super::LosQueue::MAX_CAPACITY
            ),
            QueueError::Stale => f.write_str("the ticket's answer was replaced by a later flush"),
            QueueError::FilterCount { rays, filters } => {
                write!(f, "{filters} filters for {rays} sightlines; each needs one")
            }
        }
    }
}

impl std::error::Error for QueueError {}
