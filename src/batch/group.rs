//! Grouping a chunk's rays by direction octant, straight into lanes or prepared-ray records.
//!
//! Rays are validated and prepared once, and sorted into 8 groups with a counting sort (one
//! group when the ordering is [`BatchOrdering::Unordered`]), so that within a group every ray
//! has the same octant and a node's precomputed child order applies to all of them. A
//! structure that tests each ray against its own octant's planes (the wide trees) asks for
//! [`Grouping::LargeOctants`]: the octants that hold a quarter of the chunk keep their groups
//! (coherent rays, a camera's), the others' rays share one group of mixed octants (incoherent
//! rays: one long stream rather than eight short ones, `wide::stream::CHUNK`). Invalid
//! rays get no lane: they miss. Neither do rays that miss the structure's cull box
//! ([`crate::accel::Accel::cull_bounds`], tested on the prepared ray as the structure's own walk
//! tests it first): their answer is the blank one of [`Slots::dead`], and a group's lanes end
//! where its last kept ray went. The test and the placement are branch-free (eight rays at a
//! time with AVX2; each ray is written, and the write cursor moves past it only if it is
//! kept): 60% of the fandisk's line-of-sight segments miss its box, unpredictably, and a
//! branch per ray costs more than walking them (about 17% slower on 1M segments, any hit).

#[cfg(target_arch = "x86_64")]
use glam::Vec3;

use super::lanes::Lanes;
use super::options::BatchOrdering;
#[cfg(target_arch = "x86_64")]
use super::prepare_avx2;
use super::rays::PreparedRays;
use super::slots::{GROUPS, Placer, Slots};
use crate::geom::ray::flushed_if_valid;
use crate::geom::{Aabb, PreparedRay, Ray, octant};
#[cfg(target_arch = "x86_64")]
use crate::x86::Avx2;

/// How a chunk's rays are grouped by direction octant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Grouping {
    /// A group per octant ([`BatchOrdering::ByOctant`] for a structure that does not mix
    /// octants, [`BatchOrdering::SeparateOctants`]).
    ByOctant,
    /// A group per octant holding at least a quarter of the chunk's valid rays; the rays of
    /// the other octants in one group of mixed octants (see the module docs).
    LargeOctants,
    /// One group of mixed octants.
    Unordered,
}

impl Grouping {
    /// The grouping for a structure that wants octant groups (`by_octant`), mixing the small
    /// ones (`mix_small`), under the caller's `ordering`. For closest hit under the default
    /// ordering the thread's choice may keep the small octants apart after all
    /// ([`Grouping::asks_judge`]).
    pub(crate) fn new(ordering: BatchOrdering, by_octant: bool, mix_small: bool) -> Self {
        use BatchOrdering::{ByOctant, MixedOctants, Unordered};
        match (ordering, by_octant, mix_small) {
            (Unordered, _, _) | (_, false, _) => Grouping::Unordered,
            (ByOctant | MixedOctants, true, true) => Grouping::LargeOctants,
            _ => Grouping::ByOctant,
        }
    }

    /// Whether the thread's choice (`crate::batch::mixing`) decides between this grouping and
    /// [`Grouping::ByOctant`]: small octants mixed under the default ordering.
    pub(crate) fn asks_judge(self, ordering: BatchOrdering) -> bool {
        self == Grouping::LargeOctants && ordering == BatchOrdering::ByOctant
    }
}

/// The groups of a prepared chunk: group `g` is lanes `starts[g]..ends[g]` (`ends[g]` is at
/// most `starts[g + 1]`: rays culled while preparing leave their slots unused), its rays of
/// the octants of `masks[g]` (one bit: one octant; 0: mixed octants); bit `g` of `dense` is
/// set if it is a dense octant ([`is_dense_octant`]).
pub(crate) struct Groups {
    starts: [usize; GROUPS + 1],
    ends: [usize; GROUPS],
    masks: [u8; GROUPS],
    dense: u8,
}

