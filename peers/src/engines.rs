//! One runner per library: build (best of `runs`), convert the rays to the library's own type
//! (untimed), cast every ray (best of `runs`, single thread) and keep the closest hits.
//!
//! Build time covers everything from a `raybatch::Mesh` to a structure that answers rays,
//! including the copy into the library's own vertex/triangle format where it needs one (raybatch
//! shares the mesh through an `Arc`, so it copies nothing).

use std::hint::black_box;
use std::sync::Arc;
use std::time::{Duration, Instant};

use raybatch::glam::Vec3A;
use raybatch::{
    AccelKind, BatchOptions, BatchQueries, BuildOptions, Footprint, Hit, Mesh, Ray, RayQueries,
};

use crate::embree_ffi as rtc;

/// A closest hit as every library can report it: distance along the ray (in units of `dir`)
/// and the triangle's index in the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeerHit {
    pub t: f32,
    pub triangle: u32,
}

/// One library/configuration over one ray set.
pub struct Run {
    /// The row's name: `Embree rtcIntersect1`, `raybatch aabb`, `obvhs CwBvh`, ...
    pub engine: String,
    /// Structure and settings, for the table.
    pub structure: String,
    pub build: Duration,
    pub query: Duration,
    /// `hits[i]` is ray `i`'s closest hit.
    pub hits: Vec<Option<PeerHit>>,
    /// Any-hit (occlusion) queries on the same structure, when the set asks for them and the
    /// library has such a query.
    pub any_hit: Option<AnyHit>,
}

/// Timed any-hit queries: `occluded[i]` is true if ray `i` hits anything in its range.
pub struct AnyHit {
    /// The call used.
    pub call: &'static str,
    pub query: Duration,
    pub occluded: Vec<bool>,
}

impl AnyHit {
    pub fn mrays_per_s(&self) -> f64 {
        self.occluded.len() as f64 / self.query.as_secs_f64() / 1e6
    }
}

impl Run {
    pub fn mrays_per_s(&self) -> f64 {
        self.hits.len() as f64 / self.query.as_secs_f64() / 1e6
    }
}

/// Runs `f` `runs` times; the fastest time and the last result.
pub fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut last = None;
    for _ in 0..runs.max(1) {
        drop(last.take());
        let start = Instant::now();
        let value = black_box(f());
        best = best.min(start.elapsed());
        last = Some(value);
    }
    (best, last.expect("at least one run"))
}

/// Casts every ray `runs` times; the fastest pass and its hits.
fn time_queries<R>(
    runs: usize,
    rays: &[R],
    mut cast: impl FnMut(&R) -> Option<PeerHit>,
) -> (Duration, Vec<Option<PeerHit>>) {
    let mut hits = Vec::with_capacity(rays.len());
    let mut best = Duration::MAX;
    for _ in 0..runs.max(1) {
        hits.clear();
        let start = Instant::now();
        hits.extend(rays.iter().map(|r| cast(black_box(r))));
        best = best.min(start.elapsed());
        black_box(&hits);
    }
    (best, hits)
}

/// Any-hit counterpart of [`time_queries`].
fn time_any_hit<R>(
    runs: usize,
    rays: &[R],
    call: &'static str,
    mut occluded: impl FnMut(&R) -> bool,
) -> AnyHit {
    let mut out = Vec::with_capacity(rays.len());
    let mut best = Duration::MAX;
    for _ in 0..runs.max(1) {
        out.clear();
        let start = Instant::now();
        out.extend(rays.iter().map(|r| occluded(black_box(r))));
        best = best.min(start.elapsed());
        black_box(&out);
    }
    eprintln!(
        "    any-hit {call}: {:.1} ms ({:.2} Mrays/s)",
        best.as_secs_f64() * 1e3,
        rays.len() as f64 / best.as_secs_f64() / 1e6
    );
    AnyHit {
        call,
        query: best,
        occluded: out,
    }
}

fn progress(what: &str, build: Duration, query: Duration, rays: usize) {
    eprintln!(
        "  {what}: build {:.1} ms, query {:.1} ms ({:.2} Mrays/s)",
        build.as_secs_f64() * 1e3,
        query.as_secs_f64() * 1e3,
        rays as f64 / query.as_secs_f64() / 1e6
    );
}

// ---------------------------------------------------------------------------------------------
// raybatch
// ---------------------------------------------------------------------------------------------

