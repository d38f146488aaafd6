//! Grouping a chunk's rays by direction octant, straight into lanes or prepared-ray records.
//!
//! Rays are validated and prepared once, and sorted into 8 groups with a counting sort (one
//! group when the ordering is [`BatchOrdering::Unordered`]), so that within a group every ray
//! has the same octant and a node's precomputed child order applies to all of them. Invalid
//! rays get no lane: they miss.

use super::lanes::Lanes;
use super::options::BatchOrdering;
use super::rays::PreparedRays;
use crate::geom::ray::flushed_if_valid;
use crate::geom::{PreparedRay, Ray, octant};

/// Number of groups: the 8 octants (a single group when unordered).
pub(crate) const GROUPS: usize = 8;

/// The groups of a prepared chunk: group `g` is lanes `starts[g]..starts[g + 1]`.
pub(crate) struct Groups {
    starts: [usize; GROUPS + 1],
    ordering: BatchOrdering,
}

impl Groups {
    /// The non-empty groups as `(start, end, octant_mask)`; the mask is 0 when unordered.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (usize, usize, u8)> + '_ {
        (0..GROUPS).filter_map(|g| {
            let (start, end) = (self.starts[g], self.starts[g + 1]);
            let mask = match self.ordering {
                BatchOrdering::ByOctant => 1u8 << g,
                BatchOrdering::Unordered => 0,
            };
            (start < end).then_some((start, end, mask))
        })
    }
}

/// Prepares the chunk's rays into `lanes`, grouped (see the module docs); `keys` is scratch.
pub(crate) fn prepare(
    rays: &[Ray],
    ordering: BatchOrdering,
    lanes: &mut Lanes,
    keys: &mut Vec<u8>,
) -> Groups {
    let starts = group_starts(rays, ordering, keys);
    lanes.reset(starts[GROUPS]);
    scatter(rays, keys, starts, |slot, ray, id| {
        lanes.set(slot, &ray, id)
    });
    Groups { starts, ordering }
}

/// [`prepare`] into prepared-ray records instead of lanes.
pub(crate) fn prepare_records(
    rays: &[Ray],
    ordering: BatchOrdering,
    out: &mut PreparedRays,
    keys: &mut Vec<u8>,
) -> Groups {
    let starts = group_starts(rays, ordering, keys);
    out.reserve_slots(starts[GROUPS]);
    scatter(rays, keys, starts, |slot, ray, id| out.set(slot, ray, id));
    Groups { starts, ordering }
}

/// Pass 2 of the counting sort, for either layout: `put(slot, ray, id)` for each valid ray,
/// prepared, at its place in its group.
#[inline(always)]
fn scatter(
    rays: &[Ray],
    keys: &[u8],
    starts: [usize; GROUPS + 1],
    mut put: impl FnMut(usize, PreparedRay, u32),
) {
    let mut next = starts;
    for (id, (ray, &key)) in rays.iter().zip(keys).enumerate() {
        let key = key as usize;
        if key < GROUPS {
            put(next[key], PreparedRay::from_valid(ray), id as u32);
            next[key] += 1;
        }
    }
}

/// Pass 1 of the counting sort: each ray's group into `keys` (`GROUPS` for an invalid ray)
/// and where each group starts.
fn group_starts(rays: &[Ray], ordering: BatchOrdering, keys: &mut Vec<u8>) -> [usize; GROUPS + 1] {
    let mut counts = [0usize; GROUPS + 1];
    keys.clear();
    // One pass, no branch between the validity checks (`flushed_if_valid`), no capacity check
    // per key (`extend` from an exactly sized iterator).
    keys.extend(rays.iter().map(|ray| {
        let key = match (flushed_if_valid(ray), ordering) {
            (None, _) => GROUPS,
            (Some(dir), BatchOrdering::ByOctant) => octant(dir) as usize,
            (Some(_), BatchOrdering::Unordered) => 0,
        };
        counts[key] += 1;
        key as u8
    }));
    let mut starts = [0usize; GROUPS + 1];
    for g in 0..GROUPS {
        starts[g + 1] = starts[g] + counts[g];
    }
    starts
}