impl Groups {
    /// The non-empty groups as `(start, end, octant_mask, dense)`; the mask is 0 for mixed
    /// octants, `dense` true for a dense octant.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (usize, usize, u8, bool)> + '_ {
        (0..GROUPS).filter_map(|g| {
            let (start, end) = (self.starts[g], self.ends[g]);
            let dense = self.dense >> g & 1 == 1;
            (start < end).then_some((start, end, self.masks[g], dense))
        })
    }
}

/// True if an octant holding `count` of a chunk's `valid` rays is dense: at least 3/16 of
/// them, in a chunk of at least [`DENSE_MIN_RAYS`] valid rays. Incoherent rays hold about an
/// eighth each (with 1,024 rays, 3/16 is six standard deviations above it; in much smaller
/// chunks chance alone would make some octants dense); a camera's rays, which look into at
/// most four octants (the sign of the view axis is fixed), hold a quarter or more in at least
/// one, and nearby pixels take much the same paths: such a group shares nodes well whatever
/// its length.
pub(crate) fn is_dense_octant(count: usize, valid: usize) -> bool {
    valid >= DENSE_MIN_RAYS && 16 * count >= 3 * valid
}

/// Chunks with fewer valid rays have no dense octant (see [`is_dense_octant`]).
const DENSE_MIN_RAYS: usize = 1024;

/// True if a sample of `rays` (evenly spaced, at least [`DENSE_MIN_RAYS`] of them when the batch
/// has that many) has a dense octant ([`is_dense_octant`]): a camera's rays, before the batch is
/// cut into chunks (the wide trees size their chunks by it). Invalid rays (zero or NaN
/// directions, which miss) are not counted, as the groups do not count them.
pub(crate) fn has_dense_octant(rays: &[Ray]) -> bool {
    let step = (rays.len() / DENSE_MIN_RAYS).max(1);
    let mut counts = [0usize; GROUPS];
    for dir in rays.iter().step_by(step).filter_map(flushed_if_valid) {
        counts[octant(dir) as usize] += 1;
    }
    let sampled: usize = counts.iter().sum();
    counts.iter().any(|&count| is_dense_octant(count, sampled))
}

/// Prepares the chunk's rays into `lanes`, grouped (see the module docs), those that miss
/// `cull` left out; `keys` is scratch.
pub(crate) fn prepare(
    rays: &[Ray],
    (grouping, cull): (Grouping, Option<Aabb>),
    lanes: &mut Lanes,
    (keys, slots): (&mut Vec<u8>, &mut Slots),
) -> Groups {
    let (starts, masks, dense) = group_starts(rays, grouping, keys);
    lanes.reset(starts[GROUPS]);
    let ends = scatter(rays, (keys, slots), (starts, cull), |slot, ray| {
        lanes.set(slot, &ray, slot as u32)
    });
    Groups {
        starts,
        ends,
        masks,
        dense,
    }
}

/// [`prepare`] into prepared-ray records instead of lanes. With AVX2 the eight records of a
/// step go from registers straight to their slots (`prepare_avx2::scatter_records`), where a
/// copy through a staging array took a quarter of a line-of-sight batch's preparation.
pub(crate) fn prepare_records(
    rays: &[Ray],
    (grouping, cull): (Grouping, Option<Aabb>),
    out: &mut PreparedRays,
    (keys, slots): (&mut Vec<u8>, &mut Slots),
) -> Groups {
    let (starts, masks, dense) = group_starts(rays, grouping, keys);
    out.reserve_slots(starts[GROUPS]);
    let mut placer = Placer::new(slots, starts, rays.len());
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        done = prepare_avx2::scatter_records(avx2, (rays, keys), cull.as_ref(), &mut placer, out);
    }
    scatter_rest(rays, keys, done, cull, &mut placer, |slot, ray| {
        out.set(slot, ray, slot as u32)
    });
    Groups {
        starts,
        ends: placer.next,
        masks,
        dense,
    }
}

