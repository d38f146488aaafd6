//! [`LosQueue`]: line-of-sight requests gathered from many threads during a frame and answered
//! as one batch, in a job system where every worker shares the queue.
//!
//! A game's AI systems and jobs each want a few sightlines per agent per frame, from whatever
//! thread they run on. Answering each at once costs a full walk per ray; the batched engine
//! answers thousands together much faster, but needs them in one slice. The queue bridges the
//! two, and every method takes `&self`, so an `Arc<LosQueue>` (or a reference in scoped jobs)
//! serves all the workers:
//!
//! - [`LosQueue::submit`] (any thread, any time) takes a request into the *open* frame and
//!   returns a [`Ticket`];
//! - [`LosQueue::flush`] (any thread) closes the open frame, opens the next one, and answers
//!   the closed frame with one batched any-hit call on rayon, on the scene it is given. Requests submitted while it runs
//!   go to the next frame. One flush runs at a time: a flush called while another runs
//!   returns [`QueueError::FlushRunning`] at once and closes nothing (waiting could deadlock
//!   when both run on rayon's threads);
//! - [`LosQueue::occluded`] (any thread) reads an answer by ticket, from the moment its frame
//!   is answered until the next flush has answered the following frame.
//!
//! The ticket rules: a ticket belongs to the frame that was open when it was taken (its
//! [`Ticket::frame`]); reading it before that frame is answered is [`QueueError::NotFlushed`],
//! after a later frame is answered [`QueueError::Stale`]. Every request taken is answered by
//! exactly one flush, and tickets of one frame have distinct indices from 0.
//!
//! **Per-request filters.** [`LosQueue::submit_filtered`] gives a request its own
//! [`RayFilter`]: layers, an instance to pass through (the agent's own body), back faces, end
//! points. A frame whose requests all share one filter is answered through that filter
//! ([`Scene::filtered`]), one with several through a filter per ray ([`Scene::filtered_batch`]).
//!
//! **Lock-free submits, no allocation per request.** A submit is one atomic step on a counter
//! that also says which of two request buffers is open (`frames.rs`), eleven relaxed stores of
//! the ray's floats and its filter into the slot it was given, and one more atomic step to say the slot is
//! written. Submitters never wait for each other or for a flush; a flush waits only for the
//! submitters caught between those two steps. Answers are kept as bits, two frames' worth, read
//! without locks (`answers.rs`). A whole list is reserved with one atomic step
//! ([`LosQueue::submit_all`]).
//!
//! The answers are those of `occluded_batch` on the same rays, so they equal the per-ray
//! `occluded` answers through the same filters bit for bit: by default a sightline is blocked
//! iff the segment `[from, to]` (both ends included) hits a triangle. A sightline that cannot be traced (a NaN or infinite point,
//! or both ends at the same place) is refused at submit with [`QueueError::InvalidRay`]: a bad
//! position never reads as a clear view.

mod answers;
mod frames;
mod ticket;

use std::sync::{Mutex, TryLockError};

use glam::Vec3;

use crate::batch::BatchOptions;
use crate::geom::Ray;
use crate::query::BatchQueries;
use crate::scene::{RayFilter, Scene};
use crate::workspace::StructureId;
use answers::Answers;
use frames::{Frames, Reservation};
pub use ticket::{QueueError, Ticket};

/// The queue (see the module docs).
pub struct LosQueue {
    /// Stamped on every ticket.
    id: StructureId,
    frames: Frames,
    answers: Answers,
    /// The flush's arrays, kept from frame to frame; its lock makes flushes take turns.
    flush: Mutex<FlushArrays>,
    options: BatchOptions,
}

#[derive(Default)]
struct FlushArrays {
    rays: Vec<Ray>,
    filters: Vec<RayFilter>,
    occluded: Vec<bool>,
}

impl LosQueue {
    /// Most requests one frame may hold: 2^24 (16.8M requests), far above a frame's
    /// line-of-sight work. A queue takes 88 bytes per request of capacity when made (two
    /// frames of 44-byte requests: 1.4 GiB at this maximum), and its flushes 49 bytes more
    /// per request answered (a copy of the rays, the filters and the answers).
    pub const MAX_CAPACITY: usize = 1 << 24;

    /// A queue for up to `capacity` requests per frame (1 to [`LosQueue::MAX_CAPACITY`]; other
    /// values are [`QueueError::BadCapacity`]), answered with the default batch options.
    pub fn with_capacity(capacity: usize) -> Result<Self, QueueError> {
        if !(1..=Self::MAX_CAPACITY).contains(&capacity) {
            return Err(QueueError::BadCapacity {
                requested: capacity,
            });
        }
        Ok(Self {
            id: StructureId::new(),
            frames: Frames::new(capacity),
            answers: Answers::new(capacity),
            flush: Mutex::new(FlushArrays::default()),
            options: BatchOptions::default(),
        })
    }

    /// The same queue answering with `options` (thread use, kernel, ...).
    pub fn with_options(mut self, options: BatchOptions) -> Self {
        self.options = options;
        self
    }

    /// Most requests per frame.
    pub fn capacity(&self) -> usize {
        self.frames.capacity()
    }

    /// Requests taken in the open frame so far.
    pub fn len(&self) -> usize {
        self.frames.taken()
    }

    /// True if no request was taken in the open frame so far.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Asks whether the segment from `from` to `to` is blocked; callable from any thread.
    pub fn submit(&self, from: Vec3, to: Vec3) -> Result<Ticket, QueueError> {
        self.submit_filtered(Ray::segment(from, to), RayFilter::ALL)
    }

