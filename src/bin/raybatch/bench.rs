//! `raybatch bench`: build times, memory and single-threaded query speed of every tree and
//! child ordering on the built-in scenes (or a user mesh), as one Markdown table per scene.
//!
//! The timed queries are the entries of [`COLUMNS`]; each goes through a
//! [`QueryRunner`], so a batched engine only needs new entries there, not new code here.

use std::path::Path;
use std::sync::Arc;

use raybatch::scenes::{self, RaySet, Scene, SceneKind};
use raybatch::tree::aabb_tree::NodeFormat;
use raybatch::tree::full_nodes::FullNodes;
use raybatch::tree::quantized_nodes::QuantizedNodes;
use raybatch::{AabbTree, BuildOptions, Bvh, ChildOrdering, Kernel, Mesh, Ray};

use crate::args::BenchArgs;
use crate::error::CliError;
use crate::inputs::load_mesh;
use crate::measure::{Measurement, measure, time_ms};
use crate::runner::{Engine, Query, QueryKind, QueryRunner};
use crate::table::{Align, Table};

/// The built-in scenes `--scenes` accepts.
pub const SCENE_NAMES: [&str; 3] = ["bunny", "terrain", "city"];

/// Rays per set by default (the bunny included), with `--quick`, and the seed they come from.
const DEFAULT_RAYS: usize = 1_000_000;
const QUICK_RAYS: usize = 100_000;
const RAY_SEED: u64 = 1;
/// Timed passes over each ray set; the fastest counts.
const PASSES: usize = 2;

/// One timed query: what is asked, of which rays, by which engine.
#[derive(Clone, Copy, Debug)]
struct Column {
    kind: QueryKind,
    set: RaySet,
    engine: Engine,
}

impl Column {
    const fn per_ray(kind: QueryKind, set: RaySet) -> Self {
        Self {
            kind,
            set,
            engine: Engine::PerRay,
        }
    }

    fn title(&self) -> String {
        match self.engine {
            Engine::PerRay => format!("{} {}", self.kind.name(), self.set),
        }
    }

    fn query(&self) -> Query {
        Query {
            kind: self.kind,
            kernel: Kernel::Watertight,
            engine: self.engine,
        }
    }
}

/// The query columns of every table, in order.
const COLUMNS: [Column; 6] = [
    Column::per_ray(QueryKind::Closest, RaySet::Incoherent),
    Column::per_ray(QueryKind::Closest, RaySet::OutsideIn),
    Column::per_ray(QueryKind::Closest, RaySet::Camera),
    Column::per_ray(QueryKind::Closest, RaySet::Short),
    Column::per_ray(QueryKind::Any, RaySet::LineOfSight),
    Column::per_ray(QueryKind::Any, RaySet::Short),
];

/// What every scene is run with.
struct Plan {
    rays: usize,
    leaf: u32,
    orderings: &'static [ChildOrdering],
}

impl Plan {
    fn from_args(args: &BenchArgs) -> Self {
        let default_rays = if args.quick { QUICK_RAYS } else { DEFAULT_RAYS };
        Self {
            rays: args.rays.unwrap_or(default_rays),
            leaf: args.leaf,
            orderings: if args.quick {
                &[ChildOrdering::Pns]
            } else {
                &ChildOrdering::ALL
            },
        }
    }

    fn options(&self, ordering: ChildOrdering) -> BuildOptions {
        BuildOptions::default()
            .with_leaf_size(self.leaf)
            .with_ordering(ordering)
    }
}

/// A scene ready to benchmark (user meshes have no `'static` name, hence not [`Scene`]).
struct BenchScene {
    name: String,
    mesh: Arc<Mesh>,
    kind: SceneKind,
}

impl From<Scene> for BenchScene {
    fn from(scene: Scene) -> Self {
        Self {
            name: scene.name.to_string(),
            mesh: Arc::new(scene.mesh),
            kind: scene.kind,
        }
    }
}

