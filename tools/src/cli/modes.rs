//! The modes section of `raybatch bench`: what each way of answering costs in speed and memory
//! and how wrong it is, scored by the f64 judge ([`raybatch_tools::judge`]).
//!
//! Modes: the default tree with the watertight kernel (exact) and with Möller-Trumbore; the
//! binary tree with full and with quantized nodes (same answers: the nodes visited per ray say
//! what the larger boxes cost); the zero-byte tree and its hybrid; the binary tree over
//! quantized vertices (16, 10 and 8 bits: exact for the quantized mesh, within half a grid step
//! of the original, scored here against the original). Every mode is timed per ray and batched
//! (one thread, best of [`PASSES`]) on every ray set, closest hit; the judge scores the per-ray
//! answers of the first [`JUDGED_RAYS`] rays (batched answers are the same bit for bit: the
//! crate's contract, tested).
//!
//! Then the leaks: rays from inside three closed meshes aimed exactly at vertices and edges
//! ([`raybatch_tools::scenes::closed`]), each of which must hit.

use std::sync::Arc;

use raybatch::QuantizedVertexTree;
use raybatch::mesh::quantized::QuantizedMesh;
use raybatch::{AccelKind, BatchOrdering, BuildOptions, Kernel, Mesh, Ray};
use raybatch_tools::judge::{Reference, score};
use raybatch_tools::report::{Record, Section};
use raybatch_tools::scenes::RaySet;
use raybatch_tools::scenes::closed::{aimed_rays, closed_meshes};

use crate::progress;
use crate::runner::Measured;
use crate::runner::{Engine, Query, QueryKind, QueryRunner};
use crate::table::{Align, Table, thousands};
use crate::workload::{PASSES, RaySets, speed};

/// Rays per set the judge scores (the f64 reference costs a few microseconds a ray).
pub const JUDGED_RAYS: usize = 20_000;
/// Most rays per closed mesh in the bench's leak table, which keeps the bench's run short.
pub const LEAK_RAYS: usize = 100_000;

/// How a mode is built.
#[derive(Clone, Copy, Debug)]
enum Build {
    Tree(AccelKind),
    QuantizedVertices(u32),
}

/// One mode: a name, a build and a kernel.
#[derive(Clone, Copy, Debug)]
struct Mode {
    name: &'static str,
    build: Build,
    kernel: Kernel,
}

const fn mode(name: &'static str, build: Build, kernel: Kernel) -> Mode {
    Mode {
        name,
        build,
        kernel,
    }
}

const WT: Kernel = Kernel::Watertight;

/// Every mode, the default first.
const MODES: [Mode; 9] = [
    mode("bvh8 watertight", Build::Tree(AccelKind::DEFAULT), WT),
    mode(
        "bvh8 moller-trumbore",
        Build::Tree(AccelKind::DEFAULT),
        Kernel::MollerTrumbore,
    ),
    mode("aabb full nodes", Build::Tree(AccelKind::Aabb), WT),
    mode(
        "aabb quantized nodes",
        Build::Tree(AccelKind::Quantized),
        WT,
    ),
    mode("zbt", Build::Tree(AccelKind::Zbt), WT),
    mode("hybrid", Build::Tree(AccelKind::Hybrid), WT),
    mode("aabb 16-bit vertices", Build::QuantizedVertices(16), WT),
    mode("aabb 10-bit vertices", Build::QuantizedVertices(10), WT),
    mode("aabb 8-bit vertices", Build::QuantizedVertices(8), WT),
];

/// A built mode: the structure and the bytes per triangle of the mesh it reads.
struct Built {
    tree: Box<dyn Measured>,
    mesh_bytes: usize,
}

