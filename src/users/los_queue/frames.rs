//! The queue's two request buffers: submitters fill the open one while a flush reads the
//! closed one, so neither waits for the other.
//!
//! One word (`open`) holds the open buffer's parity in its top bit and the requests taken in
//! the open frame in the other 63: a single atomic step both reserves slots and says which
//! buffer they are in, and a flush closes the frame with a single swap. A submitter writes its
//! ray's floats and filter with relaxed stores into slots no one else was given, then its
//! flags word with the `WRITTEN` bit (release); the flush waits on each slot reserved before
//! the swap until that bit is set (acquire), so it reads every request whole, and clears it.
//! A submit thus touches one shared word, the reservation: a shared count of written slots
//! cost every submitter a second contended step.
//!
//! A buffer is reused two frames later. Its next frame opens at the next flush's swap, which
//! comes after this flush has read and cleared it (flushes hold one lock in turn), so a
//! submitter never writes into a slot being read, nor sees its bit from two frames ago.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

use crossbeam::utils::CachePadded;
use glam::Vec3;

use crate::geom::Ray;
use crate::scene::RayFilter;

/// The top bit of the open word: the open frame's parity.
const PARITY: u64 = 1 << 63;

/// One request: the bits of its ray's eight floats (origin, direction, `tmin`, `tmax`), then
/// its filter's layers, ignored instance and flags.
#[derive(Default)]
struct Slot([AtomicU32; 11]);

/// Flag bits of a stored filter, and the bit that says the slot is completely stored.
const IGNORES: u32 = 1;
const CULLS: u32 = 2;
const OPEN: u32 = 4;
const WRITTEN: u32 = 8;

impl Slot {
    fn store(&self, (ray, filter): &(Ray, RayFilter)) {
        let [ox, oy, oz] = ray.origin.to_array().map(f32::to_bits);
        let [dx, dy, dz] = ray.dir.to_array().map(f32::to_bits);
        let (tmin, tmax) = (ray.tmin.to_bits(), ray.tmax.to_bits());
        let flag = |on: bool, bit: u32| if on { bit } else { 0 };
        let flags = flag(filter.ignore.is_some(), IGNORES)
            | flag(filter.cull_back_faces, CULLS)
            | flag(!filter.include_ends, OPEN);
        let ignore = filter.ignore.unwrap_or(0);
        let words = [ox, oy, oz, dx, dy, dz, tmin, tmax, filter.layers, ignore];
        for (cell, word) in self.0.iter().zip(words) {
            cell.store(word, Ordering::Relaxed);
        }
        // Release: whoever sees the bit sees the words above.
        self.0[10].store(flags | WRITTEN, Ordering::Release);
    }

    /// Waits until the slot is completely stored, reads it and clears it for its next use.
    fn take(&self) -> (Ray, RayFilter) {
        while self.0[10].load(Ordering::Acquire) & WRITTEN == 0 {
            std::thread::yield_now();
        }
        let request = self.load();
        self.0[10].store(0, Ordering::Relaxed);
        request
    }

    fn load(&self) -> (Ray, RayFilter) {
        let [ox, oy, oz, dx, dy, dz, tmin, tmax, layers, ignore, flags] =
            self.0.each_ref().map(|c| c.load(Ordering::Relaxed));
        let [ox, oy, oz, dx, dy, dz, tmin, tmax] =
            [ox, oy, oz, dx, dy, dz, tmin, tmax].map(f32::from_bits);
        let ray = Ray::with_range(Vec3::new(ox, oy, oz), Vec3::new(dx, dy, dz), tmin, tmax);
        let filter = RayFilter {
            layers,
            ignore: (flags & IGNORES != 0).then_some(ignore),
            cull_back_faces: flags & CULLS != 0,
            include_ends: flags & OPEN == 0,
        };
        (ray, filter)
    }
}

/// One frame's requests.
struct Buffer {
    slots: Box<[Slot]>,
}

/// Slots reserved by one submit: `count` of them from `first`, in frame `frame`.
pub(super) struct Reservation {
    pub frame: u64,
    pub first: usize,
    pub count: usize,
}

/// The two buffers and the open word (see the module docs).
pub(super) struct Frames {
    buffers: [Buffer; 2],
    /// The open frame's parity (top bit) and requests taken in it (the other bits; may exceed
    /// the capacity, by the requests refused).
    open: CachePadded<AtomicU64>,
    /// The open frame's number, for tickets; written by flushes only.
    open_frame: AtomicU64,
}

