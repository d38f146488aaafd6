//! [`LosQueue`]: line-of-sight requests gathered from many threads during a frame and answered
//! as one batch.
//!
//! A game's AI systems and jobs each want a few sightlines per agent per frame, from whatever
//! thread they run on. Answering each at once costs a full walk per ray; the batched engine
//! answers thousands together much faster, but needs them in one slice. The queue bridges the
//! two: [`LosQueue::submit`] takes `&self`, so any number of threads call it concurrently
//! (a lock-free bounded queue from crossbeam and an atomic ticket counter: no lock, no
//! allocation per request); each request gets a [`Ticket`]; one [`LosQueue::flush`] (which
//! takes `&mut self`, so every submitter is done) answers them all with one batched any-hit
//! call on rayon, into arrays kept from frame to frame; [`LosQueue::visible`] reads an answer by
//! ticket until the next flush.
//!
//! The answers are those of `occluded_batch` on the same rays, so they equal the per-ray
//! `occluded` answers bit for bit: a sightline is clear iff the segment `[from, to]` (both
//! ends included) hits nothing.

use std::sync::atomic::{AtomicUsize, Ordering};

use crossbeam::queue::ArrayQueue;
use glam::Vec3;

use crate::batch::BatchOptions;
use crate::geom::Ray;
use crate::query::{BatchError, BatchQueries};

/// The receipt for one request: which frame it belongs to and its place in that frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Ticket {
    frame: u64,
    index: u32,
}

impl Ticket {
    /// The request's position in its frame's batch (0 for the first request taken).
    pub fn index(&self) -> usize {
        self.index as usize
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
    /// The ticket's frame has not been flushed yet.
    NotFlushed,
    /// The ticket belongs to a frame older than the last flush: its answer is gone.
    Stale,
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
            QueueError::NotFlushed => f.write_str("the ticket's frame has not been flushed"),
            QueueError::Stale => f.write_str("the ticket's answer was replaced by a later flush"),
        }
    }
}

impl std::error::Error for QueueError {}

/// The queue (see the module docs).
pub struct LosQueue {
    requests: ArrayQueue<(u32, Ray)>,
    taken: AtomicUsize,
    /// The frame now collecting requests.
    frame: u64,
    /// The frame whose answers `occluded` holds (none before the first flush).
    answered: Option<u64>,
    rays: Vec<Ray>,
    occluded: Vec<bool>,
    options: BatchOptions,
}

impl LosQueue {
    /// A queue for up to `capacity` requests per frame (1 to `u32::MAX`), answered with the
    /// default batch options.
    pub fn with_capacity(capacity: usize) -> Self {
        let capacity = capacity.clamp(1, u32::MAX as usize);
        Self {
            requests: ArrayQueue::new(capacity),
            taken: AtomicUsize::new(0),
            frame: 0,
            answered: None,
            rays: Vec::with_capacity(capacity),
            occluded: Vec::with_capacity(capacity),
            options: BatchOptions::default(),
        }
    }

    /// The same queue answering with `options` (thread use, kernel, ...).
    pub fn with_options(mut self, options: BatchOptions) -> Self {
        self.options = options;
        self
    }

    /// Most requests per frame.
    pub fn capacity(&self) -> usize {
        self.requests.capacity()
    }

    /// Requests taken this frame.
    pub fn len(&self) -> usize {
        self.taken.load(Ordering::Relaxed).min(self.capacity())
    }

    /// True if no request was taken this frame.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Asks whether the segment from `from` to `to` is clear; callable from any thread.
    pub fn submit(&self, from: Vec3, to: Vec3) -> Result<Ticket, QueueError> {
        self.submit_ray(Ray::segment(from, to))
    }

    /// Asks whether `ray` hits nothing in its range (an invalid ray is clear: it hits nothing).
    pub fn submit_ray(&self, ray: Ray) -> Result<Ticket, QueueError> {
        let index = self.taken.fetch_add(1, Ordering::Relaxed);
        let capacity = self.capacity();
        if index >= capacity {
            return Err(QueueError::Full { capacity });
        }
        // Tickets below the capacity are unique and the queue is drained at every flush, so
        // there is always room.
        if self.requests.push((index as u32, ray)).is_err() {
            unreachable!("at most `capacity` requests are pushed between flushes");
        }
        Ok(Ticket {
            frame: self.frame,
            index: index as u32,
        })
    }

    /// Answers every request of the frame with one batched any-hit call on `world` (a tree,
    /// a scene, a filtered scene view), then opens the next frame. Returns how many requests
    /// were answered.
    pub fn flush<A: BatchQueries>(&mut self, world: &A) -> Result<usize, BatchError> {
        let count = self.len();
        self.rays.clear();
        self.rays
            .resize(count, Ray::segment(Vec3::ZERO, Vec3::ZERO));
        while let Some((index, ray)) = self.requests.pop() {
            self.rays[index as usize] = ray;
        }
        self.occluded.clear();
        self.occluded.resize(count, false);
        world.occluded_batch_with(&self.rays, &mut self.occluded, &self.options)?;
        self.answered = Some(self.frame);
        self.frame += 1;
        *self.taken.get_mut() = 0;
        Ok(count)
    }

    /// True if the request's segment is clear, as of the flush that answered it.
    pub fn visible(&self, ticket: Ticket) -> Result<bool, QueueError> {
        match self.answered {
            Some(frame) if ticket.frame == frame => Ok(!self.occluded[ticket.index as usize]),
            Some(frame) if ticket.frame < frame => Err(QueueError::Stale),
            _ => Err(QueueError::NotFlushed),
        }
    }

    /// Every answer of the last flush, by ticket index: `true` if blocked.
    pub fn occluded(&self) -> &[bool] {
        &self.occluded
    }
}
