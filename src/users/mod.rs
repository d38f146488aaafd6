//! Helpers for the library's two main users, built on the queries: game AI line of sight
//! ([`LosQueue`]: requests from many threads answered as one batch) and audio occlusion
//! ([`occlusion`], [`occlusion_batch`]: the transmission loss of every surface between a
//! source and a listener).

mod audio;
mod los_queue;

pub use audio::{AudioError, CROSSING_TOLERANCE, Materials, Occlusion, occlusion, occlusion_batch};
pub use los_queue::{LosQueue, QueueError, Ticket};
