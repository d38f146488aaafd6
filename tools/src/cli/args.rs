//! The command line, declared with `clap` (derive): the subcommands, their flags, and the help
//! text of each (`raybatch --help`, `raybatch query --help`, ...).
//!
//! Every flag may be given once; anything unknown is a usage error (exit code 2, from clap).
//! Paths stay `PathBuf`s so that non-UTF-8 file names work; `-` as `--out` means stdout.
//!
//! The structures `--tree` accepts, and how the help lists them, come from [`AccelKind::ALL`]:
//! a structure added to the library shows up here without an edit.

use std::path::PathBuf;

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Args, Parser, Subcommand, ValueEnum};
use raybatch::MAX_LEAF_SIZE;
use raybatch::{AccelKind, BatchOrdering, BuildOptions, Interleave, Kernel, LeafCopy};
use raybatch_tools::scenes::RaySet;

use crate::runner::QueryKind;

/// raybatch: batches of ray queries against triangle meshes.
#[derive(Debug, Parser)]
#[command(
    name = "raybatch",
    version,
    after_help = "Exit codes: 0 success, 1 bad input or output file, 2 bad command line.\n\
                  `raybatch COMMAND --help` describes each command's flags."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// What to do.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Time tree builds and queries, per ray and batched, and print Markdown tables per scene
    /// on stdout (progress bars on stderr when it is a terminal).
    Bench(BenchArgs),
    /// Answer the rays of a ray file against an OBJ mesh, write the answers to a file and print
    /// one JSON line of statistics on stderr.
    Query(QueryArgs),
    /// Write a ray file in the format `query` reads: the ray sets of `bench`, aimed at a mesh
    /// treated as one object, so that measurements can be repeated on the same rays.
    Rays(RaysArgs),
    /// Render a mesh to a PNG image with camera rays: normals, depth, or a heat map of the
    /// nodes each ray's walk enters.
    Render(RenderArgs),
    /// Build a tree over an OBJ mesh and write both to a cooked file, which `query`, `render`
    /// and the library (`AnyAccel::load`) read without building; print one JSON line on
    /// stderr: the build, save and load times and the file's size.
    Cook(CookArgs),
}

impl Command {
    /// The subcommand's name, for messages.
    pub fn name(&self) -> &'static str {
        match self {
            Command::Bench(_) => "bench",
            Command::Query(_) => "query",
            Command::Rays(_) => "rays",
            Command::Render(_) => "render",
            Command::Cook(_) => "cook",
        }
    }
}

/// Default largest leaf size.
const DEFAULT_LEAF: &str = "4";

/// The built-in scenes `--scenes` accepts.
pub const SCENE_NAMES: [&str; 6] = [
    "bunny",
    "terrain",
    "city",
    "level",
    "sparse",
    crate::scene_bench::NAME,
];

/// Flags of `raybatch bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Benchmark this OBJ file (an object seen from around) instead of the built-in scenes.
    #[arg(long, value_name = "FILE.obj", conflicts_with = "scenes")]
    pub mesh: Option<PathBuf>,
    /// Built-in scenes to run, comma-separated [default: all but sparse; sparse is a sparse
    /// open world for the spatial hash; instanced: scenes of many meshes placed as instances].
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = PossibleValuesParser::new(SCENE_NAMES))]
    pub scenes: Option<Vec<String>>,
    /// Structures to measure, comma-separated [default: all]. The per-ray vs batched table
    /// and the kernel line follow; the batch size sweep and the partition kernels need the
    /// default structure.
    #[arg(long, value_name = "LIST", value_delimiter = ',', value_parser = tree_parser())]
    pub trees: Option<Vec<AccelKind>>,
    /// Rays per ray set [default: 100000, or 20000 with --quick; at most 16777216]; with
    /// --rays, the fixed and split-axis orderings are timed too, on at most 200000.
    #[arg(long, value_name = "N", value_parser = bench_rays)]
    pub rays: Option<usize>,
    /// Largest leaf size.
    #[arg(long, value_name = "N", default_value = DEFAULT_LEAF, value_parser = leaf_size)]
    pub leaf: u32,
    /// 20000 rays (unless --rays), the pns ordering only and two batch sizes: a smoke test.
    #[arg(long)]
    pub quick: bool,
}