/// The row name of raybatch's structure `kind`: `raybatch aabb`, `raybatch quantized`, ...
pub fn raybatch_engine(kind: AccelKind) -> String {
    format!("raybatch {}", kind.name())
}

/// Rays per call of the small-call rows: a game frame's line-of-sight work.
pub const FRAME_CALL: usize = 4096;

/// The row name of raybatch's batched engine on `kind`: all rays in one call, or in calls of
/// `calls_of` rays.
pub fn raybatch_batched_engine(kind: AccelKind, calls_of: Option<usize>) -> String {
    match calls_of {
        None => format!("{} batched", raybatch_engine(kind)),
        Some(n) => format!("{} batched, calls of {n}", raybatch_engine(kind)),
    }
}

/// `AccelKind::build` (single-threaded: `parallel = false`, other options default) and
/// `cast_ray` (watertight kernel). With `any_hit`, also `occluded`.
pub fn raybatch(
    kind: AccelKind,
    mesh: &Arc<Mesh>,
    rays: &[Ray],
    runs: usize,
    any_hit: bool,
) -> Result<Run, String> {
    let options = BuildOptions::default().with_parallel(false);
    let (build, tree) = best_of(runs, || kind.build(Arc::clone(mesh), &options));
    let tree = tree.map_err(|e| format!("raybatch build: {e}"))?;
    let (query, hits) = time_queries(runs, rays, |r| {
        tree.cast_ray(r).map(|h| PeerHit {
            t: h.t,
            triangle: h.triangle,
        })
    });
    let structure = format!(
        "{}, leaf <= {} (wide trees: <= {}), leaf copy {}, {:?} ordering, {:.1} B/tri",
        kind.summary(),
        options.max_leaf_size,
        options.wide_leaf_size,
        options.leaf_copy.name(),
        options.ordering,
        tree.bytes_per_triangle()
    );
    let engine = raybatch_engine(kind);
    progress(&engine, build, query, rays.len());
    let any_hit = any_hit.then(|| time_any_hit(runs, rays, "occluded", |r| tree.occluded(r)));
    Ok(Run {
        engine,
        structure,
        build,
        query,
        hits,
        any_hit,
    })
}

/// The batched engine on the same tree: the whole ray array in one `cast_ray_batch_with` call on one
/// thread (`parallel = false`, other options default), or in calls of `calls_of` rays (a game
/// frame's worth of queries, for instance). With `any_hit`, also `occluded_batch_with`.
pub fn raybatch_batched(
    kind: AccelKind,
    mesh: &Arc<Mesh>,
    rays: &[Ray],
    (runs, calls_of): (usize, Option<usize>),
    any_hit: bool,
) -> Result<Run, String> {
    let options = BuildOptions::default().with_parallel(false);
    let (build, tree) = best_of(runs, || kind.build(Arc::clone(mesh), &options));
    let tree = tree.map_err(|e| format!("raybatch build: {e}"))?;
    let batch = BatchOptions::default().with_parallel(false);
    let size = calls_of.unwrap_or(rays.len()).max(1);
    let mut out: Vec<Option<Hit>> = vec![None; rays.len()];
    let (query, ()) = best_of(runs, || {
        for (rays, out) in rays.chunks(size).zip(out.chunks_mut(size)) {
            tree.cast_ray_batch_with(rays, out, &batch)
                .expect("output sized to the rays");
        }
    });
    let hits = out
        .iter()
        .map(|h| {
            h.map(|h| PeerHit {
                t: h.t,
                triangle: h.triangle,
            })
        })
        .collect();
    let engine = raybatch_batched_engine(kind, calls_of);
    progress(&engine, build, query, rays.len());
    let any_hit = any_hit.then(|| {
        let mut occluded = vec![false; rays.len()];
        let (query, ()) = best_of(runs, || {
            for (rays, out) in rays.chunks(size).zip(occluded.chunks_mut(size)) {
                tree.occluded_batch_with(rays, out, &batch)
                    .expect("output sized to the rays");
            }
        });
        eprintln!(
            "    any-hit occluded_batch: {:.1} ms ({:.2} Mrays/s)",
            query.as_secs_f64() * 1e3,
            rays.len() as f64 / query.as_secs_f64() / 1e6
        );
        AnyHit {
            call: "occluded_batch",
            query,
            occluded,
        }
    });
    let calls = match calls_of {
        None => "whole array per call".to_string(),
        Some(n) => format!("calls of {n} rays"),
    };
    Ok(Run {
        engine,
        structure: format!(
            "same tree, {calls}, one thread, {:?} batch ordering, {} partition",
            batch.ordering,
            batch.partition.name()
        ),
        build,
        query,
        hits,
        any_hit,
    })
}

