//! Whether a thread's closest-hit chunks walk their small octants mixed: chosen from the hits
//! the chunks' walks reported.
//!
//! The wide trees walk the rays of the octants that hold less than a quarter of a chunk as one
//! mixed stream (`Accel::MIXES_SMALL_OCTANTS`): for incoherent rays one long stream shares
//! more nodes than eight short ones. But a mixed stream meets each node's children in slot
//! order, not nearest first, so a closest-hit ray may find far surfaces before its nearest
//! one, each hit replacing the last. Street-level sightlines in the city pass many buildings
//! and run more than twice as fast with every octant apart (`bvh4`, docs/benchmarks.md).
//! Segments and rays from outside an object meet its near and far sides and run a few percent
//! faster apart in short chunks. Incoherent rays from inside, short rays and camera rays run
//! faster mixed.
//!
//! The count that tells them apart costs one add per reported hit: the hits a chunk's walk
//! reported per ray that has a hit. Walked mixed, sightlines that pass many surfaces report
//! several hits per hitting ray; walked apart, about one. So a chunk walks
//! apart when the last chunk walked mixed reported more than [`MANY_REPORTED`] hits per hit,
//! or, in chunks of at most [`SHORT_CHUNK`] rays, more than [`MIXING_EXCESS`] times what the
//! last chunk walked apart reported. One chunk in every [`PROBE_EVERY`] + 1 walks the other
//! way, to keep both counts fresh when the rays change (and the chunk after the first counted
//! one, to have both early). Only the default ordering ([`super::BatchOrdering::ByOctant`])
//! asks.
//!
//! The counts are per thread (in its workspace), shared by every structure and call on it: a
//! thread that alternates sightlines and incoherent rays, or two trees, judges from their mix
//! until a probe catches up (a caller who knows its rays can name the grouping,
//! [`super::BatchOrdering::SeparateOctants`] or [`super::BatchOrdering::MixedOctants`]). No
//! answer ever depends on them: both groupings give the same answers, bit for bit.

/// Reported hits per hitting ray of a mixed chunk above which its rays pass many surfaces
/// (between 1.94 and 8.3: the most of every measured set but the city's sightlines, and
/// those sightlines' least).
const MANY_REPORTED: f32 = 3.0;

/// How many times the apart count the mixed count must be for a short chunk to walk apart
/// (between 1.27, the most for incoherent rays, and 1.52, the least for line-of-sight and
/// outside-in rays).
const MIXING_EXCESS: f32 = 1.4;

/// Chunks of at most this many rays are short: their mixed streams gain less from sharing
/// nodes (in calls of 32,768 rays, outside-in rays already run faster mixed;
/// docs/benchmarks.md).
const SHORT_CHUNK: usize = 16_384;

/// Chunks between two walked against the judge's preference. A probe costs one chunk walked
/// the slow way in `PROBE_EVERY + 1`: about 4% on the city's sightlines in calls of 4,096 rays
/// (one chunk a call).
const PROBE_EVERY: u32 = 32;

/// Fewer rays with a hit than this in a chunk say nothing: its count is not kept.
const MIN_HITTING_RAYS: u64 = 64;

/// One thread's counts (see the module docs). It starts mixed, and walks the chunk after its
/// first counted one apart, to have both counts early.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct MixingJudge {
    /// Reported hits per hitting ray of the last counted chunk walked mixed.
    mixed: Option<f32>,
    /// The same for the last counted chunk walked apart.
    apart: Option<f32>,
    /// Chunks walked since the last probe.
    since_probe: u32,
}

impl MixingJudge {
    /// Whether the counts so far say that a chunk of `rays` rays walks faster apart.
    pub(crate) fn prefers_apart(&self, rays: usize) -> bool {
        match (self.mixed, self.apart) {
            (Some(mixed), _) if mixed > MANY_REPORTED => true,
            (Some(mixed), Some(apart)) => rays <= SHORT_CHUNK && mixed > MIXING_EXCESS * apart,
            _ => false,
        }
    }

    /// Whether the next chunk walks against the preference, to refresh the other count.
    fn probe_due(&self) -> bool {
        self.since_probe >= PROBE_EVERY
    }

