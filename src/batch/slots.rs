//! A chunk's slots: where each valid ray's prepared record goes (its group's next slot, by
//! [`Placer`]) and the map both ways between slots and the rays' positions ([`Slots`]), which
//! the grouping fills one ray at a time or eight at a time with AVX2.

/// Number of groups: the 8 octants (a single group when unordered).
pub(crate) const GROUPS: usize = 8;

/// Where each ray of a chunk went: the streams carry prepared slots as ray ids, so that the
/// answers a walk writes (by id) sit next to each other in memory; answers by position would
/// be spread over the whole batch, one cache and TLB miss per hit on a large batch (by slot,
/// about 6% faster on the fandisk's 1M incoherent rays).
#[derive(Clone, Debug, Default)]
pub(crate) struct Slots {
    /// By slot: the ray's position in the chunk.
    pub(crate) positions: Vec<u32>,
    /// By position: the ray's slot, [`Slots::NONE`] for an invalid ray (it has none).
    pub(crate) of_position: Vec<u32>,
}

impl Slots {
    /// No slot: the ray is invalid.
    pub(crate) const NONE: u32 = u32::MAX;

    /// The slot of every ray culled while preparing: one past the last slot, never a ray's
    /// id in a stream, so its answer stays blank (answer arrays have one entry more than slots).
    pub(crate) fn dead(&self) -> usize {
        self.positions.len()
    }
}

/// Pass 2 of the counting sort's bookkeeping, for either layout: gives each valid ray its
/// slot in its group and records both ways between slots and positions. A ray that misses the
/// cull box gets a slot too (its record is written), but the group's cursor stays where it
/// was (the next ray takes its place) and its position maps to [`Slots::dead`].
pub(crate) struct Placer<'s> {
    /// Where each group's next ray goes; at the end, where each group's kept rays end.
    pub(crate) next: [usize; GROUPS],
    positions: &'s mut [u32],
    of_position: &'s mut [u32],
    dead: u32,
}

impl<'s> Placer<'s> {
    /// Sizes `slots` for a chunk of `rays` rays whose groups start at `starts`. Every entry is
    /// written by [`Placer::place`] (every slot by the ray that ends there, every position by
    /// its ray), so the arrays are not cleared first.
    pub(crate) fn new(slots: &'s mut Slots, starts: [usize; GROUPS + 1], rays: usize) -> Self {
        let Slots {
            positions,
            of_position,
        } = slots;
        positions.resize(starts[GROUPS], 0);
        of_position.resize(rays, Slots::NONE);
        Self {
            next: std::array::from_fn(|g| starts[g]),
            positions,
            of_position,
            dead: starts[GROUPS] as u32,
        }
    }

    /// The slot ray `id` (group key `key`, touching the cull box if `kept`) is written to;
    /// `None` for an invalid ray.
    #[inline(always)]
    pub(crate) fn place(&mut self, id: usize, key: u8, kept: bool) -> Option<usize> {
        let Some(&slot) = self.next.get(key as usize) else {
            self.of_position[id] = Slots::NONE;
            return None;
        };
        self.positions[slot] = id as u32;
        self.of_position[id] = if kept { slot as u32 } else { self.dead };
        self.next[key as usize] += kept as usize;
        Some(slot)
    }
}
