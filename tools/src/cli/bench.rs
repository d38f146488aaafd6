//! `raybatch bench`: build times, memory and query speed of every tree and child ordering on
//! the built-in scenes (or a user mesh), as Markdown on stdout, per scene:
//!
//! 1. the main table: per-ray speed on one thread of every tree and ordering, one column per
//!    entry of [`COLUMNS`] (pns on every ray; fixed and split-axis on at most
//!    [`VARIANT_RAYS`], to keep the full run short);
//! 2. the zero-byte trees against brute force, the only other zero-memory option (one line);
//!    the triangle kernels on the default tree (one line);
//! 3. per-ray vs batched on the pns trees ([`compare::batched_section`]);
//! 4. on the bunny only, the batch size sweep and the partition kernels;
//!
//! and, after the scenes, the scenes of instances ([`crate::scene_bench`], `--scenes instanced`).
//!
//! The trees are every structure of [`AccelKind::ALL`], in that order, and the default tree is
//! [`AccelKind::DEFAULT`]: a structure added to the library gets its rows with no edit here.
//! Every timed query is a [`crate::runner::Query`] run by [`crate::workload`].

use std::path::Path;
use std::sync::Arc;

use raybatch::brute_force;
use raybatch::{AccelKind, AnyAccel, BuildOptions, ChildOrdering, Footprint, Kernel, Mesh};
use raybatch_tools::report::{Record, Section};
use raybatch_tools::scenes::{self, RaySet, Scene, SceneKind};

use crate::args::BenchArgs;
use crate::compare::{self, BatchedRow, Subject};
use crate::error::CliError;
use crate::heap;
use crate::inputs::load_mesh;
use crate::measure::time_ms;
use crate::progress::{self, Job};
use crate::runner::{Engine, QueryKind};
use crate::table::{Align, Table, ratio, thousands};
use crate::workload::{COLUMNS, PASSES, RaySets, speed};

/// Rays per set by default (the bunny included), with `--quick`, and at most for the orderings
/// other than pns (timed only when `--rays` asks for a long run). The default keeps the whole
/// run, report included, under five minutes on two cores.
const DEFAULT_RAYS: usize = 100_000;
const QUICK_RAYS: usize = 20_000;
const VARIANT_RAYS: usize = 200_000;
/// Batch sizes of the sweep (below the ray count; the whole set is always the last size).
const SWEEP_SIZES: [usize; 6] = [64, 256, 1 << 10, 1 << 12, 1 << 14, 1 << 16];
const QUICK_SWEEP_SIZES: [usize; 2] = [64, 1 << 12];

/// What every scene is run with.
struct Plan {
    rays: usize,
    /// Rays per set for the orderings other than pns.
    variant_rays: usize,
    leaf: u32,
    /// The structures to measure (`--trees`), in [`AccelKind::ALL`] order.
    trees: Vec<AccelKind>,
    orderings: &'static [ChildOrdering],
    batch_sizes: &'static [usize],
}

impl Plan {
    fn from_args(args: &BenchArgs) -> Self {
        let default_rays = if args.quick { QUICK_RAYS } else { DEFAULT_RAYS };
        let rays = args.rays.unwrap_or(default_rays);
        let (orderings, batch_sizes): (&'static [_], &'static [_]) = if args.quick {
            (&[ChildOrdering::Pns], &QUICK_SWEEP_SIZES)
        } else if args.rays.is_some() {
            (&ChildOrdering::ALL, &SWEEP_SIZES)
        } else {
            (&[ChildOrdering::Pns], &SWEEP_SIZES)
        };
        Self {
            rays,
            variant_rays: rays.min(VARIANT_RAYS),
            leaf: args.leaf,
            trees: AccelKind::ALL
                .into_iter()
                .filter(|k| args.trees.as_ref().is_none_or(|t| t.contains(k)))
                .collect(),
            orderings,
            batch_sizes,
        }
    }

    fn options(&self, ordering: ChildOrdering) -> BuildOptions {
        BuildOptions::default()
            .with_leaf_size(self.leaf)
            .with_ordering(ordering)
    }

    /// Whether some ordering runs on fewer rays than pns.
    fn has_variant_rays(&self) -> bool {
        self.variant_rays < self.rays && self.orderings.iter().any(|&o| o != ChildOrdering::Pns)
    }