    /// Whether the next chunk, of `rays` rays, walks its small octants mixed: as preferred, or
    /// the other way for a probe.
    pub(crate) fn choose(&self, rays: usize) -> bool {
        let apart = self.prefers_apart(rays);
        if self.probe_due() { apart } else { !apart }
    }

    /// Records the chunk [`MixingJudge::choose`] was last asked about, walked `mixed` or not,
    /// whose walk reported `reported` hits to its rays, `hitting` of which have a hit.
    pub(crate) fn record(&mut self, mixed: bool, reported: u64, hitting: u64) {
        self.since_probe = if self.probe_due() {
            0
        } else {
            self.since_probe.saturating_add(1)
        };
        if hitting < MIN_HITTING_RAYS {
            return;
        }
        let count = reported as f32 / hitting as f32;
        if !mixed {
            self.apart = Some(count);
            return;
        }
        // The first count: the next chunk probes apart, unless mixing is already ruled out.
        if self.mixed.is_none() && self.apart.is_none() && count <= MANY_REPORTED {
            self.since_probe = PROBE_EVERY;
        }
        self.mixed = Some(count);
    }
}

/// A chunk grouped as the judge chose: told the chunk's counts after its walk.
pub(crate) struct JudgedChunk<'w> {
    pub(crate) judge: &'w mut MixingJudge,
    /// The chunk's small octants share one stream.
    pub(crate) mixed: bool,
}