impl Frames {
    pub fn new(capacity: usize) -> Self {
        let buffer = || Buffer {
            slots: (0..capacity).map(|_| Slot::default()).collect(),
        };
        Self {
            buffers: [buffer(), buffer()],
            open: CachePadded::new(AtomicU64::new(0)),
            open_frame: AtomicU64::new(0),
        }
    }

    pub fn capacity(&self) -> usize {
        self.buffers[0].slots.len()
    }

    /// Requests taken in the open frame.
    pub fn taken(&self) -> usize {
        self.taken_in(self.open.load(Ordering::Relaxed))
    }

    fn taken_in(&self, word: u64) -> usize {
        usize::try_from(word & !PARITY).map_or(self.capacity(), |n| n.min(self.capacity()))
    }

    /// Reserves one slot of the open frame, or `None` if it is full.
    pub fn reserve_one(&self) -> Option<Reservation> {
        // Acquire: if this reads the word a flush swapped in, it also sees that flush's new
        // `open_frame` (see `reservation`).
        let word = self.open.fetch_add(1, Ordering::AcqRel);
        let first = usize::try_from(word & !PARITY).ok()?;
        (first < self.capacity()).then(|| self.reservation(word, first, 1))
    }

    /// Reserves `count` consecutive slots of the open frame, all or none. Nothing always fits:
    /// it touches no slot, and its frame is the open frame's number as read (no flush waits
    /// for it, so that frame may already be closed; a ticket for nothing names no request).
    pub fn reserve(&self, count: usize) -> Option<Reservation> {
        if count == 0 {
            let frame = self.open_frame.load(Ordering::Acquire);
            return Some(Reservation {
                frame,
                first: 0,
                count,
            });
        }
        let capacity = self.capacity();
        let fits = |word: u64| {
            let end = usize::try_from(word & !PARITY).ok()?.checked_add(count)?;
            (end <= capacity).then_some(word + count as u64)
        };
        let word = self
            .open
            .fetch_update(Ordering::AcqRel, Ordering::Relaxed, fits)
            .ok()?;
        Some(self.reservation(word, (word & !PARITY) as usize, count))
    }

    /// The frame a reservation made on `word` belongs to. The open frame's number is read
    /// after the reservation: either that frame or, if a flush has closed it since, the next
    /// one, never later (that flush waits for this reservation's rays); the parity tells
    /// which.
    fn reservation(&self, word: u64, first: usize, count: usize) -> Reservation {
        let parity = u64::from(word & PARITY != 0);
        let open = self.open_frame.load(Ordering::Acquire);
        let frame = if open & 1 == parity {
            open
        } else {
            open.saturating_sub(1)
        };
        Reservation {
            frame,
            first,
            count,
        }
    }

    /// Stores `requests` in the reserved slots, each marked written when whole.
    pub fn write(
        &self,
        reservation: &Reservation,
        requests: impl Iterator<Item = (Ray, RayFilter)>,
    ) {
        let buffer = &self.buffers[(reservation.frame & 1) as usize];
        let slots = &buffer.slots[reservation.first..reservation.first + reservation.count];
        for (slot, request) in slots.iter().zip(requests) {
            slot.store(&request);
        }
    }

    /// Closes the open frame, opens the next and appends the closed frame's rays and filters
    /// to `rays` and `filters`, once every submitter that reserved a slot in it has written
    /// its request. Returns the closed frame's number. Only one flush may call this at a time.
    pub fn close(&self, rays: &mut Vec<Ray>, filters: &mut Vec<RayFilter>) -> u64 {
        let frame = self.open_frame.load(Ordering::Relaxed);
        // The new number is stored *before* the swap that opens its frame, and the swap
        // releases it: a submitter whose reservation reads the swapped word therefore reads
        // this number or a later one, which `reservation` relies on. Do not reorder.
        self.open_frame.store(frame + 1, Ordering::Release);
        let next = if frame & 1 == 0 { PARITY } else { 0 };
        let count = self.taken_in(self.open.swap(next, Ordering::AcqRel));
        let buffer = &self.buffers[(frame & 1) as usize];
        for (ray, filter) in buffer.slots[..count].iter().map(Slot::take) {
            rays.push(ray);
            filters.push(filter);
        }
        frame
    }
}