// ---------------------------------------------------------------------------------------------
// Embree 3
// ---------------------------------------------------------------------------------------------

/// The build quality used for both the geometry and the scene (scene flags stay default).
pub const EMBREE_QUALITY: rtc::RTCBuildQuality = rtc::RTC_BUILD_QUALITY_HIGH;

/// Two rows sharing one build: `rtcIntersect1` per ray (the baseline every ratio refers to,
/// with default flags) and `rtcIntersect1M` over the whole array. With `any_hit`, also
/// `rtcOccluded1` (first row). `robust` sets `RTC_SCENE_FLAG_ROBUST` (Embree's more accurate
/// mode, the like-for-like peer of an exact library); the rows' names then say "robust".
pub fn embree(
    device: &rtc::Device,
    mesh: &Mesh,
    rays: &[Ray],
    runs: usize,
    any_hit: bool,
    robust: bool,
) -> Result<[Run; 2], String> {
    let flags = if robust {
        rtc::RTC_SCENE_FLAG_ROBUST
    } else {
        rtc::RTC_SCENE_FLAG_NONE
    };
    let suffix = if robust { " robust" } else { "" };
    let (build, scene) = best_of(runs, || {
        rtc::Scene::triangles(
            device,
            mesh.vertices(),
            mesh.triangles(),
            EMBREE_QUALITY,
            flags,
        )
    });
    let scene = scene?;
    let native: Vec<rtc::RTCRay> = rays
        .iter()
        .map(|r| rtc::RTCRay::new(r.origin, r.dir, r.tmin, r.tmax))
        .collect();
    let to_hit = |rh: &rtc::RTCRayHit| rh.closest().map(|(t, triangle)| PeerHit { t, triangle });

    let mut context = rtc::rtc_init_intersect_context();
    let (query1, hits1) = time_queries(runs, &native, |r| {
        let mut rh = rtc::RTCRayHit::new(*r);
        scene.intersect1(&mut context, &mut rh);
        to_hit(&rh)
    });
    progress(
        &format!("embree{suffix} rtcIntersect1"),
        build,
        query1,
        rays.len(),
    );
    let any_hit = any_hit.then(|| {
        time_any_hit(runs, &native, "rtcOccluded1", |r| {
            scene.occluded1(&mut context, r)
        })
    });

    // The stream call overwrites its input, so each pass gets a fresh copy (made untimed).
    let mut query_m = Duration::MAX;
    let mut hits_m = Vec::new();
    for _ in 0..runs.max(1) {
        let mut stream: Vec<rtc::RTCRayHit> =
            native.iter().map(|r| rtc::RTCRayHit::new(*r)).collect();
        hits_m.clear();
        let start = Instant::now();
        scene.intersect1m(&mut context, &mut stream);
        hits_m.extend(stream.iter().map(to_hit));
        query_m = query_m.min(start.elapsed());
        black_box(&hits_m);
    }
    progress(
        &format!("embree{suffix} rtcIntersect1M"),
        build,
        query_m,
        rays.len(),
    );

    let structure = |call: &str| {
        format!(
            "{call}; BVH build quality HIGH (scene + geometry), {} scene flags, threads=1, \
             {} tasking",
            if robust { "ROBUST" } else { "default" },
            device.tasking_system()
        )
    };
    Ok([
        Run {
            engine: format!("Embree{suffix} rtcIntersect1"),
            structure: structure("1 ray per call"),
            build,
            query: query1,
            hits: hits1,
            any_hit,
        },
        Run {
            engine: format!("Embree{suffix} rtcIntersect1M"),
            structure: structure("whole array per call (stream)"),
            build,
            query: query_m,
            hits: hits_m,
            any_hit: None,
        },
    ])
}

// ---------------------------------------------------------------------------------------------
// obvhs
// ---------------------------------------------------------------------------------------------