impl JudgedChunk<'_> {
    /// Hands the judge the chunk's counts ([`MixingJudge::record`]).
    pub(crate) fn record(self, reported: u64, hitting: u64) {
        self.judge.record(self.mixed, reported, hitting);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::TestRng;

    /// Walks `chunks` chunks of `rays` rays whose walks report `mixed` hits per hitting ray
    /// when mixed and `apart` when apart (1,000 hitting rays each); returns how many walked
    /// mixed.
    fn walk(
        judge: &mut MixingJudge,
        chunks: usize,
        rays: usize,
        (mixed, apart): (f32, f32),
    ) -> usize {
        let mut walked_mixed = 0;
        for _ in 0..chunks {
            let mixes = judge.choose(rays);
            let per_hit = if mixes { mixed } else { apart };
            judge.record(mixes, (per_hit * 1_000.0) as u64, 1_000);
            walked_mixed += usize::from(mixes);
        }
        walked_mixed
    }

    /// The first chunk walks mixed and the second apart (a probe); then the preference holds
    /// but for one probe every `PROBE_EVERY + 1` chunks. Chunks that count nothing (too few
    /// hitting rays) delay the first probe.
    #[test]
    fn probes_come_second_and_then_every_so_often() {
        let mut judge = MixingJudge::default();
        let first = judge.choose(4_096);
        assert!(first && !judge.probe_due());
        judge.record(first, 10, 10);
        assert!(
            judge.choose(4_096) && !judge.probe_due(),
            "nothing counted yet"
        );
        judge.record(first, 1_200, 1_000);
        let second = judge.choose(4_096);
        assert!(!second && judge.probe_due());
        judge.record(second, 1_000, 1_000);
        let n = 10 * (PROBE_EVERY as usize + 1);
        assert_eq!(
            walk(&mut judge, n, 4_096, (1.2, 1.0)),
            n - 10,
            "mixed but ten probes"
        );
    }

    /// Many reported hits per hit walked mixed: apart, whatever the chunk length, but for the
    /// probes; the rays changing back: mixed again after the next probe.
    #[test]
    fn many_reported_hits_walk_apart() {
        for rays in [4_096, 65_536] {
            let mut judge = MixingJudge::default();
            let n = 10 * (PROBE_EVERY as usize + 1);
            assert_eq!(walk(&mut judge, 2, rays, (8.3, 1.22)), 1);
            assert!(judge.prefers_apart(rays));
            assert_eq!(
                walk(&mut judge, n, rays, (8.3, 1.22)),
                10,
                "apart but ten probes"
            );
            walk(&mut judge, PROBE_EVERY as usize + 1, rays, (1.2, 1.0));
            assert!(!judge.prefers_apart(rays), "{rays} rays");
        }
    }

    /// Mixing multiplying the reported hits by more than `MIXING_EXCESS`: apart in short
    /// chunks only; by less (incoherent rays, the city's): mixed.
    #[test]
    fn a_mixing_excess_walks_short_chunks_apart() {
        for ((mixed, apart), rays, expect_apart) in [
            ((1.55, 1.0), 4_096, true),
            ((1.55, 1.0), SHORT_CHUNK, true),
            ((1.55, 1.0), 65_536, false),
            ((1.27, 1.0), 4_096, false),
            ((1.60, 1.41), 4_096, false),
            ((1.94, 1.41), 4_096, false),
        ] {
            let mut judge = MixingJudge::default();
            walk(&mut judge, 3, rays, (mixed, apart));
            let case = format!("{mixed} / {apart}, {rays} rays");
            assert_eq!(judge.prefers_apart(rays), expect_apart, "{case}");
        }
    }

    /// Chunks with too few hitting rays after the first count (the probe apart among them,
    /// counting nothing) keep to the schedule: one probe every `PROBE_EVERY + 1` chunks.
    #[test]
    fn chunks_that_count_nothing_keep_the_schedule() {
        let mut judge = MixingJudge::default();
        let first = judge.choose(4_096);
        judge.record(first, 1_200, 1_000);
        let n = 10 * (PROBE_EVERY as usize + 1);
        let mut apart = 0;
        for _ in 0..n {
            let mixes = judge.choose(4_096);
            judge.record(mixes, 10, 10);
            apart += usize::from(!mixes);
        }
        assert_eq!(apart, 10, "{judge:?}");
        assert_eq!(judge.apart, None);
    }

    /// Chunks with fewer than `MIN_HITTING_RAYS` hitting rays leave the counts alone.
    #[test]
    fn few_hitting_rays_count_nothing() {
        let mut judge = MixingJudge::default();
        let choice = judge.choose(4_096);
        judge.record(choice, 600, MIN_HITTING_RAYS - 1);
        assert_eq!(judge.mixed, None);
        judge.record(choice, 600, MIN_HITTING_RAYS);
        assert!(judge.mixed.is_some());
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
        type Scratch = <crate::WideTree as crate::accel::Accel>::Scratch;
        crate::workspace::Workspace::with_local(|w| w.parts::<Scratch>().0.mixing)
    }

    /// Casts `rays` in one batched call on this thread; checks the answers against the one-ray
    /// ones.
    fn cast_checked(tree: &crate::WideTree, rays: &[crate::Ray]) {
        use crate::{BatchQueries, RayQueries};
        let options = crate::BatchOptions::default().with_parallel(false);
        let mut hits = vec![None; rays.len()];
        tree.cast_ray_batch_with(rays, &mut hits, &options)
            .expect("sized");
        for (ray, hit) in rays.iter().zip(&hits) {
            assert_eq!(*hit, tree.cast_ray(ray), "{ray:?}");
        }
    }

    /// Sightlines across the row of walls from either end, walked mixed, report a hit per
    /// wall the slot order meets before the nearest: after the first chunks the thread prefers
    /// the octants apart. Segments that reach one wall each leave it mixed. Answers equal the
    /// one-ray answers throughout.
    #[test]
    fn sightlines_through_many_walls_walk_apart() {
        let tree = walls();
        let short = rays_along_x(4_096, |k| (k % 63) as f32 + 1.5, 1.0);
        for _ in 0..3 {
            cast_checked(&tree, &short);
        }
        let judge = thread_judge();
        assert!(!judge.prefers_apart(4_096), "one wall per segment: mixed");
        for count in [judge.mixed, judge.apart] {
            assert!(count.is_some_and(|c| (1.0..1.1).contains(&c)), "{judge:?}");
        }
        let across = rays_along_x(4_096, |k| if k % 2 == 0 { 0.0 } else { 65.0 }, 100.0);
        for _ in 0..3 {
            cast_checked(&tree, &across);
        }
        assert!(
            thread_judge().prefers_apart(4_096),
            "many walls per sightline: apart"
        );
        assert!(
            thread_judge().prefers_apart(1 << 20),
            "whatever the chunk length"
        );
    }
}
