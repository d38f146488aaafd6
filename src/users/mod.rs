//! Helpers for the library's two main users, built on the queries: game AI line of sight
//! ([`los_queue`]: requests from many threads answered as one batch) and audio occlusion
//! ([`audio`]: the transmission loss of every surface between a source and a listener).

pub mod audio;
pub mod los_queue;

pub use audio::{AudioError, CROSSING_TOLERANCE, Materials, Occlusion, occlusion, occlusion_batch};
pub use los_queue::{LosQueue, QueueError, Ticket};
