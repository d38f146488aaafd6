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
//!   the closed frame with one batched any-hit call on rayon. Requests submitted while it runs
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
//! **Lock-free submits, no allocation per request.** A submit is one atomic step on a counter
//! that also says which of two request buffers is open (`frames.rs`), eight relaxed stores of
//! the ray's floats into the slot it was given, and one more atomic step to say the slot is
//! written. Submitters never wait for each other or for a flush; a flush waits only for the
//! submitters caught between those two steps. Answers are kept as bits, two frames' worth, read
//! without locks (`answers.rs`). A whole list is reserved with one atomic step
//! ([`LosQueue::submit_all`]).
//!
//! The answers are those of `occluded_batch` on the same rays, so they equal the per-ray
//! `occluded` answers bit for bit: a sightline is blocked iff the segment `[from, to]` (both
//! ends included) hits a triangle. A sightline that cannot be traced (a NaN or infinite point,
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
    occluded: Vec<bool>,
}

impl LosQueue {
    /// Most requests one frame may hold: 2^24 (16.8M requests), far above a frame's
    /// line-of-sight work. A queue takes 64 bytes per request of capacity when made (two
    /// frames of 32-byte requests: 1 GiB at this maximum), and its flushes 33 bytes more per
    /// request answered (a copy of the rays and the answers).
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
        self.submit_ray(Ray::segment(from, to))
    }

    /// Asks whether `ray` hits anything in its range. An invalid ray (see [`Ray::validate`])
    /// is refused with [`QueueError::InvalidRay`].
    pub fn submit_ray(&self, ray: Ray) -> Result<Ticket, QueueError> {
        check(0, &ray)?;
        let reservation = self.frames.reserve_one().ok_or(QueueError::Full {
            capacity: self.capacity(),
        })?;
        self.frames.write(&reservation, std::iter::once(ray));
        Ok(self.ticket(&reservation))
    }

    /// Submits every ray of `rays` at once (a system's whole list for the frame): one atomic
    /// step for all of them instead of one each, so submitters contend less. Ray `k` gets
    /// `first.offset(k)` (see [`Ticket::offset`]). All or nothing: if one is invalid or they do
    /// not all fit, none is taken and the queue is unchanged (a list longer than the capacity
    /// never fits). An empty list takes nothing; its ticket names no request.
    pub fn submit_all(&self, rays: &[Ray]) -> Result<Ticket, QueueError> {
        for (index, ray) in rays.iter().enumerate() {
            check(index, ray)?;
        }
        let reservation = self.frames.reserve(rays.len()).ok_or(QueueError::Full {
            capacity: self.capacity(),
        })?;
        self.frames.write(&reservation, rays.iter().copied());
        Ok(self.ticket(&reservation))
    }

    /// Closes the open frame (requests submitted from now on go to the next one) and answers
    /// it with one batched any-hit call on `world` (a tree, a scene, a filtered scene view).
    /// Returns how many requests were answered, or [`QueueError::FlushRunning`] (nothing
    /// closed) if another flush is running.
    pub fn flush<A: BatchQueries>(&self, world: &A) -> Result<usize, QueueError> {
        let mut arrays = match self.flush.try_lock() {
            Ok(arrays) => arrays,
            Err(TryLockError::Poisoned(poisoned)) => poisoned.into_inner(),
            Err(TryLockError::WouldBlock) => return Err(QueueError::FlushRunning),
        };
        let FlushArrays { rays, occluded } = &mut *arrays;
        rays.clear();
        let frame = self.frames.close(rays);
        occluded.clear();
        // Blocked unless answered clear: an answer the call does not write fails closed, and
        // so does the whole frame if the call refused it (it cannot: the lengths match).
        occluded.resize(rays.len(), true);
        if world
            .occluded_batch_with(rays, occluded, &self.options)
            .is_err()
        {
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

/// Refuses a ray the queue cannot answer truthfully.
fn check(index: usize, ray: &Ray) -> Result<(), QueueError> {
    ray.validate()
        .map_err(|error| QueueError::InvalidRay { index, error })
}