fn obvhs_triangles(mesh: &Mesh) -> Vec<obvhs::triangle::Triangle> {
    mesh.triangles()
        .iter()
        .map(|&[a, b, c]| {
            let v = |i: u32| Vec3A::from(mesh.vertices()[i as usize]);
            obvhs::triangle::Triangle {
                v0: v(a),
                v1: v(b),
                v2: v(c),
            }
        })
        .collect()
}

fn obvhs_rays(rays: &[Ray]) -> Vec<obvhs::ray::Ray> {
    rays.iter()
        .map(|r| obvhs::ray::Ray::new(r.origin.into(), r.dir.into(), r.tmin, r.tmax))
        .collect()
}

/// The obvhs preset used for both trees: "tries to be around the same build time as embree
/// but with faster traversal" (PLOC + reinsertion, no pre-splits).
fn obvhs_params() -> obvhs::BvhBuildParams {
    obvhs::BvhBuildParams::medium_build()
}

/// obvhs CWBVH (8-wide compressed nodes, SIMD node test) with its Möller-Trumbore
/// `Triangle::intersect`, as in its `basic_cwbvh` example.
pub fn obvhs_cwbvh(mesh: &Mesh, rays: &[Ray], runs: usize, any_hit: bool) -> Run {
    let params = obvhs_params();
    let (build, (tris, bvh)) = best_of(runs, || {
        let tris = obvhs_triangles(mesh);
        let bvh =
            obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, params, &mut Duration::default());
        (tris, bvh)
    });
    let native = obvhs_rays(rays);
    let (query, hits) = time_queries(runs, &native, |r| {
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(*r, &mut hit, |ray, id| {
            tris[bvh.primitive_indices[id] as usize].intersect(ray)
        })
        .then(|| PeerHit {
            t: hit.t,
            triangle: bvh.primitive_indices[hit.primitive_id as usize],
        })
    });
    progress("obvhs CWBVH", build, query, rays.len());
    let any_hit = any_hit.then(|| {
        time_any_hit(runs, &native, "ray_traverse_miss", |r| {
            !bvh.ray_traverse_miss(*r, |ray, id| {
                tris[bvh.primitive_indices[id] as usize].intersect(ray)
            })
        })
    });
    Run {
        engine: "obvhs CwBvh".to_string(),
        structure: format!(
            "medium_build (PLOC, reinsertion), <= {} prims/leaf, {} nodes",
            params.max_prims_per_leaf.clamp(1, 3),
            bvh.nodes.len()
        ),
        build,
        query,
        hits,
        any_hit,
    }
}

/// obvhs BVH2 with the same preset and triangle test.
pub fn obvhs_bvh2(mesh: &Mesh, rays: &[Ray], runs: usize, any_hit: bool) -> Run {
    let params = obvhs_params();
    let (build, (tris, bvh)) = best_of(runs, || {
        let tris = obvhs_triangles(mesh);
        let bvh =
            obvhs::bvh2::builder::build_bvh2_from_tris(&tris, params, &mut Duration::default());
        (tris, bvh)
    });
    let native = obvhs_rays(rays);
    let (query, hits) = time_queries(runs, &native, |r| {
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(*r, &mut hit, |ray, id| {
            tris[bvh.primitive_indices[id] as usize].intersect(ray)
        })
        .then(|| PeerHit {
            t: hit.t,
            triangle: bvh.primitive_indices[hit.primitive_id as usize],
        })
    });
    progress("obvhs BVH2", build, query, rays.len());
    let any_hit = any_hit.then(|| {
        time_any_hit(runs, &native, "ray_traverse_miss", |r| {
            !bvh.ray_traverse_miss(*r, |ray, id| {
                tris[bvh.primitive_indices[id] as usize].intersect(ray)
            })
        })
    });
    Run {
        engine: "obvhs Bvh2".to_string(),
        structure: format!(
            "medium_build (PLOC, reinsertion, leaf collapse), <= {} prims/leaf, {} nodes",
            params.max_prims_per_leaf,
            bvh.nodes.len()
        ),
        build,
        query,
        hits,
        any_hit,
    }
}

// ---------------------------------------------------------------------------------------------
// tinybvh (through tinybvh-rs, its C++ compiled by cxx with -march=native)
// ---------------------------------------------------------------------------------------------