    /// The orderings `kind` is measured with: a structure that ignores the ordering is
    /// measured once, as pns.
    fn orderings_of(&self, kind: AccelKind) -> impl Iterator<Item = ChildOrdering> + '_ {
        let orderings = self.orderings.iter().copied();
        orderings.filter(move |&o| kind.uses_child_ordering() || o == ChildOrdering::Pns)
    }
}

/// A scene ready to benchmark (user meshes have no `'static` name, hence not [`Scene`]).
struct BenchScene {
    name: String,
    mesh: Arc<Mesh>,
    kind: SceneKind,
    /// Also run the batch size sweep and the partition kernels (the built-in bunny).
    detailed: bool,
}

impl From<Scene> for BenchScene {
    fn from(scene: Scene) -> Self {
        Self {
            name: scene.name.to_string(),
            mesh: Arc::new(scene.mesh),
            kind: scene.kind,
            detailed: scene.name == "bunny",
        }
    }
}

/// Runs the benchmark and prints its tables on stdout.
pub fn run(args: &BenchArgs) -> Result<(), CliError> {
    // The tables time queries on pools of up to `compare::THREADS` threads.
    rayon::ThreadPoolBuilder::new()
        .num_threads(compare::THREADS)
        .build()
        .map_err(|e| {
            CliError::input(format!(
                "the benchmark needs {} threads and the system refused them: {e}",
                compare::THREADS
            ))
        })?;
    let plan = Plan::from_args(args);
    for scene in load_scenes(args)? {
        let section = bench_scene(&scene, &plan);
        progress::suspend(|| println!("{section}"));
    }
    let instanced = match &args.scenes {
        None => args.mesh.is_none(),
        Some(names) => names.iter().any(|n| n == crate::scene_bench::NAME),
    };
    if instanced {
        let section = crate::scene_bench::section(plan.rays);
        progress::suspend(|| println!("{section}"));
    }
    if args.mesh.is_none() {
        let (leaks, records) = crate::modes::leaks(plan.rays.min(crate::modes::LEAK_RAYS));
        progress::suspend(|| println!("{leaks}"));
        crate::records::push(records);
    }
    let dir = crate::records::report_dir();
    let page = crate::records::write_report(&dir).map_err(|e| {
        CliError::input(format!("cannot write the report to {}: {e}", dir.display()))
    })?;
    progress::done();
    println!("Report: {} (and report.csv beside it)", page.display());
    Ok(())
}

fn load_scenes(args: &BenchArgs) -> Result<Vec<BenchScene>, CliError> {
    if let Some(path) = &args.mesh {
        return Ok(vec![load_user_mesh(path)?]);
    }
    let scenes = match &args.scenes {
        None => {
            progress::step("generating the built-in scenes");
            scenes::builtin()
        }
        Some(names) => names
            .iter()
            .filter(|n| *n != crate::scene_bench::NAME)
            .map(|n| builtin_scene(n))
            .collect(),
    };
    Ok(scenes.into_iter().map(BenchScene::from).collect())
}

/// The built-in scene called `name` (one of [`crate::args::SCENE_NAMES`]; the parser checked).
fn builtin_scene(name: &str) -> Scene {
    progress::step(format!("{name}: generating the scene"));
    scenes::named(name).unwrap_or_else(|| unreachable!("scene '{name}' passed the parser"))
}

fn load_user_mesh(path: &Path) -> Result<BenchScene, CliError> {
    let mesh = load_mesh(path)?;
    let name = path.file_stem().unwrap_or(path.as_os_str());
    Ok(BenchScene {
        name: name.to_string_lossy().into_owned(),
        mesh: Arc::new(mesh),
        kind: SceneKind::Object,
        detailed: false,
    })
}

/// The ray sets of one scene: every ray for pns, maybe fewer for the other orderings.
struct SceneRays {
    all: RaySets,
    variants: Option<RaySets>,
}

impl SceneRays {
    fn generate(scene: &BenchScene, plan: &Plan) -> Self {
        let generate = |count| {
            progress::step(format!("{}: generating {count} rays per set", scene.name));
            RaySets::generate(&scene.mesh, scene.kind, count)
        };
        Self {
            all: generate(plan.rays),
            variants: plan.has_variant_rays().then(|| generate(plan.variant_rays)),
        }
    }

    fn for_ordering(&self, ordering: ChildOrdering) -> &RaySets {
        match (&self.variants, ordering) {
            (Some(variants), o) if o != ChildOrdering::Pns => variants,
            _ => &self.all,
        }
    }
}

