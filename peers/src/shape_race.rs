//! `--shape-race R`: shape queries one at a time, raybatch's default tree against parry3d's
//! `TriMesh`, on the same queries, timed in turn for R rounds, best kept; then agreement.
//!
//! Four query sets over the mesh's box (radii 1-3% of its diagonal, sweeps 5-20% of it long,
//! in random directions): sphere and capsule overlap tests (is anything within the shape), and
//! sphere and capsule sweeps (first time of contact over the motion). parry3d answers them with
//! `intersection_test` and `cast_shapes` (target distance 0, impacts at time 0 kept).
//! Agreement: the same yes or no, and contact times within 1e-4 of the motion.

use std::hint::black_box;
use std::time::{Duration, Instant};

use parry3d::math::{Pose, Vector};
use parry3d::query::{ShapeCastOptions, cast_shapes, intersection_test};
use parry3d::shape::{Ball, Capsule, TriMesh};
use raybatch::glam::Vec3;
use raybatch::shape::{Shape, ShapeQueries};
use raybatch::{AccelKind, AnyAccel, BuildOptions, Mesh};
use raybatch_tools::scenes::rng::SplitMix64;

/// One query of a set: a shape and, for sweeps, its motion.
#[derive(Clone, Copy)]
struct Query {
    shape: Shape,
    motion: Vec3,
}

/// What one pass answers per query: `None` for no contact, else the contact time (0 for an
/// overlap).
type Answers = Vec<Option<f32>>;

/// The four query sets: (name, whether it sweeps, the queries).
fn query_sets(mesh: &Mesh, count: usize, seed: u64) -> Vec<(&'static str, bool, Vec<Query>)> {
    let bounds = mesh.bounds();
    let diagonal = (bounds.max - bounds.min).length();
    let make = |capsule: bool, sweep: bool, salt: u64| -> Vec<Query> {
        (0..count)
            .map(|i| {
                let mut rng = SplitMix64::for_item(seed ^ salt, i as u64);
                let p = |rng: &mut SplitMix64| {
                    let t = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                    bounds.min + (bounds.max - bounds.min) * t
                };
                let centre = p(&mut rng);
                let radius = diagonal * rng.range_f32(0.01, 0.03);
                let shape = if capsule {
                    let half = rng.unit_vector() * diagonal * rng.range_f32(0.01, 0.04);
                    Shape::Capsule {
                        a: centre - half,
                        b: centre + half,
                        radius,
                    }
                } else {
                    Shape::Sphere { centre, radius }
                };
                let motion = if sweep {
                    rng.unit_vector() * diagonal * rng.range_f32(0.05, 0.2)
                } else {
                    Vec3::ZERO
                };
                Query { shape, motion }
            })
            .collect()
    };
    vec![
        ("sphere overlap", false, make(false, false, 1)),
        ("capsule overlap", false, make(true, false, 2)),
        ("sphere sweep", true, make(false, true, 3)),
        ("capsule sweep", true, make(true, true, 4)),
    ]
}

fn raybatch_pass(tree: &AnyAccel, queries: &[Query], sweep: bool, out: &mut Answers) {
    out.clear();
    out.extend(queries.iter().map(|q| {
        if sweep {
            let contact = tree.sweep(&q.shape, q.motion).expect("a valid sweep");
            contact.map(|c| c.t)
        } else {
            let overlaps = tree.overlaps(&q.shape).expect("a valid shape");
            overlaps.then_some(0.0)
        }
    }));
}

fn vector(v: Vec3) -> Vector {
    Vector::new(v.x, v.y, v.z)
}

/// The query's shape in parry3d's terms, at the identity.
fn parry_shape(shape: &Shape) -> Box<dyn parry3d::shape::Shape> {
    match *shape {
        Shape::Sphere { radius, .. } => Box::new(Ball::new(radius)),
        Shape::Capsule { a, b, radius } => Box::new(Capsule::new(vector(a), vector(b), radius)),
        Shape::Box(_) => unreachable!("no box queries in the race"),
    }
}

