//! The race: the rows issue 7's targets name (Embree's one-ray calls, raybatch per ray,
//! batched and in calls of 4,096), built once and timed pass by pass in turn, each round
//! starting with the next contender, best pass kept. (tinybvh stays in the full table only:
//! its tree, built beside the others here, crashed in tinybvh-rs's ray setup.)
//!
//! The full table times each library's passes back to back, so on a machine whose speed drifts
//! (a shared VM: the same pass took 200 and 340 ms within an hour here) one library may get a
//! fast phase and the next a slow one, and the ratios swing. Taking turns spreads every phase
//! over every contender; the ratio of two best passes then holds where separate runs drift.

use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

use raybatch::{AccelKind, AnyAccel, BatchOptions, BuildOptions, Hit, Mesh, Ray};

use crate::embree_ffi as rtc;
use crate::engines::{EMBREE_QUALITY, raybatch_engine};

/// Rays per call of the small-call rows: a game frame's line-of-sight work.
pub const FRAME_CALL: usize = 4096;

/// One contender: its row name and one timed pass over every ray, which returns, per ray,
/// whether it hit (closest hit) or is occluded (any hit).
struct Contender<'a> {
    name: String,
    pass: Box<dyn FnMut() -> Vec<bool> + 'a>,
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
        pass: Box::new(|| {
            let mut context = rtc::rtc_init_intersect_context();
            native
                .iter()
                .map(|r| {
                    let mut rh = rtc::RTCRayHit::new(*r);
                    scene.intersect1(&mut context, &mut rh);
                    rh.closest().is_some()
                })
                .collect()
        }),
    }];
    for tree in [&bvh4, &bvh8] {
        closest.push(per_ray(tree, rays, |t, r| t.cast_ray(r).is_some()));
    }
    closest.push(batched_closest(&bvh4, rays, None));
    closest.push(batched_closest(&bvh4, rays, Some(FRAME_CALL)));
    let mut out = vec![("closest hit", run(closest, rounds))];

    if any_hit {
        let mut occluded = vec![Contender {
            name: "Embree rtcOccluded1".into(),
            pass: Box::new(|| {
                let mut context = rtc::rtc_init_intersect_context();
                native
                    .iter()
                    .map(|r| scene.occluded1(&mut context, r))
                    .collect()
            }),
        }];
        for tree in [&bvh4, &bvh8] {
            occluded.push(per_ray(tree, rays, |t, r| t.occluded(r)));
        }
        occluded.push(batched_occluded(&bvh4, rays, None));
        occluded.push(batched_occluded(&bvh4, rays, Some(FRAME_CALL)));
        out.push(("any hit", run(occluded, rounds)));
    }
    Ok(out)
}

/// `rounds` rounds of one pass per contender, round `r` starting with contender `r`.
fn run(mut contenders: Vec<Contender<'_>>, rounds: usize) -> Vec<Placing> {
    let n = contenders.len();
    let mut best = vec![Duration::MAX; n];
    let mut answers: Vec<Vec<bool>> = vec![Vec::new(); n];
    for round in 0..rounds.max(1) {
        for k in (0..n).map(|k| (k + round) % n) {
            let start = Instant::now();
            let pass = black_box((contenders[k].pass)());
            best[k] = best[k].min(start.elapsed());
            answers[k] = pass;
        }
        eprintln!("  round {} of {}", round + 1, rounds.max(1));
    }
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
        pass: Box::new(move || rays.iter().map(|r| query(tree, black_box(r))).collect()),
    }
}

/// The row name of a batched contender.
fn batched_name(kind: AccelKind, calls_of: Option<usize>) -> String {
    match calls_of {
        None => format!("{} batched", raybatch_engine(kind)),
        Some(n) => format!("{} batched, calls of {n}", raybatch_engine(kind)),
    }
}

/// `cast_rays_with` on one thread, all rays in one call or in calls of `calls_of`.
fn batched_closest<'a>(
    (kind, tree): &'a (AccelKind, AnyAccel),
    rays: &'a [Ray],
    calls_of: Option<usize>,
) -> Contender<'a> {
    let size = calls_of.unwrap_or(rays.len()).max(1);
    let batch = BatchOptions::default().with_parallel(false);
    let mut hits: Vec<Option<Hit>> = vec![None; rays.len()];
    Contender {
        name: batched_name(*kind, calls_of),
        pass: Box::new(move || {
            for (rays, out) in rays.chunks(size).zip(hits.chunks_mut(size)) {
                tree.cast_rays_with(rays, out, &batch)
                    .expect("output sized to the rays");
            }
            hits.iter().map(Option::is_some).collect()
        }),
    }
}

/// `occluded_batch_with` on one thread, all rays in one call or in calls of `calls_of`.
fn batched_occluded<'a>(
    (kind, tree): &'a (AccelKind, AnyAccel),
    rays: &'a [Ray],
    calls_of: Option<usize>,
) -> Contender<'a> {
    let size = calls_of.unwrap_or(rays.len()).max(1);
    let batch = BatchOptions::default().with_parallel(false);
    let mut occluded = vec![false; rays.len()];
    Contender {
        name: batched_name(*kind, calls_of),
        pass: Box::new(move || {
            for (rays, out) in rays.chunks(size).zip(occluded.chunks_mut(size)) {
                tree.occluded_batch_with(rays, out, &batch)
                    .expect("output sized to the rays");
            }
            occluded.clone()
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