/// Pass 2 of the counting sort for [`prepare`]'s lanes: `put(slot, ray)` for each valid ray,
/// prepared, at the slot [`Placer`] gives it. Returns where each group's kept rays end. Eight
/// rays at a time with AVX2 (the same records, the same box test).
#[inline(always)]
fn scatter(
    rays: &[Ray],
    (keys, slots): (&[u8], &mut Slots),
    (starts, cull): ([usize; GROUPS + 1], Option<Aabb>),
    mut put: impl FnMut(usize, PreparedRay),
) -> [usize; GROUPS] {
    let mut placer = Placer::new(slots, starts, rays.len());
    // Rays done eight at a time (none without AVX2).
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = Avx2::detect() {
        let mut records = [PreparedRay::from_valid(&Ray::new(Vec3::ZERO, Vec3::X)); 8];
        for (k, (eight, keys)) in rays.chunks_exact(8).zip(keys.chunks_exact(8)).enumerate() {
            let touching =
                prepare_avx2::prepare(avx2, eight.try_into().unwrap(), cull.as_ref(), &mut records);
            for (j, (&key, record)) in keys.iter().zip(&records).enumerate() {
                if let Some(slot) = placer.place(8 * k + j, key, touching >> j & 1 == 1) {
                    put(slot, *record);
                }
            }
        }
        done = rays.len() / 8 * 8;
    }
    scatter_rest(rays, keys, done, cull, &mut placer, &mut put);
    placer.next
}

/// The rays from `done` on, one at a time: prepared and `put` at the slot `placer` gives them.
#[inline(always)]
fn scatter_rest(
    rays: &[Ray],
    keys: &[u8],
    done: usize,
    cull: Option<Aabb>,
    placer: &mut Placer,
    mut put: impl FnMut(usize, PreparedRay),
) {
    for (id, (ray, &key)) in rays.iter().zip(keys).enumerate().skip(done) {
        // An invalid ray (key `GROUPS`) is not prepared; `place` gives it no slot.
        let ray = ((key as usize) < GROUPS).then(|| PreparedRay::from_valid(ray));
        let kept = ray.is_some_and(|ray| cull.is_none_or(|bounds| bounds.hit_by(&ray, ray.tmax)));
        if let (Some(slot), Some(ray)) = (placer.place(id, key, kept), ray) {
            put(slot, ray);
        }
    }
}

/// Pass 1 of the counting sort: each ray's group into `keys` (`GROUPS` for an invalid ray),
/// where each group starts and its octant mask. Eight rays at a time with AVX2 (the same keys).
fn group_starts(
    rays: &[Ray],
    grouping: Grouping,
    keys: &mut Vec<u8>,
) -> ([usize; GROUPS + 1], [u8; GROUPS], u8) {
    let by_octant = grouping != Grouping::Unordered;
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
    let mut masks = std::array::from_fn(|g| if by_octant { 1u8 << g } else { 0 });
    let valid: usize = counts[..GROUPS].iter().sum();
    let dense_octants = (0..GROUPS)
        .filter(|&g| by_octant && is_dense_octant(counts[g], valid))
        .fold(0u8, |bits, g| bits | 1 << g);
    if grouping == Grouping::LargeOctants {
        mix_small_octants(keys, (&mut counts, valid), &mut masks);
    }
    // A group that became the mixed one is no octant's.
    let dense = (0..GROUPS)
        .filter(|&g| masks[g] != 0)
        .fold(0u8, |bits, g| bits | (dense_octants & 1 << g));
    let mut starts = [0usize; GROUPS + 1];
    for g in 0..GROUPS {
        starts[g + 1] = starts[g] + counts[g];
    }
    (starts, masks, dense)
}

