//! The race: the headline rows (Embree's one-ray calls, raybatch per ray, batched and in calls
//! of 4,096, for the 4-wide, 8-wide and quantized 8-wide trees), built once per ray set and
//! timed pass by pass in turn, round `r` starting with contender `r` (so `R` at least the
//! number of rows lets each go first once), best pass kept. Each pass writes one answer per
//! ray (hit or not, occluded or not) into a buffer made before the timing; the rows are
//! checked against the first on those answers only (the full table compares distances and
//! triangles too). (tinybvh stays in the full table only: its tree, built beside the others
//! here, crashes in tinybvh-rs's ray setup.)
//!
//! The full table times each library's passes back to back, so on a machine whose speed drifts
//! (a shared VM: the same pass took 200 and 340 ms within an hour here) one library may get a
//! fast phase and the next a slow one, and the ratios swing. Taking turns spreads every phase
//! over every contender; the ratio of two best passes then holds where separate runs drift.

use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

use raybatch::{
    AccelKind, AnyAccel, BatchOptions, BatchOrdering, BatchQueries, BuildOptions, Hit, Mesh, Ray,
    RayQueries,
};

use crate::embree_ffi as rtc;
use crate::engines::{EMBREE_QUALITY, FRAME_CALL, raybatch_batched_engine, raybatch_engine};

/// One timed pass over every ray, which writes, per ray, whether it hit (closest hit) or is
/// occluded (any hit).
type Pass<'a> = Box<dyn FnMut(&mut [bool]) + 'a>;

/// One contender: its row name and its pass.
struct Contender<'a> {
    name: String,
    pass: Pass<'a>,
}

/// A contender's result: its best pass and how many rays it answered otherwise than the
/// first contender (Embree).
pub struct Placing {
    pub name: String,
    pub best: Duration,
    pub disagreements: usize,
}

/// Races the closest-hit rows (and with `any_hit` the any-hit rows) over `rays`, `rounds`
/// rounds; Embree's one-ray call is the first row of each.
pub fn race(
    device: &rtc::Device,
    mesh: &Arc<Mesh>,
    rays: &[Ray],
    rounds: usize,
    any_hit: bool,
) -> Result<Vec<(&'static str, Vec<Placing>)>, String> {
    let options = BuildOptions::default().with_parallel(false);
    let build = |kind: AccelKind| {
        kind.build(Arc::clone(mesh), &options)
            .map_err(|e| format!("raybatch build: {e}"))
    };
    let bvh4 = (AccelKind::Bvh4, build(AccelKind::Bvh4)?);
    let bvh8 = (AccelKind::Bvh8, build(AccelKind::Bvh8)?);
    let bvh8q = (AccelKind::Bvh8q, build(AccelKind::Bvh8q)?);
    let scene = rtc::Scene::triangles(
        device,
        mesh.vertices(),
        mesh.triangles(),
        EMBREE_QUALITY,
        rtc::RTC_SCENE_FLAG_NONE,
    )?;
    let native: Vec<rtc::RTCRay> = rays
        .iter()
        .map(|r| rtc::RTCRay::new(r.origin, r.dir, r.tmin, r.tmax))
        .collect();

    let mut closest = vec![Contender {
        name: "Embree rtcIntersect1".into(),
        pass: Box::new(|hit: &mut [bool]| {
            let mut context = rtc::rtc_init_intersect_context();
            for (hit, r) in hit.iter_mut().zip(&native) {
                let mut rh = rtc::RTCRayHit::new(*r);
                scene.intersect1(&mut context, &mut rh);
                *hit = rh.closest().is_some();
            }
        }),
    }];
    for tree in [&bvh4, &bvh8, &bvh8q] {
        closest.push(per_ray(tree, rays, |t, r| t.cast_ray(r).is_some()));
    }
    for tree in [&bvh4, &bvh8, &bvh8q] {
        closest.push(batched_closest(tree, rays, None, BatchOrdering::ByOctant));
        closest.push(batched_closest(
            tree,
            rays,
            Some(FRAME_CALL),
            BatchOrdering::ByOctant,
        ));
    }
    // The default tree with every octant its own stream, and with the small ones always mixed:
    // the two groupings the rows above choose between (`BatchOrdering::ByOctant`).
    for ordering in [BatchOrdering::SeparateOctants, BatchOrdering::MixedOctants] {
        closest.push(batched_closest(&bvh4, rays, None, ordering));
        closest.push(batched_closest(&bvh4, rays, Some(FRAME_CALL), ordering));
    }
    let mut out = vec![("closest hit", run(closest, rays.len(), rounds))];

    if any_hit {
        let mut occluded = vec![Contender {
            name: "Embree rtcOccluded1".into(),
            pass: Box::new(|occluded: &mut [bool]| {
                let mut context = rtc::rtc_init_intersect_context();
                for (occluded, r) in occluded.iter_mut().zip(&native) {
                    *occluded = scene.occluded1(&mut context, r);
                }
            }),
        }];
        for tree in [&bvh4, &bvh8, &bvh8q] {
            occluded.push(per_ray(tree, rays, |t, r| t.occluded(r)));
        }
        for tree in [&bvh4, &bvh8, &bvh8q] {
            occluded.push(batched_occluded(tree, rays, None));
            occluded.push(batched_occluded(tree, rays, Some(FRAME_CALL)));
        }
        out.push(("any hit", run(occluded, rays.len(), rounds)));
    }
    Ok(out)
}