/// The mesh as tinybvh takes it: three 4-float corners per triangle.
#[cfg(target_feature = "avx2")]
fn tinybvh_corners(mesh: &Mesh) -> Vec<[f32; 4]> {
    mesh.triangles()
        .iter()
        .flat_map(|t| t.map(|i| mesh.vertices()[i as usize].extend(0.0).to_array()))
        .collect()
}

/// tinybvh rays, each with its direction's length: tinybvh normalizes the direction, so its
/// distances are in units of length, and the range end it is given (1e30 for an endless
/// ray) is scaled to match. Its range starts at 0: `None` if a ray starts past 0.
#[cfg(target_feature = "avx2")]
fn tinybvh_rays(rays: &[Ray]) -> Option<Vec<(tinybvh_rs::Ray, f32)>> {
    rays.iter()
        .map(|r| {
            (r.tmin == 0.0).then(|| {
                let length = r.dir.length();
                let mut ray = tinybvh_rs::Ray::new(r.origin.to_array(), r.dir.to_array());
                ray.hit.t = (r.tmax * length).min(tinybvh_rs::INFINITE);
                (ray, length)
            })
        })
        .collect()
}

/// Casts `ray` through `tree`; the hit, if it lies in front of the ray's range end, its
/// distance back in units of the caller's direction.
#[cfg(target_feature = "avx2")]
fn tinybvh_cast(
    tree: &tinybvh_rs::bvh8_cpu::BVH,
    (ray, length): &(tinybvh_rs::Ray, f32),
) -> Option<PeerHit> {
    use tinybvh_rs::Intersector;
    let mut cast = *ray;
    tree.intersect(&mut cast);
    (cast.hit.t < ray.hit.t).then_some(PeerHit {
        t: cast.hit.t / length,
        triangle: cast.hit.prim,
    })
}

/// tinybvh's fastest CPU layout, BVH8_CPU (8-wide nodes, AVX2, triangles in SoA blocks of four;
/// "Accelerated Single Ray Tracing for Wide Vector Units"), converted from its binned SAH BVH
/// with leaves of at most 4 as it requires. tinybvh-rs only offers `Intersect` on it when the
/// crate is compiled with AVX2 (`RUSTFLAGS="-C target-feature=+avx2,+fma"`), and has no
/// occlusion query, so there is no any-hit row. `None` if a ray starts past 0.
#[cfg(target_feature = "avx2")]
pub fn tinybvh_bvh8(mesh: &Mesh, rays: &[Ray], runs: usize) -> Option<Run> {
    use tinybvh_rs::{bvh, bvh8_cpu, mbvh};
    let native = tinybvh_rays(rays)?;
    let corners = tinybvh_corners(mesh);
    let (build, tree) = best_of(runs, || {
        let mut wald = bvh::BVH::new(corners.as_slice().into()).expect("tinybvh build");
        wald.split_leaves(4);
        let wide = mbvh::BVH::new(&wald);
        bvh8_cpu::BVH::new(&wide).expect("tinybvh BVH8_CPU conversion")
    });
    let (query, hits) = time_queries(runs, &native, |r| tinybvh_cast(&tree, r));
    progress("tinybvh BVH8_CPU", build, query, rays.len());
    Some(Run {
        engine: "tinybvh BVH8_CPU".to_string(),
        structure: "binned SAH (BVH::Build), leaves split to <= 4, MBVH<8>, BVH8_CPU; no \
                    occlusion query in tinybvh-rs"
            .to_string(),
        build,
        query,
        hits,
        any_hit: None,
    })
}

// ---------------------------------------------------------------------------------------------
// parry3d
// ---------------------------------------------------------------------------------------------