/// [`Grouping::LargeOctants`]: moves the rays of the octants holding less than a quarter of
/// the valid rays (if there are two such octants or more) into the group of the first of them,
/// whose mask becomes 0, and counts them there.
fn mix_small_octants(
    keys: &mut [u8],
    (counts, valid): (&mut [usize; GROUPS + 1], usize),
    masks: &mut [u8; GROUPS],
) {
    // One bit per small octant (no allocation: this runs once per chunk, per call).
    let small = (0..GROUPS)
        .filter(|&g| counts[g] > 0 && 4 * counts[g] < valid)
        .fold(0u32, |bits, g| bits | 1 << g);
    if small.count_ones() < 2 {
        return;
    }
    let mixed = small.trailing_zeros() as usize;
    // Each key's new group: the mixed one for a small octant, its own otherwise (invalid rays
    // keep key `GROUPS`).
    let mut new_key: [u8; GROUPS + 1] = std::array::from_fn(|g| g as u8);
    for g in (mixed + 1..GROUPS).filter(|&g| small >> g & 1 == 1) {
        new_key[g] = mixed as u8;
        counts[mixed] += std::mem::take(&mut counts[g]);
    }
    for key in keys.iter_mut() {
        *key = new_key[*key as usize];
    }
    masks[mixed] = 0;
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::test_support::TestRng;

    /// A camera's octants are dense, incoherent rays' are not, under every grouping that keeps
    /// octants; a group of mixed octants never is.
    #[test]
    fn dense_octants_are_a_cameras() {
        let mut rng = TestRng::new(9);
        let incoherent: Vec<Ray> = (0..4096)
            .map(|_| Ray::new(rng.vec3(3.0), rng.vec3(1.0)))
            .collect();
        // Looking down, a 64 x 64 image: a quarter of the rays in each of four octants.
        let camera: Vec<Ray> = (0..4096)
            .map(|i| {
                let (x, z) = ((i % 64) as f32 - 31.5, (i / 64) as f32 - 31.5);
                Ray::new(Vec3::new(0.0, 9.0, 0.0), Vec3::new(x, -40.0, z))
            })
            .collect();
        let mut keys = Vec::new();
        for grouping in [Grouping::ByOctant, Grouping::LargeOctants] {
            let (_, _, dense) = group_starts(&incoherent, grouping, &mut keys);
            assert_eq!(dense, 0, "{grouping:?}");
            let (_, masks, dense) = group_starts(&camera, grouping, &mut keys);
            assert_eq!(dense.count_ones(), 4, "{grouping:?}");
            assert!((0..GROUPS).all(|g| dense >> g & 1 == 0 || masks[g] == 1 << g));
        }
        let (_, _, dense) = group_starts(&camera, Grouping::Unordered, &mut keys);
        assert_eq!(dense, 0);
        // Three octants of a quarter and two of an eighth: the small two are mixed.
        let mut lopsided = camera[..3072].to_vec();
        lopsided.extend((0..1024).map(|i| {
            let y = if i % 2 == 0 { 1.0 } else { -1.0 };
            Ray::new(Vec3::ZERO, Vec3::new(-1.0, y, 1.0))
        }));
        let (_, masks, dense) = group_starts(&lopsided, Grouping::LargeOctants, &mut keys);
        assert_eq!(dense.count_ones(), 3);
        assert!((0..GROUPS).all(|g| dense >> g & 1 == 0 || masks[g] != 0));
        assert!(is_dense_octant(192, 1024) && !is_dense_octant(191, 1024));
        assert!(!is_dense_octant(3, 16) && !is_dense_octant(0, 0));
        // A dense octant that holds less than a quarter, and is the first of the small ones,
        // becomes the mixed group: no octant's, so not dense (3/16 and 1/16 mixed, three
        // quarters apart).
        let dir = |octant: usize| {
            let sign = |bit: usize| if octant >> bit & 1 == 1 { -1.0 } else { 1.0 };
            Vec3::new(sign(0), sign(1), sign(2))
        };
        let shares = [(0, 768), (1, 256), (2, 1024), (3, 1024), (4, 1024)];
        let rays: Vec<Ray> = shares
            .iter()
            .flat_map(|&(octant, n)| std::iter::repeat_n(Ray::new(Vec3::ZERO, dir(octant)), n))
            .collect();
        let (_, masks, dense) = group_starts(&rays, Grouping::LargeOctants, &mut keys);
        assert_eq!(masks[0], 0, "octants 0 and 1 are mixed");
        assert_eq!(dense, 0b11100);
        let (_, _, dense) = group_starts(&rays, Grouping::ByOctant, &mut keys);
        assert_eq!(dense, 0b11101);
    }

    /// Rays that miss the cull box get no lane (their position maps to the dead slot), the
    /// others keep theirs, in their octant's group, with their prepared record; a chunk whose
    /// length is not a multiple of eight runs both the eight-at-a-time and the one-at-a-time
    /// placement.
    #[test]
    fn culled_rays_get_the_dead_slot() {
        let bounds = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let mut rng = TestRng::new(5);
        let rays: Vec<Ray> = (0..1003)
            .map(|i| {
                let dir = if i % 97 == 0 {
                    Vec3::ZERO
                } else {
                    rng.vec3(1.0)
                };
                Ray::new(rng.vec3(3.0), dir)
            })
            .collect();
        let mut out = PreparedRays::default();
        let (mut keys, mut slots) = (Vec::new(), Slots::default());
        let cull = (Grouping::ByOctant, Some(bounds));
        let groups = prepare_records(&rays, cull, &mut out, (&mut keys, &mut slots));
        let dead = slots.dead() as u32;
        let mut kept = 0;
        for (id, ray) in rays.iter().enumerate() {
            let slot = slots.of_position[id];
            match PreparedRay::new(ray) {
                None => assert_eq!(slot, Slots::NONE, "invalid ray {id}"),
                Some(p) if !bounds.hit_by(&p, p.tmax) => assert_eq!(slot, dead, "ray {id}"),
                Some(p) => {
                    kept += 1;
                    let slot = slot as usize;
                    assert_eq!(slots.positions[slot], id as u32);
                    assert_eq!(out.rays[slot].origin, p.origin);
                    assert_eq!(out.rays[slot].inv_dir, p.inv_dir);
                    let (_, _, mask, _) = groups
                        .iter()
                        .find(|&(start, end, ..)| (start..end).contains(&slot))
                        .expect("a kept ray lies in a group");
                    assert_eq!(mask, p.octant_mask, "ray {id}");
                }
            }
        }
        let in_groups: usize = groups.iter().map(|(start, end, ..)| end - start).sum();
        assert_eq!(in_groups, kept);
        assert!(kept > 100 && rays.len() - kept > 100, "{kept} kept");
    }

    /// The ordering picks the grouping: a structure that mixes small octants gets
    /// [`Grouping::LargeOctants`] under [`BatchOrdering::MixedOctants`], a group per octant
    /// under [`BatchOrdering::SeparateOctants`], and what the thread's choice says under
    /// [`BatchOrdering::ByOctant`] (the only ordering that asks it); a structure that does not
    /// mix, a group per octant under all three; one that does not group by octant, one group
    /// whatever the ordering.
    #[test]
    fn the_ordering_picks_the_grouping() {
        use BatchOrdering::{ByOctant, MixedOctants, SeparateOctants, Unordered};
        use Grouping as G;
        // (ordering, by octant, mixes small, grouping when the judge mixes, when it does not)
        for (ordering, by_octant, mix_small, mixing, separate) in [
            (ByOctant, true, true, G::LargeOctants, G::ByOctant),
            (MixedOctants, true, true, G::LargeOctants, G::LargeOctants),
            (SeparateOctants, true, true, G::ByOctant, G::ByOctant),
            (ByOctant, true, false, G::ByOctant, G::ByOctant),
            (MixedOctants, true, false, G::ByOctant, G::ByOctant),
            (SeparateOctants, true, false, G::ByOctant, G::ByOctant),
            (Unordered, true, true, G::Unordered, G::Unordered),
            (SeparateOctants, false, true, G::Unordered, G::Unordered),
            (ByOctant, false, true, G::Unordered, G::Unordered),
        ] {
            let case = format!("{ordering:?} {by_octant} {mix_small}");
            let grouping = Grouping::new(ordering, by_octant, mix_small);
            assert_eq!(grouping, mixing, "{case}");
            let asks = grouping.asks_judge(ordering);
            let apart = if asks { G::ByOctant } else { grouping };
            assert_eq!(apart, separate, "{case}");
            assert_eq!(asks, mixing != separate, "{case}");
        }
    }

    /// [`Grouping::LargeOctants`]: an octant holding a quarter of the valid rays or more keeps
    /// its group and mask; the rays of the others share one group of mask 0 (unless only one
    /// octant is small: it keeps its own); every valid ray lies in one group, invalid ones in
    /// none.
    #[test]
    fn small_octants_share_one_mixed_group() {
        let mut rng = TestRng::new(9);
        // Directions of octant `o`: signs from its bits, some components zero (-0.0 counts as
        // negative).
        let dir = |rng: &mut TestRng, o: u32| {
            let mut d = rng.vec3(1.0).abs() + Vec3::splat(0.1);
            if rng.range(0.0, 1.0) < 0.1 {
                d.y = 0.0;
            }
            Vec3::from_array(std::array::from_fn(|a| {
                if o >> a & 1 == 1 { -d[a] } else { d[a] }
            }))
        };
        // Shares of the octants (out of 100): (octant, share); and the groups expected: (mask,
        // share).
        type Shares = &'static [(u32, usize)];
        type Expected = &'static [(u8, usize)];
        let cases: [(Shares, Expected); 4] = [
            (
                &[
                    (0, 13),
                    (1, 13),
                    (2, 12),
                    (3, 12),
                    (4, 13),
                    (5, 12),
                    (6, 13),
                    (7, 12),
                ],
                &[(0, 100)],
            ),
            (&[(5, 97), (6, 3)], &[(1 << 5, 97), (1 << 6, 3)]),
            (
                &[(7, 60), (1, 20), (2, 10), (3, 10)],
                &[(1 << 7, 60), (0, 40)],
            ),
            (
                &[(0, 25), (4, 25), (2, 50)],
                &[(1, 25), (1 << 4, 25), (1 << 2, 50)],
            ),
        ];
        for (shares, expected) in cases {
            let mut rays: Vec<Ray> = Vec::new();
            for &(octant, share) in shares {
                for _ in 0..share * 10 {
                    rays.push(Ray::new(rng.vec3(3.0), dir(&mut rng, octant)));
                }
            }
            rays.push(Ray::new(Vec3::ZERO, Vec3::ZERO));
            let mut out = PreparedRays::default();
            let (mut keys, mut slots) = (Vec::new(), Slots::default());
            let grouping = (Grouping::LargeOctants, None);
            let groups = prepare_records(&rays, grouping, &mut out, (&mut keys, &mut slots));
            let mut found: Vec<(u8, usize)> = groups
                .iter()
                .map(|(start, end, mask, _)| (mask, end - start))
                .collect();
            found.sort_by_key(|&(mask, _)| mask);
            let mut expected: Vec<(u8, usize)> = expected
                .iter()
                .map(|&(mask, share)| (mask, share * 10))
                .collect();
            expected.sort_by_key(|&(mask, _)| mask);
            assert_eq!(found, expected, "shares {shares:?}");
            // Every valid ray in one slot of one group, its own record there.
            let mut seen = vec![false; rays.len()];
            for (start, end, mask, _) in groups.iter() {
                for slot in start..end {
                    let (id, ray) = (slots.positions[slot] as usize, &out.rays[slot]);
                    assert!(!std::mem::replace(&mut seen[id], true), "ray {id} twice");
                    assert_eq!(slots.of_position[id] as usize, slot);
                    assert_eq!(ray.origin, rays[id].origin);
                    assert!(mask == 0 || mask == ray.octant_mask, "mask {mask}");
                }
            }
            assert_eq!(seen.iter().filter(|&&s| s).count(), rays.len() - 1);
            assert_eq!(slots.of_position[rays.len() - 1], Slots::NONE);
        }
    }
}
