//! The answers of the last two frames flushed, one bit per request, readable from any thread
//! while the next flush runs.
//!
//! Each frame's answers go to the buffer of its parity, so a flush writing frame `f + 1` never
//! touches what readers of frame `f` read. Frame `f + 2` does reuse frame `f`'s buffer; it is
//! a sequence lock: the writer marks the buffer as being written before it stores the bits and
//! stamps the frame after, and a reader checks the stamp before and after its read, refusing
//! the answer (stale) if it changed. All of it is atomics: no lock, and a reader never waits.

use std::sync::atomic::{AtomicU64, Ordering, fence};

use crate::users::los_queue::ticket::QueueError;

/// No frame (before the first flush, or while a buffer is being written).
const NONE: u64 = u64::MAX;

pub(super) struct Answers {
    /// Per buffer, bit `i % 64` of word `i / 64` is request `i`'s answer (set: blocked).
    bits: [Box<[AtomicU64]>; 2],
    /// Per buffer, the frame whose answers it holds, or [`NONE`].
    holds: [AtomicU64; 2],
    /// The last frame answered, or [`NONE`].
    latest: AtomicU64,
}

impl Answers {
    pub fn new(capacity: usize) -> Self {
        let words = || {
            (0..capacity.div_ceil(64))
                .map(|_| AtomicU64::new(0))
                .collect()
        };
        Self {
            bits: [words(), words()],
            holds: [AtomicU64::new(NONE), AtomicU64::new(NONE)],
            latest: AtomicU64::new(NONE),
        }
    }

    /// Stores frame `frame`'s answers (`occluded[i]` for request `i`) and makes it the latest.
    /// Only one flush may call this at a time.
    pub fn publish(&self, frame: u64, occluded: &[bool]) {
        let b = (frame & 1) as usize;
        self.holds[b].store(NONE, Ordering::Relaxed);
        fence(Ordering::Release);
        for (word, answers) in self.bits[b].iter().zip(occluded.chunks(64)) {
            let packed = answers
                .iter()
                .enumerate()
                .fold(0u64, |w, (i, &blocked)| w | (u64::from(blocked) << i));
            word.store(packed, Ordering::Relaxed);
        }
        self.holds[b].store(frame, Ordering::Release);
        self.latest.store(frame, Ordering::Release);
    }

    /// Request `index`'s answer in frame `frame`, if that frame is the latest answered.
    pub fn read(&self, frame: u64, index: usize) -> Result<bool, QueueError> {
        let latest = self.latest.load(Ordering::Acquire);
        if latest == NONE || frame > latest {
            return Err(QueueError::NotFlushed);
        }
        if frame < latest {
            return Err(QueueError::Stale);
        }
        let b = (frame & 1) as usize;
        let word = self.bits[b]
            .get(index / 64)
            .ok_or(QueueError::UnknownTicket)?;
        if self.holds[b].load(Ordering::Acquire) != frame {
            return Err(QueueError::Stale);
        }
        let bits = word.load(Ordering::Relaxed);
        fence(Ordering::Acquire);
        if self.holds[b].load(Ordering::Relaxed) != frame {
            return Err(QueueError::Stale);
        }
        Ok(bits >> (index % 64) & 1 == 1)
    }
}