/// Where parry's shape sits: a ball at its centre, a capsule (given in world points) at the
/// origin.
fn parry_pose(shape: &Shape) -> Pose {
    match *shape {
        Shape::Sphere { centre, .. } => Pose::from_translation(vector(centre)),
        _ => Pose::IDENTITY,
    }
}

fn parry_pass(
    trimesh: &TriMesh,
    shapes: &[Box<dyn parry3d::shape::Shape>],
    queries: &[Query],
    sweep: bool,
    out: &mut Answers,
) {
    out.clear();
    out.extend(queries.iter().zip(shapes).map(|(q, shape)| {
        let pose = parry_pose(&q.shape);
        if sweep {
            let options = ShapeCastOptions {
                max_time_of_impact: 1.0,
                target_distance: 0.0,
                stop_at_penetration: true,
                compute_impact_geometry_on_penetration: false,
            };
            let hit = cast_shapes(
                &pose,
                vector(q.motion),
                shape.as_ref(),
                &Pose::IDENTITY,
                Vector::ZERO,
                trimesh,
                options,
            )
            .expect("parry3d casts balls and capsules on meshes");
            hit.map(|h| h.time_of_impact)
        } else {
            let hit = intersection_test(&pose, shape.as_ref(), &Pose::IDENTITY, trimesh)
                .expect("parry3d tests balls and capsules on meshes");
            hit.intersecting.then_some(0.0)
        }
    }));
}

/// The race's table (Markdown).
pub fn shape_race(mesh: &Mesh, count: usize, rounds: usize, seed: u64) -> Result<String, String> {
    let tree = AccelKind::for_mesh(mesh)
        .build(mesh.clone(), &BuildOptions::default())
        .map_err(|e| e.to_string())?;
    let vertices = mesh.vertices().iter().map(|&v| vector(v)).collect();
    let trimesh = TriMesh::new(vertices, mesh.triangles().to_vec())
        .map_err(|e| format!("parry3d TriMesh::new: {e:?}"))?;
    let mut table = format!(
        "| queries ({count} each) | raybatch `{}` (µs a query) | parry3d `TriMesh` (µs) | \
         raybatch over parry3d | contacts | disagreements |\n|---|---:|---:|---:|---:|---:|\n",
        tree.kind().name()
    );
    for (name, sweep, queries) in query_sets(mesh, count, seed) {
        let shapes: Vec<_> = queries.iter().map(|q| parry_shape(&q.shape)).collect();
        let (mut mine, mut theirs) = (Vec::new(), Vec::new());
        let (mut best_mine, mut best_theirs) = (Duration::MAX, Duration::MAX);
        for round in 0..rounds {
            let mut time_mine = || {
                let start = Instant::now();
                raybatch_pass(&tree, &queries, sweep, &mut mine);
                best_mine = best_mine.min(start.elapsed());
            };
            let mut time_theirs = || {
                let start = Instant::now();
                parry_pass(&trimesh, &shapes, &queries, sweep, &mut theirs);
                best_theirs = best_theirs.min(start.elapsed());
            };
            if round % 2 == 0 {
                time_mine();
                time_theirs();
            } else {
                time_theirs();
                time_mine();
            }
            black_box((&mine, &theirs));
        }
        let disagree = mine
            .iter()
            .zip(&theirs)
            .filter(|(a, b)| match (a, b) {
                (Some(a), Some(b)) => (a - b).abs() > 1e-4,
                (None, None) => false,
                _ => true,
            })
            .count();
        let contacts = mine.iter().filter(|a| a.is_some()).count();
        let per = |d: Duration| d.as_secs_f64() * 1e6 / count as f64;
        table += &format!(
            "| {name} | {:.3} | {:.3} | {:.2}x | {contacts} | {disagree} |\n",
            per(best_mine),
            per(best_theirs),
            best_theirs.as_secs_f64() / best_mine.as_secs_f64()
        );
    }
    Ok(table)
}