/// Runs the benchmark and prints its tables on stdout.
pub fn run(args: &BenchArgs) -> Result<(), CliError> {
    let plan = Plan::from_args(args);
    for scene in load_scenes(args)? {
        println!("{}", bench_scene(&scene, &plan));
    }
    Ok(())
}

fn load_scenes(args: &BenchArgs) -> Result<Vec<BenchScene>, CliError> {
    if let Some(path) = &args.mesh {
        return Ok(vec![load_user_mesh(path)?]);
    }
    let scenes = match &args.scenes {
        None => {
            progress("generating the built-in scenes ...");
            scenes::builtin()
        }
        Some(names) => names.iter().map(|n| builtin_scene(n)).collect(),
    };
    Ok(scenes.into_iter().map(BenchScene::from).collect())
}

/// The built-in scene called `name` (one of [`SCENE_NAMES`]; the parser checked).
fn builtin_scene(name: &str) -> Scene {
    progress(&format!("{name}: generating the scene ..."));
    match name {
        "bunny" => scenes::bunny(),
        "terrain" => scenes::terrain(scenes::BUILTIN_TERRAIN_CELLS),
        "city" => scenes::city(scenes::BUILTIN_CITY_BLOCKS),
        other => unreachable!("scene '{other}' passed the parser"),
    }
}

fn load_user_mesh(path: &Path) -> Result<BenchScene, CliError> {
    let mesh = load_mesh(path)?;
    let name = path.file_stem().unwrap_or(path.as_os_str());
    Ok(BenchScene {
        name: name.to_string_lossy().into_owned(),
        mesh: Arc::new(mesh),
        kind: SceneKind::Object,
    })
}

/// The ray sets of one scene, generated once and shared by every tree.
struct RaySets {
    sets: Vec<(RaySet, Vec<Ray>)>,
}

impl RaySets {
    fn generate(scene: &BenchScene, count: usize) -> Self {
        let sets = RaySet::ALL
            .into_iter()
            .map(|set| {
                let rays = scenes::generate(set, &scene.mesh, scene.kind, count, RAY_SEED);
                (set, rays)
            })
            .collect();
        Self { sets }
    }

    fn get(&self, set: RaySet) -> &[Ray] {
        let found = self.sets.iter().find(|(s, _)| *s == set);
        &found.expect("every ray set is generated").1
    }
}

/// Results of one tree and ordering on one scene.
struct Row {
    /// The node format's name ([`NodeFormat::NAME`]).
    tree: &'static str,
    ordering: ChildOrdering,
    build_ms: f64,
    parallel_build_ms: f64,
    bytes_per_triangle: f64,
    /// Mrays/s per entry of [`COLUMNS`].
    mrays: Vec<f64>,
}

/// Builds every tree, measures it, and returns the scene's Markdown section.
fn bench_scene(scene: &BenchScene, plan: &Plan) -> String {
    progress(&format!(
        "{}: generating {} rays per set ...",
        scene.name, plan.rays
    ));
    let rays = RaySets::generate(scene, plan.rays);
    let mut rows = Vec::new();
    let mut kernels = String::new();
    for &ordering in plan.orderings {
        let (row, tree) = bench_tree::<FullNodes>(scene, plan, ordering, &rays);
        rows.push(row);
        if ordering == ChildOrdering::Pns {
            // The default tree: compare the kernels on it while it exists.
            kernels = compare_kernels(&scene.name, &tree, rays.get(RaySet::Incoherent));
        }
    }
    for &ordering in plan.orderings {
        rows.push(bench_tree::<QuantizedNodes>(scene, plan, ordering, &rays).0);
    }
    format!(
        "{}\n{}\n{kernels}\n",
        heading(scene, plan),
        results_table(&rows).render()
    )
}