/// Flags of `raybatch query`.
#[derive(Debug, Args)]
pub struct QueryArgs {
    /// The mesh; triangle ids are its triangles in file order (polygons are fan-triangulated).
    /// A tree cooked by `raybatch cook` may stand in its place: it brings its mesh and its
    /// tree, so the build flags do not apply and --tree, if given, must name its kind.
    #[arg(long, value_name = "MESH.obj|TREE.rbt")]
    pub mesh: PathBuf,
    /// Rays as records of 8 little-endian f32: ox oy oz dx dy dz tmin tmax (invalid rays, e.g.
    /// with NaN, are not an error: they miss).
    #[arg(long, value_name = "RAYS.bin")]
    pub rays: PathBuf,
    /// closest: 16 bytes per ray: f32 t, u32 triangle, f32 u, f32 v (a miss is t = +inf,
    /// triangle = 4294967295, u = v = 0). any: 1 byte per ray: 1 if anything is hit in
    /// [tmin, tmax], else 0.
    #[arg(long, value_parser = choice(&QueryKind::ALL, QueryKind::name))]
    pub kind: QueryKind,
    #[command(flatten)]
    pub build: TreeArgs,
    /// The output, written only if everything succeeded ('-': stdout). See tools/README.md
    /// for what happens when the path exists.
    #[arg(long, value_name = "HITS.bin")]
    pub out: PathBuf,
    /// The triangle test: watertight (exact on shared edges) or moller-trumbore.
    #[arg(long, default_value = Kernel::default().name(), value_parser = choice(&Kernel::ALL, Kernel::name))]
    pub kernel: Kernel,
    /// Answer the rays as one batch (same answers, usually faster) instead of one by one.
    #[arg(long)]
    pub batched: bool,
    /// Run the query on N threads [default: 1 for the per-ray engine, one per core for
    /// --batched]; at most 4 per core (see tools/README.md).
    #[arg(long, value_name = "N", value_parser = threads)]
    pub threads: Option<usize>,
    /// Answer the rays once to warm up, then N more times, timing each; the JSON line reports
    /// the median (query_ms, mrays_per_s) and every pass (passes_ms) [default: one timed pass,
    /// no warm-up; at most 1000].
    #[arg(long, value_name = "N", value_parser = passes)]
    pub passes: Option<usize>,
    /// With --batched, pass the rays to the API in calls of N rays [default: all in one call],
    /// e.g. 4096 for a game frame's line-of-sight work.
    #[arg(long, value_name = "N", value_parser = positive)]
    pub batch_size: Option<usize>,
    /// With --batched, the largest chunk the engine walks at once [default: the structure's
    /// own: 65,536 rays for the wide trees (1,048,576 for incoherent rays on a tree of over
    /// 16 MiB with its mesh), 1,048,576 for the grids and kd-tree, 131,072 for the others];
    /// larger chunks share nodes among more rays and take about 90 bytes a ray.
    #[arg(long, value_name = "N", value_parser = positive)]
    pub max_chunk: Option<usize>,
    /// With --batched, whether the wide trees walk rays side by side, hiding cache misses
    /// (always), shares each node among the rays that reach it (never), or picks by its size
    /// (auto).
    #[arg(long, value_name = "WHEN", default_value = Interleave::default().name(), value_parser = choice(&Interleave::ALL, Interleave::name))]
    pub interleave: Interleave,
    /// With --batched, how the rays are grouped by direction (the same answers): by-octant
    /// (the wide trees walk the octants holding less than a quarter of a chunk as one
    /// stream, unless closest-hit rays report many more hits each that way: then every
    /// octant apart), separate-octants (every octant apart: every ray meets the children nearest
    /// first; faster for closest-hit rays that pass many surfaces, such as sightlines in a
    /// city), mixed-octants (by-octant without the choice: small octants always in one
    /// stream), unordered (one stream, children in a fixed order).
    #[arg(long, value_name = "ORDER", default_value = BatchOrdering::default().name(), value_parser = choice(&BatchOrdering::ALL, BatchOrdering::name))]
    pub ordering: BatchOrdering,
}