/// Results of one tree and ordering on one scene.
struct Row {
    tree: AccelKind,
    ordering: ChildOrdering,
    build_ms: f64,
    parallel_build_ms: f64,
    /// Loading the tree from its cooked bytes, if its kind cooks.
    load_ms: Option<f64>,
    bytes_per_triangle: f64,
    /// The most heap the (parallel) build had in use at once, per triangle.
    build_peak_per_triangle: f64,
    /// Per-ray Mrays/s on one thread, per entry of [`COLUMNS`].
    mrays: Vec<f64>,
}

impl Row {
    /// The speed of the column asking `kind` of `set`.
    fn speed_of(&self, kind: QueryKind, set: RaySet) -> f64 {
        let column = COLUMNS.iter().position(|c| c.kind == kind && c.set == set);
        self.mrays[column.expect("the main table has this column")]
    }
}

/// Everything printed for one scene, gathered tree by tree.
#[derive(Default)]
struct SceneReport {
    rows: Vec<Row>,
    /// The zero-byte trees against the only other zero-memory option, brute force.
    zero_memory: String,
    kernels: String,
    batched: Vec<BatchedRow>,
    /// The batch size sweep and the partition kernels (detailed scenes only).
    details: Vec<String>,
}

impl SceneReport {
    fn render(&self, scene: &BenchScene, plan: &Plan) -> String {
        let mut sections = vec![
            heading(scene, plan),
            results_table(&self.rows).render(),
            self.zero_memory.clone(),
            self.kernels.clone(),
            compare::batched_section(&self.batched, plan.rays),
        ];
        sections.extend(self.details.iter().cloned());
        // One blank line between sections, whether or not they end in a newline.
        // (`--trees` may leave some out: no zero-byte tree, no default tree.)
        let sections: Vec<&str> = sections
            .iter()
            .map(|s| s.trim_end())
            .filter(|s| !s.is_empty())
            .collect();
        sections.join("\n\n") + "\n"
    }
}

/// Builds every tree, measures it, and returns the scene's Markdown section.
fn bench_scene(scene: &BenchScene, plan: &Plan) -> String {
    let rays = SceneRays::generate(scene, plan);
    let mut report = SceneReport::default();
    let trees = plan
        .trees
        .iter()
        .map(|&k| plan.orderings_of(k).count())
        .sum::<usize>();
    let job = Job::start(&scene.name, trees as u64, "trees");
    for &kind in &plan.trees {
        bench_kind(kind, scene, plan, &rays, &mut report, &job);
    }
    job.finish();
    report.zero_memory = zero_memory(scene, &rays.all, &report.rows);
    let (modes, records) = crate::modes::section(&scene.name, &scene.mesh, &rays.all);
    crate::records::push(records);
    report.details.push(modes);
    report.render(scene, plan)
}

/// Benchmarks structure `kind` with every ordering; the pns tree also gets the batched
/// comparison, and the extra comparisons if `kind` is the default structure.
fn bench_kind(
    kind: AccelKind,
    scene: &BenchScene,
    plan: &Plan,
    rays: &SceneRays,
    report: &mut SceneReport,
    job: &Job,
) {
    for ordering in plan.orderings_of(kind) {
        let (row, tree) = bench_tree(kind, scene, plan, ordering, rays.for_ordering(ordering));
        if ordering == ChildOrdering::Pns {
            let subject = Subject {
                scene: &scene.name,
                label: format!("{}/{}", kind.name(), ordering.name()),
                tree: &tree,
            };
            report
                .batched
                .extend(compare::batched_rows(&subject, &row.mrays, &rays.all));
            if kind == AccelKind::DEFAULT {
                default_tree_extras(&subject, scene, plan, &rays.all, &row, report);
            }
        }
        crate::records::push(main_records(&scene.name, &row));
        report.rows.push(row);
        job.advance();
    }
}

/// The report's rows of one main-table row: one per query column.
fn main_records(scene: &str, row: &Row) -> Vec<Record> {
    let mode = format!("{}/{}", row.tree.name(), row.ordering.name());
    COLUMNS
        .iter()
        .zip(&row.mrays)
        .map(|(c, &m)| {
            let mut r = Record::new(Section::Main, scene, &mode, &c.title(), "per-ray").speed(m);
            r.bytes_per_triangle = Some(row.bytes_per_triangle);
            r
        })
        .collect()
}