/// parry3d `TriMesh::new` (no flags) and `RayCast::cast_local_ray_and_get_normal` with
/// `solid = false` and the ray's `tmax` as max time of impact (parry rays have no `tmin`:
/// every ray here starts at `t = 0`). Parry uses glam 0.33 through glamx, so vectors are
/// rebuilt component-wise.
/// With `any_hit`, also `RayCast::intersects_local_ray`.
pub fn parry(mesh: &Mesh, rays: &[Ray], runs: usize, any_hit: bool) -> Result<Run, String> {
    use parry3d::math::Vector;
    use parry3d::query::{Ray as PRay, RayCast};
    use parry3d::shape::TriMesh;

    let vec = |v: raybatch::glam::Vec3| Vector::new(v.x, v.y, v.z);
    let (build, trimesh) = best_of(runs, || {
        let vertices = mesh.vertices().iter().map(|&v| vec(v)).collect();
        TriMesh::new(vertices, mesh.triangles().to_vec())
    });
    let trimesh = trimesh.map_err(|e| format!("parry3d TriMesh::new: {e:?}"))?;
    if rays.iter().any(|r| r.tmin != 0.0) {
        eprintln!("  warning: parry3d has no tmin; rays with tmin > 0 are cast from t = 0");
    }
    let native: Vec<(PRay, f32)> = rays
        .iter()
        .map(|r| (PRay::new(vec(r.origin), vec(r.dir)), r.tmax))
        .collect();
    let (query, hits) = time_queries(runs, &native, |(ray, tmax)| {
        trimesh
            .cast_local_ray_and_get_normal(ray, *tmax, false)
            .map(|i| PeerHit {
                t: i.time_of_impact,
                triangle: i.subshape,
            })
    });
    progress("parry3d TriMesh", build, query, rays.len());
    let any_hit = any_hit.then(|| {
        time_any_hit(runs, &native, "intersects_local_ray", |(ray, tmax)| {
            trimesh.intersects_local_ray(ray, *tmax)
        })
    });
    Ok(Run {
        engine: "parry3d TriMesh".to_string(),
        structure: "TriMesh::new (its BVH), cast_local_ray_and_get_normal, solid = false".into(),
        build,
        query,
        hits,
        any_hit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::compare;
    use raybatch::glam::Vec3;
    use raybatch_tools::scenes::{RaySet, SceneKind, generate};

    /// A closed box (12 triangles) and incoherent rays from inside it: every ray hits, away
    /// from edges with probability 1, so every library must agree.
    #[test]
    fn every_library_agrees_on_a_box() {
        let (lo, hi) = (Vec3::new(-1.0, -2.0, -0.5), Vec3::new(3.0, 1.0, 2.5));
        let corners: Vec<Vec3> = (0..8)
            .map(|i| {
                Vec3::select(
                    raybatch::glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0),
                    hi,
                    lo,
                )
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
            .collect();
        let mesh = Arc::new(Mesh::new(corners, triangles).unwrap());
        let rays = generate(RaySet::Incoherent, &mesh, SceneKind::Object, 2000, 3);

        let reference = raybatch(AccelKind::DEFAULT, &mesh, &rays, 1, true).unwrap();
        assert!(reference.hits.iter().all(Option::is_some));
        let device = rtc::Device::new("threads=1").unwrap();
        let mut runs = Vec::new();
        for kind in AccelKind::ALL {
            if kind != AccelKind::DEFAULT {
                runs.push(raybatch(kind, &mesh, &rays, 1, true).unwrap());
            }
            runs.push(raybatch_batched(kind, &mesh, &rays, (1, None), true).unwrap());
        }
        runs.extend(embree(&device, &mesh, &rays, 1, true, false).unwrap());
        runs.extend(embree(&device, &mesh, &rays, 1, true, true).unwrap());
        runs.push(obvhs_cwbvh(&mesh, &rays, 1, true));
        runs.push(obvhs_bvh2(&mesh, &rays, 1, true));
        runs.push(parry(&mesh, &rays, 1, true).unwrap());
        for run in &runs {
            // obvhs' CWBVH node test clamps the box entry to 1e-4 instead of the ray's tmin
            // (`cwbvh::node::EPSILON`), so it may miss hits closer than that: leave those out.
            let near =
                |i: usize| run.engine == "obvhs CwBvh" && reference.hits[i].unwrap().t < 1e-4;
            let keep: Vec<usize> = (0..rays.len()).filter(|&i| !near(i)).collect();
            let pick = |h: &[Option<PeerHit>]| keep.iter().map(|&i| h[i]).collect::<Vec<_>>();
            let a = compare(&pick(&reference.hits), &pick(&run.hits), &mut Vec::new(), 0);
            assert_eq!((a.hit_miss(), a.t_differs), (0, 0), "{}: {a:?}", run.engine);
            if let Some(any) = &run.any_hit {
                let occluded = keep.iter().filter(|&&i| any.occluded[i]).count();
                assert_eq!(occluded, keep.len(), "{} {}", run.engine, any.call);
            }
        }
    }
}
