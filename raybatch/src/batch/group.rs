//! Grouping a chunk's rays by direction octant, straight into lanes or prepared-ray records.
//!
//! Rays are validated and prepared once, and sorted into 8 groups with a counting sort (one
//! group when the ordering is [`BatchOrdering::Unordered`]), so that within a group every ray
//! has the same octant and a node's precomputed child order applies to all of them. Invalid
//! rays get no lane: they miss.

#[cfg(target_arch = "x86_64")]
use glam::Vec3;

use super::lanes::Lanes;
use super::options::BatchOrdering;
#[cfg(target_arch = "x86_64")]
use super::prepare_avx2;
use super::rays::PreparedRays;
use crate::geom::ray::flushed_if_valid;
use crate::geom::{PreparedRay, Ray, octant};
#[cfg(target_arch = "x86_64")]
use crate::x86::Avx2;

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
    (keys, slots): (&mut Vec<u8>, &mut Slots),
) -> Groups {
    let starts = group_starts(rays, ordering, keys);
    lanes.reset(starts[GROUPS]);
    scatter(rays, (keys, slots), starts, |slot, ray| {
        lanes.set(slot, &ray, slot as u32)
    });
    Groups { starts, ordering }
}

/// [`prepare`] into prepared-ray records instead of lanes.
pub(crate) fn prepare_records(
    rays: &[Ray],
    ordering: BatchOrdering,
    out: &mut PreparedRays,
    (keys, slots): (&mut Vec<u8>, &mut Slots),
) -> Groups {
    let starts = group_starts(rays, ordering, keys);
    out.reserve_slots(starts[GROUPS]);
    scatter(rays, (keys, slots), starts, |slot, ray| {
        out.set(slot, ray, slot as u32)
    });
    Groups { starts, ordering }
}

/// Where each ray of a chunk went: the streams carry prepared slots as ray ids, so that the
/// answers a walk writes (by id) sit next to each other in memory; answers by position would
/// be spread over the whole batch, one cache and TLB miss per hit on a large batch (fandisk,
/// 1M incoherent rays, one thread: 95-98 -> 87-94 ms).
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
}

/// Pass 2 of the counting sort, for either layout: `put(slot, ray)` for each valid ray,
/// prepared, at its place in its group, and both ways between slots and positions in `slots`.
/// Eight rays at a time with AVX2 (the same records).
#[inline(always)]
fn scatter(
    rays: &[Ray],
    (keys, slots): (&[u8], &mut Slots),
    starts: [usize; GROUPS + 1],
    mut put: impl FnMut(usize, PreparedRay),
) {
    let Slots {
        positions,
        of_position,
    } = slots;
    positions.clear();
    positions.resize(starts[GROUPS], 0);
    of_position.clear();
    of_position.resize(rays.len(), Slots::NONE);
    let mut next = starts;
    let mut place = |id: usize, key: u8, ray: PreparedRay| {
        let key = key as usize;
        if key < GROUPS {
            put(next[key], ray);
            positions[next[key]] = id as u32;
            of_position[id] = next[key] as u32;
            next[key] += 1;
        }
    };
    // Rays done eight at a time (none without AVX2).
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        let mut records = [PreparedRay::from_valid(&Ray::new(Vec3::ZERO, Vec3::X)); 8];
        for (k, (eight, keys)) in rays.chunks_exact(8).zip(keys.chunks_exact(8)).enumerate() {
            prepare_avx2::prepare(avx2, eight.try_into().unwrap(), &mut records);
            for (j, (&key, record)) in keys.iter().zip(&records).enumerate() {
                place(8 * k + j, key, *record);
            }
        }
        done = rays.len() / 8 * 8;
    }
    for (id, (ray, &key)) in rays.iter().zip(keys).enumerate().skip(done) {
        if (key as usize) < GROUPS {
            place(id, key, PreparedRay::from_valid(ray));
        }
    }
}

/// Pass 1 of the counting sort: each ray's group into `keys` (`GROUPS` for an invalid ray)
/// and where each group starts. Eight rays at a time with AVX2 (the same keys).
fn group_starts(rays: &[Ray], ordering: BatchOrdering, keys: &mut Vec<u8>) -> [usize; GROUPS + 1] {
    let by_octant = matches!(ordering, BatchOrdering::ByOctant);
    keys.clear();
    keys.resize(rays.len(), 0);
    // Rays done eight at a time (none without AVX2).
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        for (out, eight) in keys.chunks_exact_mut(8).zip(rays.chunks_exact(8)) {
            let eight = eight.try_into().unwrap();
            out.copy_from_slice(&prepare_avx2::keys(avx2, eight, by_octant, GROUPS as u8));
        }
        done = rays.len() / 8 * 8;
    }
    for (key, ray) in keys.iter_mut().zip(rays).skip(done) {
        *key = match flushed_if_valid(ray) {
            None => GROUPS as u8,
            Some(dir) if by_octant => octant(dir) as u8,
            Some(_) => 0,
        };
    }
    let mut counts = [0usize; GROUPS + 1];
    for &key in keys.iter() {
        counts[key as usize] += 1;
    }
    let mut starts = [0usize; GROUPS + 1];
    for g in 0..GROUPS {
        starts[g + 1] = starts[g] + counts[g];
    }
    starts
}