fn build(mode: &Mode, mesh: &Arc<Mesh>) -> Built {
    let options = BuildOptions::default();
    match mode.build {
        Build::Tree(kind) => Built {
            tree: Box::new(
                kind.build(mesh.clone(), &options)
                    .expect("the scenes build"),
            ),
            mesh_bytes: mesh.heap_bytes(),
        },
        Build::QuantizedVertices(bits) => {
            let q = QuantizedMesh::new(mesh, bits).expect("valid bit counts");
            let mesh_bytes = q.heap_bytes();
            let tree = QuantizedVertexTree::build(q, &options).expect("builds");
            Built {
                tree: Box::new(tree),
                mesh_bytes,
            }
        }
    }
}

/// Nodes (and leaves) the one-ray walk enters per ray, closest hit
/// ([`RayQueries::cast_ray_visits`]).
fn nodes_per_ray(tree: &dyn Measured, kernel: Kernel, rays: &[Ray]) -> f64 {
    let visits: u64 = rays
        .iter()
        .map(|r| u64::from(tree.cast_ray_visits(r, kernel).1))
        .sum();
    visits as f64 / rays.len().max(1) as f64
}

/// The modes table of one scene, and its records.
pub fn section(scene: &str, mesh: &Arc<Mesh>, rays: &RaySets) -> (String, Vec<Record>) {
    let mut records = Vec::new();
    let judge = Reference::new(mesh);
    let judged: Vec<_> = RaySet::ALL
        .into_iter()
        .map(|set| {
            let sample = &rays.get(set)[..rays.get(set).len().min(JUDGED_RAYS)];
            (set, sample, judge.closest_all(sample))
        })
        .collect();
    let triangles = mesh.triangle_count().max(1) as f64;
    for m in &MODES {
        progress::step(format!("{scene}: mode {}: building and measuring", m.name));
        let built = build(m, mesh);
        for (set, sample, truth) in &judged {
            let all = rays.get(*set);
            let label = format!("closest {set}");
            let answers: Vec<_> = sample
                .iter()
                .map(|r| built.tree.cast_ray_with(r, m.kernel))
                .collect();
            let per_ray = Query::new(QueryKind::Closest, m.kernel, Engine::PerRay).with_threads(1);
            let batched = Query::new(
                QueryKind::Closest,
                m.kernel,
                Engine::batched(BatchOrdering::ByOctant),
            )
            .with_threads(1);
            for (engine, query) in [("per-ray", per_ray), ("batched", batched)] {
                let mut r = Record::new(Section::Modes, scene, m.name, &label, engine)
                    .speed(speed(&*built.tree, query, all));
                r.bytes_per_triangle = Some(built.tree.heap_bytes() as f64 / triangles);
                r.mesh_bytes_per_triangle = Some(built.mesh_bytes as f64 / triangles);
                r.score = Some(score(&judge, sample, truth, &answers));
                if engine == "per-ray" && *set == RaySet::Incoherent {
                    r.nodes_per_ray = Some(nodes_per_ray(&*built.tree, m.kernel, sample));
                }
                records.push(r);
            }
        }
    }
    let judged_rays = judged.first().map_or(0, |(_, sample, _)| sample.len());
    (modes_table(scene, &records, judged_rays), records)
}

/// The modes table: one line per mode and ray set.
fn modes_table(scene: &str, records: &[Record], judged: usize) -> String {
    let mut table = Table::default();
    for (title, align) in [("mode", Align::Left), ("rays", Align::Left)] {
        table.column(title, align);
    }
    for title in [
        "per-ray",
        "batched",
        "bytes/tri",
        "mesh bytes/tri",
        "nodes/ray",
        "hit/miss",
        "wrong tri",
        "ties",
        "max t err",
        "mean t err",
    ] {
        table.column(title, Align::Right);
    }
    for pair in records.chunks(2) {
        let [p, b] = pair else { continue };
        let s = p.score.unwrap_or_default();
        let opt = |x: Option<f64>, d: usize| x.map_or("-".into(), |x| format!("{x:.d$}"));
        table.push(vec![
            p.mode.clone(),
            p.rays.clone(),
            opt(p.mrays_per_s, 2),
            opt(b.mrays_per_s, 2),
            opt(p.bytes_per_triangle, 1),
            opt(p.mesh_bytes_per_triangle, 1),
            opt(p.nodes_per_ray, 2),
            rate(s.missed + s.extra, s.rays),
            rate(s.wrong_triangle, s.rays),
            s.ties.to_string(),
            format!("{:.1e}", s.max_t_error),
            format!("{:.1e}", s.mean_t_error),
        ]);
    }
    format!(
        "Modes on {scene}: closest hit, Mrays/s on one thread (best of {PASSES}), bytes per \
         triangle of the structure and of the mesh it reads; error figures against the f64 \
         judge on the first {} rays of each set (hit/miss and wrong-triangle counts, true ties \
         excluded; t error relative to max(|t|, |origin|)). nodes/ray: binary trees, \
         incoherent rays.\n\n{}",
        thousands(judged),
        table.render()
    )
}