/// Rays brute force is timed on: it tests every triangle, so a few thousand say enough, and
/// fewer on large meshes (about [`BRUTE_FORCE_TESTS`] ray/triangle tests, a few seconds).
const BRUTE_FORCE_RAYS: usize = 2_000;
const BRUTE_FORCE_TESTS: usize = 200_000_000;
const BRUTE_FORCE_MIN_RAYS: usize = 100;

/// One paragraph: brute force (the O(n) scan, the only other option that needs no memory
/// beside the mesh) against the zero-byte trees, closest hit on incoherent rays, and what the
/// zero-byte trees keep beside the mesh.
fn zero_memory(scene: &BenchScene, rays: &RaySets, rows: &[Row]) -> String {
    let zero_byte = |r: &&Row| r.tree == AccelKind::Zbt;
    if !rows.iter().any(|r| zero_byte(&r)) {
        // `--trees` left it out.
        return String::new();
    }
    let incoherent = rays.get(RaySet::Incoherent);
    let affordable = BRUTE_FORCE_TESTS / scene.mesh.triangle_count().max(1);
    let count = affordable.clamp(BRUTE_FORCE_MIN_RAYS, BRUTE_FORCE_RAYS);
    let sample = &incoherent[..incoherent.len().min(count)];
    progress::step(format!("{}: brute force", scene.name));
    let brute = brute_force_speed(&scene.mesh, sample);
    let zbt = rows
        .iter()
        .filter(|r| r.ordering == ChildOrdering::Pns)
        .filter(zero_byte)
        .map(|r| {
            let speed = r.speed_of(QueryKind::Closest, RaySet::Incoherent);
            format!(
                "{} {speed:.2} Mrays/s ({} brute force)",
                r.tree.name(),
                ratio(speed / brute)
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    format!(
        "Zero memory beside the mesh, closest incoherent: brute force {} rays/s (on {} rays); \
         {zbt}. The zero-byte trees' bytes/tri is 0: each thread that queries one \
         keeps a box cache of {} KiB (shared by every zero-byte and hybrid tree it queries), \
         and the catalog keeps a 4 bytes/tri id map to answer in the mesh's own triangle ids \
         (`Footprint::id_map_bytes`; a user of `ZeroByteTree` reorders per-triangle data \
         once instead).",
        thousands((brute * 1e6) as usize),
        thousands(sample.len()),
        raybatch::zbt::BOX_CACHE_BYTES / 1024,
    )
}

/// Mrays/s of the brute-force closest hit over `rays` on one thread.
fn brute_force_speed(mesh: &Mesh, rays: &[raybatch::Ray]) -> f64 {
    let (hits, ms) = time_ms(|| {
        rays.iter()
            .filter(|r| brute_force::cast_ray(mesh, r, Kernel::Watertight).is_some())
            .count()
    });
    std::hint::black_box(hits);
    rays.len() as f64 / (ms * 1e3)
}

/// The comparisons run on the default tree only: kernels, and on detailed scenes the batch size
/// sweep and the partition kernels.
fn default_tree_extras(
    subject: &Subject,
    scene: &BenchScene,
    plan: &Plan,
    rays: &RaySets,
    row: &Row,
    report: &mut SceneReport,
) {
    let incoherent = rays.get(RaySet::Incoherent);
    report.kernels = compare::compare_kernels(subject, incoherent);
    if scene.detailed {
        let per_ray = row.speed_of(QueryKind::Closest, RaySet::Incoherent);
        let sweep = compare::batch_size_sweep(subject, incoherent, per_ray, plan.batch_sizes);
        let partitions = compare::compare_partitions(subject, incoherent);
        report.details.extend([sweep, partitions]);
    }
}

/// Builds one tree (single-threaded, then in parallel) and times every column on it, per ray
/// on one thread; returns its row and the tree.
fn bench_tree(
    kind: AccelKind,
    scene: &BenchScene,
    plan: &Plan,
    ordering: ChildOrdering,
    rays: &RaySets,
) -> (Row, AnyAccel) {
    let label = format!("{}: {}/{}", scene.name, kind.name(), ordering.name());
    progress::step(format!("{label}: building"));
    let options = plan.options(ordering);
    let (tree, build_ms) = build(kind, &scene.mesh, options.with_parallel(false));
    let ((_, parallel_build_ms), build_peak) =
        heap::peak_during(|| build(kind, &scene.mesh, options));
    progress::step(format!("{label}: loading it cooked"));
    let load_ms = load_ms(&tree);
    let mrays = COLUMNS
        .iter()
        .map(|c| {
            progress::step(format!("{label}: per-ray {}", c.title()));
            speed(&tree, c.query(Engine::PerRay), rays.get(c.set))
        })
        .collect();
    let row = Row {
        tree: kind,
        ordering,
        build_ms,
        parallel_build_ms,
        load_ms,
        bytes_per_triangle: tree.bytes_per_triangle(),
        build_peak_per_triangle: build_peak as f64 / scene.mesh.triangle_count().max(1) as f64,
        mrays,
    };
    (row, tree)
}

/// The fastest of three loads of `tree` from its cooked bytes (`raybatch cook`), in
/// milliseconds, if its kind cooks.
fn load_ms(tree: &AnyAccel) -> Option<f64> {
    let bytes = tree.to_cooked().ok()?;
    Some(crate::cook::fastest_load(&bytes, 3).expect("a cooked tree loads as it was saved"))
}

/// The tree and its build time in milliseconds.
fn build(kind: AccelKind, mesh: &Arc<Mesh>, options: BuildOptions) -> (AnyAccel, f64) {
    let (tree, ms) = time_ms(|| kind.build(Arc::clone(mesh), &options));
    // Leaf sizes are checked by the parser and every scene fits every structure.
    (tree.expect("the benchmark's trees always build"), ms)
}

fn heading(scene: &BenchScene, plan: &Plan) -> String {
    format!(
        "### {} ({} triangles)\n\nQueries in Mrays/s, per ray, one thread, best of {PASSES} \
         passes over {}; leaf size {}. \"vs {default}\" and \"vs fixed\": speed relative to the \
         {default} tree with the same ordering and to the same tree with the fixed ordering \
         (geometric mean over the query columns).\n",
        scene.name,
        thousands(scene.mesh.triangle_count()),
        ray_counts(plan),
        plan.leaf,
        default = AccelKind::DEFAULT.name(),
    )
}

/// How many rays each ordering was timed on, for the caption.
fn ray_counts(plan: &Plan) -> String {
    let all = thousands(plan.rays);
    if !plan.has_variant_rays() {
        return format!("{all} rays per set");
    }
    format!(
        "{all} rays per set for pns and {} for the other orderings (same distributions, so \
         the speeds compare)",
        thousands(plan.variant_rays)
    )
}

fn results_table(rows: &[Row]) -> Table {
    let mut table = Table::default();
    table.column("tree", Align::Left);
    table.column("ordering", Align::Left);
    table.column("build ms", Align::Right);
    table.column("parallel build ms", Align::Right);
    table.column("load ms", Align::Right);
    table.column("bytes/tri", Align::Right);
    table.column("build peak bytes/tri", Align::Right);
    for c in &COLUMNS {
        table.column(c.title(), Align::Right);
    }
    table.column(format!("vs {}", AccelKind::DEFAULT.name()), Align::Right);
    table.column("vs fixed", Align::Right);
    for row in rows {
        table.push(row_cells(row, rows));
    }
    table
}

fn row_cells(row: &Row, rows: &[Row]) -> Vec<String> {
    let find = |tree, ordering| {
        rows.iter()
            .find(|r| r.tree == tree && r.ordering == ordering)
    };
    let vs = |base: Option<&Row>| base.map_or("-".to_string(), |b| ratio(speedup(row, b)));
    let mut cells = vec![
        row.tree.name().to_string(),
        row.ordering.name().to_string(),
        format!("{:.1}", row.build_ms),
        format!("{:.1}", row.parallel_build_ms),
        row.load_ms.map_or("-".to_string(), |ms| format!("{ms:.1}")),
        format!("{:.1}", row.bytes_per_triangle),
        format!("{:.1}", row.build_peak_per_triangle),
    ];
    cells.extend(row.mrays.iter().map(|m| format!("{m:.2}")));
    cells.push(vs(find(AccelKind::DEFAULT, row.ordering)));
    cells.push(vs(find(row.tree, ChildOrdering::Fixed)));
    cells
}

/// Geometric mean over the columns of `row`'s speed divided by `base`'s.
fn speedup(row: &Row, base: &Row) -> f64 {
    let logs: f64 = row
        .mrays
        .iter()
        .zip(&base.mrays)
        .map(|(a, b)| (a / b).ln())
        .sum();
    (logs / row.mrays.len() as f64).exp()
}
