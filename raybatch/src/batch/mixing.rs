//! Whether a thread's closest-hit chunks walk their small octants mixed: chosen from the hits
//! the last chunks reported.
//!
//! The wide trees walk the rays of the octants that hold less than a quarter of a chunk as one
//! mixed stream (`Accel::MIXES_SMALL_OCTANTS`): for incoherent rays one long stream shares
//! more nodes than eight short ones. But a mixed stream meets each node's children in slot
//! order, not nearest first, and a closest-hit ray that passes many surfaces before its
//! nearest one then finds the far ones first, each hit replacing the last. Street-level
//! sightlines in the city do (twenty-third session, `bvh4`, ratios to Embree): mixed, 0.74 in
//! one call and 0.52 in calls of 4,096 rays; every octant apart, 1.93 and 1.21. Every other ray
//! set measured runs faster mixed (incoherent, short, outside-in rays on four meshes).
//!
//! The count that tells them apart costs one add per reported hit: the hits a chunk's walk
//! reported per ray that has a hit. Walked mixed, the city's sightlines report 8.3-9.9 (calls
//! of 4,096 rays; one call); every other set 1.0-1.94; walked octant by octant, every set
//! 1.0-1.41. So a chunk walked mixed that reports more than [`REPORTED_PER_HIT`] sends the
//! thread's next [`SEPARATE_CHUNKS`] chunks octant by octant, and the chunk after them mixed
//! again, to look whether the rays have changed. Only the default ordering
//! ([`super::BatchOrdering::ByOctant`]) asks; the state is per thread (in its workspace), so
//! rays that a thread answers decide for it, and no answer ever depends on it.

/// Reported hits per ray with a hit above which a mixed chunk's rays are judged to pass many
/// surfaces (between 1.94 and 8.3, the measured sets' worst and the sightlines', above).
const REPORTED_PER_HIT: u64 = 3;

/// Chunks a thread walks octant by octant before it tries mixing again. A probe in the bad
/// case costs one slow chunk in `SEPARATE_CHUNKS + 1`: on the city's sightlines in calls of
/// 4,096 rays (one chunk a call), 1.21 -> about 1.16 of Embree.
const SEPARATE_CHUNKS: u32 = 32;

/// Fewer rays with a hit than this in a chunk say nothing: the chunk does not change the
/// choice.
const MIN_HITTING_RAYS: u64 = 64;

use crate::hit::{Closest, Hit, Visitor};

/// One thread's choice (see the module docs); starts mixed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct MixingJudge {
    /// Chunks still to walk octant by octant; 0: mix.
    separate_left: u32,
}

impl MixingJudge {
    /// Whether the next chunk should walk its small octants mixed.
    pub(crate) fn mixes(&self) -> bool {
        self.separate_left == 0
    }

    /// Records a chunk walked mixed or not (as [`MixingJudge::mixes`] said) whose walk reported
    /// `reported` hits to its rays, `hitting` of which have a hit.
    pub(crate) fn record(&mut self, mixed: bool, reported: u64, hitting: u64) {
        if !mixed {
            self.separate_left = self.separate_left.saturating_sub(1);
        } else if hitting >= MIN_HITTING_RAYS && reported > REPORTED_PER_HIT * hitting {
            self.separate_left = SEPARATE_CHUNKS;
        }
    }
}

/// A chunk grouped as the judge said: told the chunk's counts after its walk.
pub(crate) struct JudgedChunk<'w> {
    pub(crate) judge: &'w mut MixingJudge,
    /// The chunk's small octants were walked mixed.
    pub(crate) mixed: bool,
}

impl JudgedChunk<'_> {
    /// Hands the judge the chunk's counts ([`MixingJudge::record`]).
    pub(crate) fn record(self, reported: u64, hitting: u64) {
        self.judge.record(self.mixed, reported, hitting);
    }
}

/// [`Closest`] that counts the hits reported to it: the judge's count, one add per hit.
pub(crate) struct TallyingClosest<'a> {
    pub(crate) closest: Closest<'a>,
    pub(crate) reported: u64,
}