    /// Asks whether `ray` hits anything in its range. An invalid ray (see [`Ray::validate`])
    /// is refused with [`QueueError::InvalidRay`].
    pub fn submit_ray(&self, ray: Ray) -> Result<Ticket, QueueError> {
        self.submit_filtered(ray, RayFilter::ALL)
    }

    /// Asks whether `ray` hits anything its filter lets count (see [`RayFilter`]), as
    /// `scene.filtered(filter).occluded(&ray)` answers. An invalid ray is refused with
    /// [`QueueError::InvalidRay`].
    pub fn submit_filtered(&self, ray: Ray, filter: RayFilter) -> Result<Ticket, QueueError> {
        check(0, &ray)?;
        let reservation = self.frames.reserve_one().ok_or(QueueError::Full {
            capacity: self.capacity(),
        })?;
        self.frames
            .write(&reservation, std::iter::once((ray, filter)));
        Ok(self.ticket(&reservation))
    }

    /// Submits every ray of `rays` at once (a system's whole list for the frame): one atomic
    /// step for all of them instead of one each, so submitters contend less. Ray `k` gets
    /// `first.offset(k)` (see [`Ticket::offset`]). All or nothing: if one is invalid or they do
    /// not all fit, none is taken and the queue is unchanged (a list longer than the capacity
    /// never fits). An empty list takes nothing; its ticket names no request.
    pub fn submit_all(&self, rays: &[Ray]) -> Result<Ticket, QueueError> {
        self.submit_all_requests(rays, |_| RayFilter::ALL)
    }

    /// [`LosQueue::submit_all`] with a filter per ray: `filters[k]` for `rays[k]`. Slices of
    /// different lengths are [`QueueError::FilterCount`], and nothing is taken.
    pub fn submit_all_filtered(
        &self,
        rays: &[Ray],
        filters: &[RayFilter],
    ) -> Result<Ticket, QueueError> {
        if rays.len() != filters.len() {
            return Err(QueueError::FilterCount {
                rays: rays.len(),
                filters: filters.len(),
            });
        }
        self.submit_all_requests(rays, |k| filters[k])
    }

    fn submit_all_requests(
        &self,
        rays: &[Ray],
        filter: impl Fn(usize) -> RayFilter,
    ) -> Result<Ticket, QueueError> {
        for (index, ray) in rays.iter().enumerate() {
            check(index, ray)?;
        }
        let reservation = self.frames.reserve(rays.len()).ok_or(QueueError::Full {
            capacity: self.capacity(),
        })?;
        let requests = rays.iter().enumerate().map(|(k, ray)| (*ray, filter(k)));
        self.frames.write(&reservation, requests);
        Ok(self.ticket(&reservation))
    }

    /// Closes the open frame (requests submitted from now on go to the next one) and answers
    /// it with one batched any-hit call on `scene`, each request through its filter. Returns
    /// how many requests were answered, or [`QueueError::FlushRunning`] (nothing closed) if
    /// another flush is running.
    pub fn flush(&self, scene: &Scene) -> Result<usize, QueueError> {
        let mut arrays = match self.flush.try_lock() {
            Ok(arrays) => arrays,
            Err(TryLockError::Poisoned(poisoned)) => poisoned.into_inner(),
            Err(TryLockError::WouldBlock) => return Err(QueueError::FlushRunning),
        };
        let FlushArrays {
            rays,
            filters,
            occluded,
        } = &mut *arrays;
        rays.clear();
        filters.clear();
        let frame = self.frames.close(rays, filters);
        occluded.clear();
        // Blocked unless answered clear: an answer the call does not write fails closed, and
        // so does the whole frame if the call refused it (it cannot: the lengths match).
        occluded.resize(rays.len(), true);
        let answered = match shared_filter(filters) {
            Some(filter) => {
                scene
                    .filtered(filter)
                    .occluded_batch_with(rays, occluded, &self.options)
            }
            None => {
                scene
                    .filtered_batch(filters)
                    .occluded_batch_with(rays, occluded, &self.options)
            }
        };
        if answered.is_err() {
            occluded.fill(true);
        }
        self.answers.publish(frame, occluded);
        Ok(rays.len())
    }

    /// True if the request's segment is blocked, as answered by the flush of its frame.
    pub fn occluded(&self, ticket: Ticket) -> Result<bool, QueueError> {
        if ticket.queue != self.id.get() || ticket.count == 0 {
            return Err(QueueError::UnknownTicket);
        }
        self.answers.read(ticket.frame, ticket.index as usize)
    }

    fn ticket(&self, reservation: &Reservation) -> Ticket {
        Ticket {
            queue: self.id.get(),
            frame: reservation.frame,
            index: reservation.first as u32,
            count: reservation.count as u32,
        }
    }
}

/// The filter every request shares, if they do (the faster path: see [`RayFilter`]).
fn shared_filter(filters: &[RayFilter]) -> Option<RayFilter> {
    let first = filters.first().copied().unwrap_or(RayFilter::ALL);
    filters.iter().all(|f| *f == first).then_some(first)
}

/// Refuses a ray the queue cannot answer truthfully.
fn check(index: usize, ray: &Ray) -> Result<(), QueueError> {
    ray.validate()
        .map_err(|error| QueueError::InvalidRay { index, error })
}