/// The tree to build over a mesh (`query`, `cook`).
#[derive(Debug, Args)]
pub struct TreeArgs {
    /// The structure to build [default: the fastest per ray for the mesh: bvh8, or bvh8q
    /// where the tree and mesh are beyond the caches (from about 550k triangles)].
    #[arg(long, value_parser = tree_parser())]
    pub tree: Option<AccelKind>,
    /// Largest leaf size.
    #[arg(long, value_name = "N", default_value = DEFAULT_LEAF, value_parser = leaf_size)]
    pub leaf: u32,
    /// The wide trees (bvh4, bvh4q, bvh8, bvh8q): the largest leaf their collapse may merge
    /// small subtrees into where the surface area heuristic says it pays (1: the binary tree's
    /// leaves).
    #[arg(long, value_name = "N", default_value_t = BuildOptions::default().wide_leaf_size, value_parser = leaf_size)]
    pub wide_leaf: u32,
    /// What the tree copies of its leaves' triangles in leaf order: nothing, the vertex
    /// indices with the triangle id (12 bytes per triangle, in place of the 4-byte id; meshes
    /// of more than 2^21 vertices copy nothing), the corners (36 bytes per triangle) or, for
    /// the wide trees, blocks (each leaf's ids and distinct corners together, one read a leaf,
    /// about 28 bytes per triangle; the binary trees copy the indices instead); auto: the
    /// indices for bvh4 and bvh8, blocks for bvh8q over 8 MiB with its mesh (the indices
    /// where blocks would pass 38 bytes a triangle), nothing for the others. Fewer dependent
    /// loads per leaf; the same answers.
    #[arg(long, value_name = "COPY", default_value = LeafCopy::default().name(), value_parser = choice(&LeafCopy::ALL, LeafCopy::name))]
    pub leaf_copy: LeafCopy,
}

impl TreeArgs {
    /// The build options the flags ask for.
    pub fn options(&self) -> BuildOptions {
        BuildOptions::default()
            .with_leaf_size(self.leaf)
            .with_wide_leaf_size(self.wide_leaf)
            .with_leaf_copy(self.leaf_copy)
    }
}

/// Flags of `raybatch cook`.
#[derive(Debug, Args)]
pub struct CookArgs {
    /// The mesh (OBJ).
    #[arg(long, value_name = "MESH.obj", required_unless_present = "scene")]
    pub mesh: Option<PathBuf>,
    /// A built-in scene's mesh instead of an OBJ file (the terrain has 1,002,528 triangles).
    #[arg(long, value_name = "NAME", conflicts_with = "mesh", value_parser = PossibleValuesParser::new(raybatch_tools::scenes::NAMES))]
    pub scene: Option<String>,
    /// The cooked file to write ('-': stdout).
    #[arg(long, value_name = "TREE.rbt")]
    pub out: PathBuf,
    #[command(flatten)]
    pub build: TreeArgs,
    /// Load the written tree back N times, timing each, and report the fastest (at most
    /// 1000).
    #[arg(long, value_name = "N", default_value = "3", value_parser = passes)]
    pub loads: usize,
}

/// Flags of `raybatch rays`.
#[derive(Debug, Args)]
pub struct RaysArgs {
    /// The mesh the rays are aimed at (treated as one object).
    #[arg(long, value_name = "MESH.obj")]
    pub mesh: PathBuf,
    /// Which ray set.
    #[arg(long, value_parser = choice(&RaySet::ALL, RaySet::name))]
    pub set: RaySet,
    /// How many rays (at most 134217728: 4 GiB of rays).
    #[arg(long, value_name = "N", value_parser = ray_count)]
    pub count: usize,
    /// Where to write them ('-': stdout).
    #[arg(long, value_name = "RAYS.bin")]
    pub out: PathBuf,
    /// The generator's seed; the same seed gives the same file on every machine.
    #[arg(long, value_name = "S", default_value = "1")]
    pub seed: u64,
}

/// What a pixel of `raybatch render` shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Shade {
    /// The hit triangle's normal, facing the camera, as a colour (a shaded look).
    Normal,
    /// Distance to the hit, near bright and far dark.
    Depth,
    /// Nodes (cells, for the grids) the ray's one-ray walk entered, blue (few) to red (most).
    Heat,
}

/// Flags of `raybatch render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The mesh to look at: an OBJ file, or a tree cooked by `raybatch cook` (with its mesh).
    #[arg(long, value_name = "MESH.obj|TREE.rbt")]
    pub mesh: PathBuf,
    /// The PNG image to write ('-': stdout).
    #[arg(long, value_name = "IMAGE.png")]
    pub out: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value = "640", value_parser = image_side)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value = "480", value_parser = image_side)]
    pub height: u32,
    /// Where the camera stands, as a direction from the mesh's centre: X,Y,Z (the camera looks
    /// at the centre from far enough to see the whole mesh; +Y is up in the image).
    #[arg(long, value_name = "X,Y,Z", default_value = "0.3,0.25,1", value_parser = direction)]
    pub view: [f32; 3],
    /// What each pixel shows.
    #[arg(long, value_enum, default_value = "normal")]
    pub shade: Shade,
    /// The structure to build [default: bvh8]; a cooked file brings its own.
    #[arg(long, value_parser = tree_parser())]
    pub tree: Option<AccelKind>,
    /// Answer the camera rays as one batch (the same image) instead of one by one; not with
    /// --shade heat, which counts the one-ray walk.
    #[arg(long)]
    pub batched: bool,
}