fn rate(count: usize, of: usize) -> String {
    format!("{count} ({:.3}%)", 100.0 * count as f64 / of.max(1) as f64)
}

/// The leak table: every mode on rays aimed at the vertices and edges of closed meshes from
/// inside, per ray and batched; a miss is a leak.
pub fn leaks(count: usize) -> (String, Vec<Record>) {
    let mut records = Vec::new();
    let mut table = Table::default();
    table.column("mesh", Align::Left);
    table.column("mode", Align::Left);
    for title in ["leaks per ray", "leaks batched", "judge misses"] {
        table.column(title, Align::Right);
    }
    for closed in closed_meshes() {
        progress::step(format!("leaks: {}", closed.name));
        let mesh = Arc::new(closed.mesh.clone());
        let rays = aimed_rays(&closed, count, 7);
        let judge = Reference::new(&mesh);
        let truth = judge.closest_all(&rays);
        let judge_misses = truth.iter().filter(|h| h.is_none()).count();
        for m in &MODES {
            let built = build(m, &mesh);
            let [per_ray, batched] = [Engine::PerRay, Engine::batched(BatchOrdering::ByOctant)]
                .map(|engine| {
                    let query = Query::new(QueryKind::Closest, m.kernel, engine).with_threads(1);
                    let mut runner = QueryRunner::new(&*built.tree, query, rays.len())
                        .expect("one thread starts");
                    runner.run(&rays);
                    let misses = runner.closest().iter().filter(|h| h.is_none()).count();
                    (score(&judge, &rays, &truth, runner.closest()), misses)
                });
            for (engine, (s, _)) in [("per-ray", per_ray), ("batched", batched)] {
                let mut r = Record::new(
                    Section::Leaks,
                    closed.name,
                    m.name,
                    "aimed from inside",
                    engine,
                );
                r.score = Some(s);
                records.push(r);
            }
            table.push(vec![
                closed.name.to_string(),
                m.name.to_string(),
                rate(per_ray.1, rays.len()),
                rate(batched.1, rays.len()),
                judge_misses.to_string(),
            ]);
        }
    }
    let text = format!(
        "Leaks: {} rays per closed mesh (5,120 triangles each: an icosphere, a jittered one, one \
         10,000 units from the origin) from inside, aimed exactly at vertices and edge \
         midpoints; every ray must hit, a miss is a leak (docs/benchmarks.md has runs of 10M \
         rays per mesh).\n\n{}",
        thousands(count),
        table.render()
    );
    (text, records)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first mode is the default tree with the watertight kernel, under the name the
    /// report's charts look for.
    #[test]
    fn the_first_mode_is_the_default_tree() {
        let first = &MODES[0];
        assert!(matches!(first.build, Build::Tree(kind) if kind == AccelKind::DEFAULT));
        assert!(matches!(first.kernel, Kernel::Watertight));
        assert_eq!(first.name, raybatch_tools::report::charts::DEFAULT_MODE);
        assert_eq!(
            first.name,
            format!("{} watertight", AccelKind::DEFAULT.name())
        );
    }
}