/// Builds one tree (single-threaded, then in parallel) and times every column on it; returns
/// its row and the tree.
fn bench_tree<N: NodeFormat>(
    scene: &BenchScene,
    plan: &Plan,
    ordering: ChildOrdering,
    rays: &RaySets,
) -> (Row, AabbTree<N>) {
    let label = format!("{}: {}/{}", scene.name, N::NAME, ordering.name());
    progress(&format!("{label}: building ..."));
    let (tree, build_ms) = build::<N>(&scene.mesh, plan.options(ordering).with_parallel(false));
    let (_, parallel_build_ms) = build::<N>(&scene.mesh, plan.options(ordering));
    progress(&format!("{label}: querying ..."));
    let mrays = COLUMNS
        .iter()
        .map(|c| time_query(&tree, c.query(), rays.get(c.set)).mrays_per_s())
        .collect();
    let row = Row {
        tree: N::NAME,
        ordering,
        build_ms,
        parallel_build_ms,
        bytes_per_triangle: tree.bytes_per_triangle(),
        mrays,
    };
    (row, tree)
}

/// The tree and its build time in milliseconds.
fn build<N: NodeFormat>(mesh: &Arc<Mesh>, options: BuildOptions) -> (AabbTree<N>, f64) {
    let (tree, ms) = time_ms(|| AabbTree::<N>::build(Arc::clone(mesh), &options));
    // Leaf sizes are checked by the parser and every scene fits both node formats.
    (tree.expect("the benchmark's trees always build"), ms)
}

/// Best of [`PASSES`] runs of `query` over `rays`.
fn time_query<T: Bvh>(tree: &T, query: Query, rays: &[Ray]) -> Measurement {
    let mut runner = QueryRunner::new(tree, query, rays.len());
    measure(rays, PASSES, |chunk| runner.run(chunk))
}

/// One line comparing the triangle kernels for closest hits on `tree` (the default one,
/// aabb/pns).
fn compare_kernels<T: Bvh>(scene_name: &str, tree: &T, rays: &[Ray]) -> String {
    progress(&format!("{scene_name}: comparing kernels ..."));
    let speed = |kernel| {
        let query = Query {
            kind: QueryKind::Closest,
            kernel,
            engine: Engine::PerRay,
        };
        time_query(tree, query, rays).mrays_per_s()
    };
    let (watertight, moller) = (speed(Kernel::Watertight), speed(Kernel::MollerTrumbore));
    format!(
        "Kernels, closest incoherent on aabb/pns: {} {watertight:.2} Mrays/s, {} {moller:.2} \
         Mrays/s ({} / {} = {}).",
        Kernel::Watertight.name(),
        Kernel::MollerTrumbore.name(),
        Kernel::MollerTrumbore.name(),
        Kernel::Watertight.name(),
        ratio(moller / watertight),
    )
}

fn heading(scene: &BenchScene, plan: &Plan) -> String {
    format!(
        "### {} ({} triangles)\n\nQueries in Mrays/s, one thread, best of {PASSES} passes over \
         {} rays per set; leaf size {}. \"vs aabb\" and \"vs fixed\": speed relative to the aabb \
         tree with the same ordering and to the same tree with the fixed ordering (geometric \
         mean over the query columns).\n",
        scene.name,
        thousands(scene.mesh.triangle_count()),
        thousands(plan.rays),
        plan.leaf,
    )
}

fn results_table(rows: &[Row]) -> Table {
    let mut table = Table::default();
    table.column("tree", Align::Left);
    table.column("ordering", Align::Left);
    table.column("build ms", Align::Right);
    table.column("parallel build ms", Align::Right);
    table.column("bytes/tri", Align::Right);
    for c in &COLUMNS {
        table.column(c.title(), Align::Right);
    }
    table.column("vs aabb", Align::Right);
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
        row.tree.to_string(),
        row.ordering.name().to_string(),
        format!("{:.1}", row.build_ms),
        format!("{:.1}", row.parallel_build_ms),
        format!("{:.1}", row.bytes_per_triangle),
    ];
    cells.extend(row.mrays.iter().map(|m| format!("{m:.2}")));
    cells.push(vs(find(FullNodes::NAME, row.ordering)));
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

fn ratio(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2}x")
    } else {
        "-".to_string()
    }
}

/// `1234567` as `1,234,567`.
fn thousands(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, d) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(d);
    }
    out
}

fn progress(message: &str) {
    eprintln!("{message}");
}