impl Visitor for TallyingClosest<'_> {
    #[inline(always)]
    fn visit(&mut self, ray: u32, hit: Hit, tmax: &mut f32) {
        self.reported += 1;
        self.closest.visit(ray, hit, tmax);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;

    /// Mixed until a mixed chunk reports many hits per hitting ray; then `SEPARATE_CHUNKS`
    /// chunks apart, and a mixed one again, which decides anew. Chunks with few hitting rays
    /// change nothing.
    #[test]
    fn many_reported_hits_separate_the_octants_for_a_while() {
        let mut judge = MixingJudge::default();
        assert!(judge.mixes());
        judge.record(true, 1_940, 1_000);
        assert!(judge.mixes(), "1.94 reported hits per hit: stays mixed");
        judge.record(true, 600, 63);
        assert!(judge.mixes(), "too few hitting rays to judge");
        judge.record(true, 3_001, 1_000);
        for _ in 0..SEPARATE_CHUNKS {
            assert!(!judge.mixes());
            judge.record(false, 1_000, 1_000);
        }
        assert!(judge.mixes(), "a mixed chunk again, to look");
        judge.record(true, 8_000, 1_000);
        assert!(!judge.mixes(), "the rays still pass many surfaces");
        for _ in 0..SEPARATE_CHUNKS {
            judge.record(false, 0, 0);
        }
        judge.record(true, 1_200, 1_000);
        assert!(judge.mixes(), "the rays changed: mixed stays");
    }

    /// 64 walls, squares across x = 1..=64 (two triangles each).
    fn walls() -> crate::WideTree {
        let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
        for k in 1..=64u32 {
            let x = k as f32;
            for (y, z) in [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)] {
                vertices.push(glam::Vec3::new(x, y, z));
            }
            let v = 4 * (k - 1);
            triangles.extend([[v, v + 1, v + 2], [v, v + 2, v + 3]]);
        }
        let mesh = crate::Mesh::new(vertices, triangles).expect("a valid mesh");
        crate::WideTree::build(mesh, &crate::BuildOptions::default()).expect("a small tree")
    }

    /// `n` rays along x, half each way, their y and z slopes small and of every sign (every
    /// octant holds an eighth of them: one mixed stream), starting at `x(k)` for ray `k` and
    /// `length` long.
    fn rays_along_x(n: usize, x: impl Fn(usize) -> f32, length: f32) -> Vec<crate::Ray> {
        let mut rng = TestRng::new(17);
        (0..n)
            .map(|k| {
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                let dir = glam::Vec3::new(sign, rng.range(-0.05, 0.05), rng.range(-0.05, 0.05));
                let origin = glam::Vec3::new(x(k), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
                crate::Ray::with_range(origin, dir, 0.0, length)
            })
            .collect()
    }

    /// This thread's choice.
    fn thread_judge() -> MixingJudge {
        type Scratch = <crate::WideTree as crate::Accel>::Scratch;
        crate::workspace::Workspace::with_local(|w| w.parts::<Scratch>().0.mixing)
    }

    /// Casts `rays` in one batched call on this thread; checks the answers against the one-ray
    /// ones.
    fn cast_checked(tree: &crate::WideTree, rays: &[crate::Ray]) {
        use crate::{BatchQueries, RayQueries};
        let options = crate::BatchOptions::default().with_parallel(false);
        let mut hits = vec![None; rays.len()];
        tree.cast_rays_with(rays, &mut hits, &options)
            .expect("sized");
        for (ray, hit) in rays.iter().zip(&hits) {
            assert_eq!(*hit, tree.cast_ray(ray), "{ray:?}");
        }
    }

    /// Sightlines across the row of walls from either end, walked mixed, report a hit per
    /// wall the slot order meets before the nearest: the thread's next chunks keep the octants
    /// apart. Segments that reach one wall each leave the choice mixed. Answers equal the
    /// one-ray answers throughout.
    #[test]
    fn sightlines_through_many_walls_separate_the_octants() {
        let tree = walls();
        let short = rays_along_x(4_096, |k| (k % 63) as f32 + 1.5, 1.0);
        cast_checked(&tree, &short);
        assert!(thread_judge().mixes(), "one wall per segment: mixed");
        let across = rays_along_x(4_096, |k| if k % 2 == 0 { 0.0 } else { 65.0 }, 100.0);
        cast_checked(&tree, &across);
        assert!(!thread_judge().mixes(), "many walls per sightline: apart");
        cast_checked(&tree, &across);
        assert!(!thread_judge().mixes(), "apart for a while");
    }
}