/// The best of `rounds` timings of each of `count` contenders (`time(k)` times contender
/// `k` once), taken in turns: round `r` starts with contender `r`, so that no contender always
/// goes first. The first error stops the race.
pub fn best_in_turns<E>(
    count: usize,
    rounds: usize,
    mut time: impl FnMut(usize) -> Result<Duration, E>,
) -> Result<Vec<Duration>, E> {
    let mut best = vec![Duration::MAX; count];
    for round in 0..rounds {
        for k in (0..count).map(|k| (k + round) % count) {
            best[k] = best[k].min(time(k)?);
        }
        eprintln!("  round {} of {rounds}", round + 1);
    }
    Ok(best)
}

/// `rounds` rounds of one pass per contender over `rays` rays, taken in turns.
fn run(mut contenders: Vec<Contender<'_>>, rays: usize, rounds: usize) -> Vec<Placing> {
    let n = contenders.len();
    let mut answers = vec![vec![false; rays]; n];
    let timed = best_in_turns(n, rounds, |k| {
        let start = Instant::now();
        (contenders[k].pass)(black_box(&mut answers[k]));
        Ok::<_, std::convert::Infallible>(start.elapsed())
    });
    let Ok(best) = timed;
    contenders
        .iter()
        .zip(best)
        .zip(&answers)
        .map(|((c, best), a)| Placing {
            name: c.name.clone(),
            best,
            disagreements: a.iter().zip(&answers[0]).filter(|(x, y)| x != y).count(),
        })
        .collect()
}

/// A raybatch tree (of kind `kind`) and its one-ray query `query` over every ray.
fn per_ray<'a>(
    (kind, tree): &'a (AccelKind, AnyAccel),
    rays: &'a [Ray],
    query: impl Fn(&AnyAccel, &Ray) -> bool + 'a,
) -> Contender<'a> {
    Contender {
        name: raybatch_engine(*kind),
        pass: Box::new(move |answers: &mut [bool]| {
            for (answer, r) in answers.iter_mut().zip(rays) {
                *answer = query(tree, black_box(r));
            }
        }),
    }
}

/// `cast_ray_batch_with` on one thread, all rays in one call or in calls of `calls_of`.
fn batched_closest<'a>(
    tree: &'a (AccelKind, AnyAccel),
    rays: &'a [Ray],
    calls_of: Option<usize>,
    ordering: BatchOrdering,
) -> Contender<'a> {
    let mut hits: Vec<Option<Hit>> = vec![None; calls_of.unwrap_or(rays.len())];
    let calls = (calls_of, ordering);
    batched(tree, rays, calls, move |tree, rays, hit, batch| {
        let hits = &mut hits[..rays.len()];
        tree.cast_ray_batch_with(rays, hits, batch)
            .expect("output sized to the rays");
        // Read back as the one-ray rows write theirs: one answer per ray.
        for (hit, h) in hit.iter_mut().zip(hits) {
            *hit = h.is_some();
        }
    })
}

/// `occluded_batch_with` on one thread, all rays in one call or in calls of `calls_of`.
fn batched_occluded<'a>(
    tree: &'a (AccelKind, AnyAccel),
    rays: &'a [Ray],
    calls_of: Option<usize>,
) -> Contender<'a> {
    let calls = (calls_of, BatchOrdering::ByOctant);
    batched(tree, rays, calls, |tree, rays, occluded, batch| {
        tree.occluded_batch_with(rays, occluded, batch)
            .expect("output sized to the rays")
    })
}

/// A batched contender: `call` answers each call's rays (all of them, or `calls_of` at a
/// time) on one thread with `ordering`, writing one answer per ray.
fn batched<'a>(
    (kind, tree): &'a (AccelKind, AnyAccel),
    rays: &'a [Ray],
    (calls_of, ordering): (Option<usize>, BatchOrdering),
    mut call: impl FnMut(&AnyAccel, &[Ray], &mut [bool], &BatchOptions) + 'a,
) -> Contender<'a> {
    let size = calls_of.unwrap_or(rays.len()).max(1);
    let batch = BatchOptions {
        ordering,
        ..BatchOptions::default().with_parallel(false)
    };
    let mut name = raybatch_batched_engine(*kind, calls_of);
    if ordering != BatchOrdering::ByOctant {
        name = format!("{name}, {}", ordering.name());
    }
    Contender {
        name,
        pass: Box::new(move |answers: &mut [bool]| {
            for (rays, out) in rays.chunks(size).zip(answers.chunks_mut(size)) {
                call(tree, rays, out, &batch);
            }
        }),
    }
}

/// The race's table: best pass, speed against the first row, disagreements with it.
pub fn table(query: &str, placings: &[Placing]) -> String {
    let first = placings[0].best.as_secs_f64();
    let mut out = format!(
        "Race, {query}: best pass of each, taking turns\n\n\
         | engine | best pass (ms) | speed vs {} | answers differing |\n|---|---:|---:|---:|\n",
        placings[0].name
    );
    for p in placings {
        out += &format!(
            "| {} | {:.1} | {:.2} | {} |\n",
            p.name,
            p.best.as_secs_f64() * 1e3,
            first / p.best.as_secs_f64(),
            p.disagreements
        );
    }
    out
}