/// A parser for one of `all`, by `name` (its help lists the names).
fn choice<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
) -> impl TypedValueParser<Value = T> {
    let values = all.iter().map(move |&v| PossibleValue::new(name(v)));
    PossibleValuesParser::new(values).map(move |text| {
        let found = all.iter().find(|&&v| name(v) == text);
        *found.expect("clap only passes the possible values")
    })
}

/// The structures of [`AccelKind::ALL`], by name, each with its summary in the help.
fn tree_parser() -> impl TypedValueParser<Value = AccelKind> {
    let values = AccelKind::ALL.map(|k| PossibleValue::new(k.name()).help(k.summary()));
    PossibleValuesParser::new(values)
        .map(|text| AccelKind::from_name(&text).expect("clap only passes the possible values"))
}

/// A whole number of at least 1.
fn positive(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(0) => Err("must be at least 1".into()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("'{text}' is not a whole number")),
    }
}

/// A whole number from 1 to `max`; `what` says what the limit keeps in bounds.
fn at_most(text: &str, max: usize, what: &str) -> Result<usize, String> {
    let n = positive(text)?;
    if n > max {
        return Err(format!("{n} is more than {max} ({what})"));
    }
    Ok(n)
}

/// Most timed passes of `query --passes`: each pass's time is kept.
const MAX_PASSES: usize = 1000;

fn passes(text: &str) -> Result<usize, String> {
    at_most(text, MAX_PASSES, "the most passes a query times")
}

/// Most rays `rays --count` writes: 4 GiB of rays, generated in memory before they are written.
pub const MAX_RAY_COUNT: usize = 1 << 27;

fn ray_count(text: &str) -> Result<usize, String> {
    at_most(text, MAX_RAY_COUNT, "4 GiB of rays, generated in memory")
}

/// Most rays per set `bench --rays` takes: each scene holds five sets and their answers.
pub const MAX_BENCH_RAYS: usize = 1 << 24;

fn bench_rays(text: &str) -> Result<usize, String> {
    at_most(
        text,
        MAX_BENCH_RAYS,
        "five sets of rays and their answers per scene",
    )
}

fn leaf_size(text: &str) -> Result<u32, String> {
    match text.parse::<u32>() {
        Ok(n) if (1..=MAX_LEAF_SIZE).contains(&n) => Ok(n),
        _ => Err(format!("must be a whole number from 1 to {MAX_LEAF_SIZE}")),
    }
}

/// Threads per core `--threads` accepts at most.
pub const THREADS_PER_CORE: usize = 4;

/// The most threads `--threads` accepts: [`THREADS_PER_CORE`] per core. A query is CPU-bound,
/// so threads beyond the cores only take turns on them; each costs a stack and a workspace, and
/// tens of thousands exhaust the system (the process aborts after minutes).
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    THREADS_PER_CORE * cores
}

fn threads(text: &str) -> Result<usize, String> {
    let n = positive(text)?;
    let max = max_threads();
    if n > max {
        return Err(format!(
            "{n} is more than {max} ({THREADS_PER_CORE} per core on this machine): a query \
             is CPU-bound, more threads only take turns on the cores"
        ));
    }
    Ok(n)
}

/// Largest image side `render` accepts (a 8192 x 8192 image is 67 million rays).
const MAX_IMAGE_SIDE: u32 = 8192;

fn image_side(text: &str) -> Result<u32, String> {
    match text.parse::<u32>() {
        Ok(n) if (1..=MAX_IMAGE_SIDE).contains(&n) => Ok(n),
        _ => Err(format!("must be a whole number from 1 to {MAX_IMAGE_SIDE}")),
    }
}

/// `X,Y,Z`: three finite numbers, not all zero.
fn direction(text: &str) -> Result<[f32; 3], String> {
    let numbers: Result<Vec<f32>, _> = text.split(',').map(|n| n.trim().parse()).collect();
    match numbers.as_deref() {
        Ok(&[x, y, z]) if [x, y, z].iter().all(|v| v.is_finite()) && [x, y, z] != [0.0; 3] => {
            Ok([x, y, z])
        }
        _ => Err(format!(
            "'{text}' is not three finite numbers X,Y,Z, not all 0"
        )),
    }
}
