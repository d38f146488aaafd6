//! [`LosQueue`]: line-of-sight requests gathered from many threads during a frame and answered
//! as one batch.
//!
//! A game's AI systems and jobs each want a few sightlines per agent per frame, from whatever
//! thread they run on. Answering each at once costs a full walk per ray; the batched engine
//! answers thousands together much faster, but needs them in one slice. The queue bridges the
//! two: [`LosQueue::submit`] takes `&self`, so any number of threads call it concurrently;
//! each request gets a [`Ticket`]; one [`LosQueue::flush`] (which takes `&mut self`, so every
//! submitter is done) answers them all with one batched any-hit call on rayon, into arrays kept
//! from frame to frame; [`LosQueue::visible`] reads an answer by ticket until the next flush.
//!
//! **Lock-free, no allocation per request.** The ticket is a `fetch_add` on one counter (kept
//! on its own cache line with crossbeam's `CachePadded`), and it is also the request's slot in
//! an array allocated once: the request is written there with relaxed atomic stores of its
//! eight floats, so submitters never wait on each other and never touch each other's slots.
//! The flush, holding `&mut self` (after every submitter has finished, which orders their
//! writes before it), reads the slots as plain values: no draining pass, and a whole list
//! can be reserved with one atomic step ([`LosQueue::submit_all`]). (Crossbeam's `ArrayQueue`
//! runs as fast in the `game_ai_los` example but needs a draining pass and a
//! compare-and-swap per push.)
//!
//! The answers are those of `occluded_batch` on the same rays, so they equal the per-ray
//! `occluded` answers bit for bit: a sightline is clear iff the segment `[from, to]` (both
//! ends included) hits nothing.

use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};

use crossbeam::utils::CachePadded;
use glam::Vec3;

use crate::batch::BatchOptions;
use crate::geom::Ray;
use crate::query::{BatchError, BatchQueries};
use crate::workspace::StructureId;

/// The receipt for one request (or, from [`LosQueue::submit_all`], for a list of them): which
/// frame it belongs to and its place in that frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Ticket {
    /// The queue that issued it (a [`StructureId`]), so another queue's ticket is refused.
    queue: u64,
    frame: u64,
    index: u32,
    /// Requests the ticket covers: 1, the length of a list, or 0 for a ticket that names no
    /// request (an [`Ticket::offset`] past its list).
    count: u32,
}

impl Ticket {
    /// The request's position in its frame's batch (0 for the first request taken).
    pub fn index(&self) -> usize {
        self.index as usize
    }

    /// The ticket of the `k`-th ray of a [`LosQueue::submit_all`] that returned this ticket.
    /// Past the list it names no request: [`LosQueue::visible`] refuses it with
    /// [`QueueError::UnknownTicket`].
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
    /// The ticket's frame has not been flushed yet.
    NotFlushed,
    /// The ticket was not issued by this queue for this frame (another queue's ticket, or an
    /// [`Ticket::offset`] past the list it was taken for).
    UnknownTicket,
    /// A queue needs room for 1 to [`LosQueue::MAX_CAPACITY`] requests.
    BadCapacity {
        /// The capacity asked for.
        requested: usize,
    },
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
            QueueError::UnknownTicket => f.write_str("the ticket was not issued by this queue"),
            QueueError::BadCapacity { requested } => write!(
                f,
                "a line-of-sight queue holds 1 to {} requests, not {requested}",
                LosQueue::MAX_CAPACITY
            ),
            QueueError::Stale => f.write_str("the ticket's answer was replaced by a later flush"),
        }
    }
}

impl std::error::Error for QueueError {}

/// One request's ray as the bits of its eight floats: origin, direction, `tmin`, `tmax`.
#[derive(Default)]
struct Slot([AtomicU32; 8]);

impl Slot {
    fn store(&self, ray: &Ray) {
        let [ox, oy, oz] = ray.origin.to_array();
        let [dx, dy, dz] = ray.dir.to_array();
        for (cell, v) in self
            .0
            .iter()
            .zip([ox, oy, oz, dx, dy, dz, ray.tmin, ray.tmax])
        {
            cell.store(v.to_bits(), Ordering::Relaxed);
        }
    }

    /// The ray, read through `&mut` (no submitter is running).
    fn load(&mut self) -> Ray {
        let [ox, oy, oz, dx, dy, dz, tmin, tmax] =
            self.0.each_mut().map(|c| f32::from_bits(*c.get_mut()));
        Ray::with_range(Vec3::new(ox, oy, oz), Vec3::new(dx, dy, dz), tmin, tmax)
    }
}

/// The queue (see the module docs).
pub struct LosQueue {
    /// Stamped on every ticket.
    id: StructureId,
    slots: Box<[Slot]>,
    taken: CachePadded<AtomicUsize>,
    /// The frame now collecting requests.
    frame: u64,
    /// The frame whose answers `occluded` holds (none before the first flush).
    answered: Option<u64>,
    rays: Vec<Ray>,
    occluded: Vec<bool>,
    options: BatchOptions,
}

impl LosQueue {
    /// Most requests one frame may hold: 2^24 (16.8M requests), far above a frame's
    /// line-of-sight work. A queue takes 32 bytes of slots per request of capacity when made
    /// (512 MiB at this maximum), and its flushes 33 bytes more per request answered (a copy
    /// of the rays and the answers: about 1 GiB in all at the maximum).
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
            slots: (0..capacity).map(|_| Slot::default()).collect(),
            taken: CachePadded::new(AtomicUsize::new(0)),
            frame: 0,
            answered: None,
            rays: Vec::with_capacity(capacity),
            occluded: Vec::with_capacity(capacity),
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
        self.slots.len()
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
        let Some(slot) = self.slots.get(index) else {
            return Err(QueueError::Full {
                capacity: self.capacity(),
            });
        };
        // Each index below the capacity is handed out once per frame: the slot is ours.
        slot.store(&ray);
        Ok(Ticket {
            queue: self.id.get(),
            frame: self.frame,
            index: index as u32,
            count: 1,
        })
    }

    /// Submits every ray of `rays` at once (a system's whole list for the frame): one atomic
    /// step for all of them instead of one each, so submitters contend less. Ray `k` gets
    /// `first.offset(k)` (see [`Ticket::offset`]). All or nothing: if they do not all fit,
    /// none is taken and the queue is unchanged.
    pub fn submit_all(&self, rays: &[Ray]) -> Result<Ticket, QueueError> {
        let capacity = self.capacity();
        let fits = |taken: usize| taken.checked_add(rays.len()).filter(|&end| end <= capacity);
        let start = self
            .taken
            .fetch_update(Ordering::Relaxed, Ordering::Relaxed, fits)
            .map_err(|_| QueueError::Full { capacity })?;
        for (slot, ray) in self.slots[start..start + rays.len()].iter().zip(rays) {
            slot.store(ray);
        }
        Ok(Ticket {
            queue: self.id.get(),
            frame: self.frame,
            index: start as u32,
            count: rays.len() as u32,
        })
    }

    /// Answers every request of the frame with one batched any-hit call on `world` (a tree,
    /// a scene, a filtered scene view), then opens the next frame. Returns how many requests
    /// were answered.
    pub fn flush<A: BatchQueries>(&mut self, world: &A) -> Result<usize, BatchError> {
        let count = self.len();
        self.rays.clear();
        self.rays
            .extend(self.slots[..count].iter_mut().map(Slot::load));
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
        if ticket.queue != self.id.get() || ticket.count == 0 {
            return Err(QueueError::UnknownTicket);
        }
        match self.answered {
            Some(frame) if ticket.frame == frame => self
                .occluded
                .get(ticket.index as usize)
                .map(|&blocked| !blocked)
                .ok_or(QueueError::UnknownTicket),
            Some(frame) if ticket.frame < frame => Err(QueueError::Stale),
            _ => Err(QueueError::NotFlushed),
        }
    }

    /// Every answer of the last flush, by ticket index: `true` if blocked.
    pub fn occluded(&self) -> &[bool] {
        &self.occluded
    }
}
