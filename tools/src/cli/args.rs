//! Command-line parsing by hand: the subcommands, their flags, and the help text.
//!
//! Flags are `--name value` or bare switches; every flag may be given once. Anything unknown is
//! a usage error. Paths stay `OsString`s so that non-UTF-8 file names work.
//!
//! The structures `--tree` accepts, and how the help and usage texts list them, come from
//! [`AccelKind::ALL`]: a structure added to the library shows up here without an edit.

use std::ffi::OsString;
use std::path::PathBuf;
use std::str::FromStr;

use raybatch::bvh::build::MAX_LEAF_SIZE;
use raybatch::{AccelKind, Interleave, Kernel};
use raybatch_tools::scenes::RaySet;

use crate::bench::SCENE_NAMES;
use crate::error::CliError;
use crate::runner::QueryKind;

/// The full `--help` text.
pub fn help() -> String {
    format!(
        "\
raybatch - batches of ray queries against triangle meshes

Usage:
  raybatch bench [--mesh FILE.obj | --scenes LIST] [--rays N] [--leaf N] [--quick]
  raybatch query --mesh MESH.obj --rays RAYS.bin --kind closest|any --out HITS.bin
                 [--tree {trees}] [--kernel watertight|moller-trumbore]
                 [--leaf N] [--batched] [--threads N] [--passes N] [--batch-size N]
                 [--leaf-corners] [--interleave auto|always|never]
  raybatch rays --mesh MESH.obj --set SET --count N --out RAYS.bin [--seed S]
  raybatch --help

bench: times tree builds and queries, per ray and batched, and prints Markdown tables per
scene on stdout (progress goes to stderr).
  --mesh FILE.obj   benchmark this OBJ file (an object seen from around) instead of the
                    built-in scenes
  --scenes LIST     comma-separated built-in scenes: bunny,terrain,city,sparse,instanced
                    (default: all but sparse; sparse is a sparse open world for the spatial
                    hash; instanced: scenes of many meshes placed as instances)
  --rays N          rays per ray set (default 100000, or 20000 with --quick); with --rays,
                    the fixed and split-axis orderings are timed too, on at most 200000
  --leaf N          largest leaf size, 1 to 16 (default 4)
  --quick           20000 rays (unless --rays), the pns ordering only and three batch
                    sizes, a smoke test

query: answers the rays of RAYS.bin against MESH.obj, writes the answers to HITS.bin and
prints one JSON line of statistics on stderr.
  --mesh MESH.obj   the mesh; triangle ids are its triangles in file order (polygons are
                    fan-triangulated)
  --rays RAYS.bin   rays as records of 8 little-endian f32: ox oy oz dx dy dz tmin tmax
                    (invalid rays, e.g. with NaN, are not an error: they miss)
  --kind KIND       closest: 16 bytes per ray: f32 t, u32 triangle, f32 u, f32 v
                      (a miss is t = +inf, triangle = 4294967295, u = v = 0)
                    any: 1 byte per ray: 1 if anything is hit in [tmin, tmax], else 0
  --out HITS.bin    the output, written only if everything succeeded
  --tree TREE       the structure to build (default: {default}):
{tree_list}
  --kernel KERNEL   watertight (the default, exact on shared edges) or moller-trumbore
  --leaf N          largest leaf size, 1 to 16 (default 4)
  --batched         answer the rays as one batch (same answers, usually faster) instead
                    of one by one
  --threads N       run the query on N threads (default: 1 for the per-ray engine,
                    rayon's default, one per core, for --batched)
  --passes N        answer the rays once to warm up, then N more times, timing each; the
                    JSON line reports the median (query_ms, mrays_per_s) and every pass
                    (passes_ms). Default: one timed pass, no warm-up
  --batch-size N    with --batched, pass the rays to the API in calls of N rays (default:
                    all in one call), e.g. 4096 for a game frame's line-of-sight work
  --leaf-corners    keep a copy of each triangle's corners in leaf order (36 more bytes per
                    triangle, fewer dependent loads; the same answers)
  --interleave WHEN with --batched, whether the 4-wide tree walks rays side by side,
                    hiding cache misses (always), shares each node among the rays that
                    reach it (never), or picks by its size (auto, the default)

rays: writes a ray file in the format `query` reads: the ray sets of `bench`, aimed at a mesh
treated as one object, so that measurements can be repeated on the same rays.
  --set SET         incoherent, outside-in, camera, short or line-of-sight
  --count N         number of rays
  --seed S          the generator's seed (default 1); the same seed gives the same file on
                    every machine

Exit codes: 0 success, 1 bad input or output file, 2 bad command line.
",
        trees = tree_names().join("|"),
        default = AccelKind::DEFAULT.name(),
        tree_list = tree_list(),
    )
}

/// Usage lines of `bench`, shown with usage errors.
pub const BENCH_USAGE: &str =
    "usage: raybatch bench [--mesh FILE.obj | --scenes LIST] [--rays N] [--leaf N] [--quick]";

/// Usage lines of `query`, shown with usage errors.
pub fn query_usage() -> String {
    format!(
        "usage: raybatch query --mesh MESH.obj --rays RAYS.bin \
--kind closest|any --out HITS.bin [--tree {}] \
[--kernel watertight|moller-trumbore] [--leaf N] [--batched] [--threads N] \
[--passes N] [--batch-size N] [--leaf-corners] [--interleave auto|always|never]",
        tree_names().join("|")
    )
}

/// The names of every structure, in [`AccelKind::ALL`] order.
fn tree_names() -> Vec<&'static str> {
    AccelKind::ALL.into_iter().map(AccelKind::name).collect()
}

/// One help line per structure: its name and summary, indented under `--tree`.
fn tree_list() -> String {
    let width = AccelKind::ALL
        .iter()
        .map(|k| k.name().len())
        .max()
        .unwrap_or(0);
    let lines: Vec<String> = AccelKind::ALL
        .into_iter()
        .map(|k| format!("                      {:width$}  {}", k.name(), k.summary()))
        .collect();
    lines.join("\n")
}

/// Usage line of the tool as a whole.
pub const TOP_USAGE: &str = "usage: raybatch bench|query|rays [FLAGS] (see raybatch --help)";

/// Usage line of `raybatch rays`.
pub const RAYS_USAGE: &str =
    "usage: raybatch rays --mesh MESH.obj --set SET --count N --out RAYS.bin [--seed S]";

/// Default largest leaf size.
const DEFAULT_LEAF: u32 = 4;

/// What to do.
#[derive(Debug)]
pub enum Command {
    Help,
    Bench(BenchArgs),
    Query(QueryArgs),
    Rays(RaysArgs),
}

/// Flags of `raybatch rays`.
#[derive(Debug)]
pub struct RaysArgs {
    /// The mesh the rays are aimed at (treated as one object).
    pub mesh: PathBuf,
    /// Which ray set.
    pub set: RaySet,
    /// How many rays.
    pub count: usize,
    /// Where to write them.
    pub out: PathBuf,
    /// The generator's seed.
    pub seed: u64,
}

/// Flags of `raybatch bench`.
#[derive(Debug)]
pub struct BenchArgs {
    /// A user mesh instead of the built-in scenes.
    pub mesh: Option<PathBuf>,
    /// Built-in scenes to run, in the given order (`None`: all of them).
    pub scenes: Option<Vec<String>>,
    /// Rays per ray set, overriding the default.
    pub rays: Option<usize>,
    pub leaf: u32,
    pub quick: bool,
}

/// Flags of `raybatch query`.
#[derive(Debug)]
pub struct QueryArgs {
    pub mesh: PathBuf,
    pub rays: PathBuf,
    pub kind: QueryKind,
    pub out: PathBuf,
    /// The structure to build.
    pub tree: AccelKind,
    pub kernel: Kernel,
    pub leaf: u32,
    /// Use the batched engine instead of the per-ray one.
    pub batched: bool,
    /// Threads to run on (`None`: one for the per-ray engine, rayon's default for batched).
    pub threads: Option<usize>,
    /// Timed passes after a warm-up (`None`: one pass, no warm-up).
    pub passes: Option<usize>,
    /// Rays per call of the batched engine (`None`: all in one call).
    pub batch_size: Option<usize>,
    /// Build with [`raybatch::BuildOptions::leaf_corners`].
    pub leaf_corners: bool,
    /// [`raybatch::BatchOptions::interleave`].
    pub interleave: Interleave,
}

/// Parses the arguments after the program name.
pub fn parse(args: Vec<OsString>) -> Result<Command, CliError> {
    if args.iter().any(|a| a == "--help" || a == "-h") {
        return Ok(Command::Help);
    }
    let mut cursor = Cursor::new(args);
    match cursor.next_word()?.as_deref() {
        None => Err(CliError::usage("missing command (bench, query or rays)")),
        Some("help") => Ok(Command::Help),
        Some("bench") => parse_bench(&mut cursor).map(Command::Bench),
        Some("query") => parse_query(&mut cursor).map(Command::Query),
        Some("rays") => parse_rays(&mut cursor).map(Command::Rays),
        Some(other) => Err(CliError::usage(format!("unknown command '{other}'"))),
    }
}

fn parse_bench(cursor: &mut Cursor) -> Result<BenchArgs, CliError> {
    let (mut mesh, mut scenes, mut rays, mut leaf, mut quick) = (None, None, None, None, None);
    while let Some(flag) = cursor.next_flag()? {
        match flag.as_str() {
            "--mesh" => set_once(&mut mesh, &flag, cursor.path(&flag)?)?,
            "--scenes" => set_once(&mut scenes, &flag, scene_list(&cursor.text(&flag)?)?)?,
            "--rays" => set_once(&mut rays, &flag, cursor.positive(&flag)?)?,
            "--leaf" => set_once(&mut leaf, &flag, cursor.leaf_size(&flag)?)?,
            "--quick" => set_once(&mut quick, &flag, true)?,
            _ => return Err(unknown_flag(&flag)),
        }
    }
    if mesh.is_some() && scenes.is_some() {
        return Err(CliError::usage("--mesh and --scenes cannot be combined"));
    }
    Ok(BenchArgs {
        mesh,
        scenes,
        rays,
        leaf: leaf.unwrap_or(DEFAULT_LEAF),
        quick: quick.unwrap_or(false),
    })
}

fn parse_rays(cursor: &mut Cursor) -> Result<RaysArgs, CliError> {
    let (mut mesh, mut set, mut count, mut out, mut seed) = (None, None, None, None, None);
    while let Some(flag) = cursor.next_flag()? {
        match flag.as_str() {
            "--mesh" => set_once(&mut mesh, &flag, cursor.path(&flag)?)?,
            "--set" => set_once(&mut set, &flag, ray_set(&cursor.text(&flag)?)?)?,
            "--count" => set_once(&mut count, &flag, cursor.positive(&flag)?)?,
            "--out" => set_once(&mut out, &flag, cursor.path(&flag)?)?,
            "--seed" => set_once(&mut seed, &flag, cursor.number(&flag)?)?,
            _ => return Err(unknown_flag(&flag)),
        }
    }
    Ok(RaysArgs {
        mesh: required(mesh, "--mesh")?,
        set: required(set, "--set")?,
        count: required(count, "--count")?,
        out: required(out, "--out")?,
        seed: seed.unwrap_or(1),
    })
}

fn ray_set(text: &str) -> Result<RaySet, CliError> {
    RaySet::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = RaySet::ALL.iter().map(|s| s.name()).collect();
        CliError::usage(format!(
            "unknown --set '{text}' (expected {})",
            one_of(&names)
        ))
    })
}

fn parse_query(cursor: &mut Cursor) -> Result<QueryArgs, CliError> {
    let (mut mesh, mut rays, mut kind, mut out) = (None, None, None, None);
    let (mut tree, mut kernel, mut leaf, mut batched, mut threads) = (None, None, None, None, None);
    let (mut passes, mut batch_size, mut leaf_corners, mut interleave) = (None, None, None, None);
    while let Some(flag) = cursor.next_flag()? {
        match flag.as_str() {
            "--mesh" => set_once(&mut mesh, &flag, cursor.path(&flag)?)?,
            "--rays" => set_once(&mut rays, &flag, cursor.path(&flag)?)?,
            "--kind" => set_once(&mut kind, &flag, query_kind(&cursor.text(&flag)?)?)?,
            "--out" => set_once(&mut out, &flag, cursor.path(&flag)?)?,
            "--tree" => set_once(&mut tree, &flag, tree_kind(&cursor.text(&flag)?)?)?,
            "--kernel" => set_once(&mut kernel, &flag, kernel_named(&cursor.text(&flag)?)?)?,
            "--leaf" => set_once(&mut leaf, &flag, cursor.leaf_size(&flag)?)?,
            "--batched" => set_once(&mut batched, &flag, true)?,
            "--threads" => set_once(&mut threads, &flag, cursor.positive(&flag)?)?,
            "--passes" => set_once(&mut passes, &flag, cursor.positive(&flag)?)?,
            "--batch-size" => set_once(&mut batch_size, &flag, cursor.positive(&flag)?)?,
            "--leaf-corners" => set_once(&mut leaf_corners, &flag, true)?,
            "--interleave" => set_once(
                &mut interleave,
                &flag,
                interleave_named(&cursor.text(&flag)?)?,
            )?,
            _ => return Err(unknown_flag(&flag)),
        }
    }
    Ok(QueryArgs {
        mesh: required(mesh, "--mesh")?,
        rays: required(rays, "--rays")?,
        kind: required(kind, "--kind")?,
        out: required(out, "--out")?,
        tree: tree.unwrap_or(AccelKind::DEFAULT),
        kernel: kernel.unwrap_or_default(),
        leaf: leaf.unwrap_or(DEFAULT_LEAF),
        batched: batched.unwrap_or(false),
        threads,
        passes,
        batch_size,
        leaf_corners: leaf_corners.unwrap_or(false),
        interleave: interleave.unwrap_or_default(),
    })
}

fn interleave_named(text: &str) -> Result<Interleave, CliError> {
    Interleave::ALL
        .into_iter()
        .find(|i| i.name() == text)
        .ok_or_else(|| {
            let names: Vec<&str> = Interleave::ALL.iter().map(|i| i.name()).collect();
            CliError::usage(format!(
                "unknown --interleave '{text}' (expected {})",
                one_of(&names)
            ))
        })
}

/// Walks the arguments, handing out flags and their values.
struct Cursor {
    args: std::vec::IntoIter<OsString>,
}

impl Cursor {
    fn new(args: Vec<OsString>) -> Self {
        Self {
            args: args.into_iter(),
        }
    }

    /// The next argument as text, if any.
    fn next_word(&mut self) -> Result<Option<String>, CliError> {
        self.args.next().map(utf8).transpose()
    }

    /// The next flag; a bare word where a flag is expected is an error.
    fn next_flag(&mut self) -> Result<Option<String>, CliError> {
        match self.next_word()? {
            Some(w) if !w.starts_with("--") => {
                Err(CliError::usage(format!("unexpected argument '{w}'")))
            }
            other => Ok(other),
        }
    }

    /// The value after `flag` (one that looks like another flag counts as missing).
    fn value(&mut self, flag: &str) -> Result<OsString, CliError> {
        match self.args.next() {
            Some(v) if !v.to_string_lossy().starts_with("--") => Ok(v),
            _ => Err(CliError::usage(format!("{flag} needs a value"))),
        }
    }

    fn path(&mut self, flag: &str) -> Result<PathBuf, CliError> {
        self.value(flag).map(PathBuf::from)
    }

    fn text(&mut self, flag: &str) -> Result<String, CliError> {
        self.value(flag).and_then(utf8)
    }

    fn number<T: FromStr>(&mut self, flag: &str) -> Result<T, CliError> {
        let text = self.text(flag)?;
        text.parse()
            .map_err(|_| CliError::usage(format!("{flag} needs a whole number, not '{text}'")))
    }

    /// A number of at least 1.
    fn positive(&mut self, flag: &str) -> Result<usize, CliError> {
        match self.number(flag)? {
            0 => Err(CliError::usage(format!("{flag} must be at least 1"))),
            n => Ok(n),
        }
    }

    fn leaf_size(&mut self, flag: &str) -> Result<u32, CliError> {
        let n = self.number(flag)?;
        if (1..=MAX_LEAF_SIZE).contains(&n) {
            Ok(n)
        } else {
            Err(CliError::usage(format!(
                "{flag} must be between 1 and {MAX_LEAF_SIZE}, not {n}"
            )))
        }
    }
}

fn utf8(arg: OsString) -> Result<String, CliError> {
    arg.into_string()
        .map_err(|a| CliError::usage(format!("argument {a:?} is not valid UTF-8")))
}

fn set_once<T>(slot: &mut Option<T>, flag: &str, value: T) -> Result<(), CliError> {
    if slot.replace(value).is_some() {
        return Err(CliError::usage(format!("{flag} given more than once")));
    }
    Ok(())
}

fn required<T>(slot: Option<T>, flag: &str) -> Result<T, CliError> {
    slot.ok_or_else(|| CliError::usage(format!("missing {flag}")))
}

fn unknown_flag(flag: &str) -> CliError {
    CliError::usage(format!("unknown flag '{flag}'"))
}

/// Comma-separated names, each a built-in scene.
fn scene_list(text: &str) -> Result<Vec<String>, CliError> {
    text.split(',')
        .map(str::trim)
        .map(|name| {
            if SCENE_NAMES.contains(&name) {
                Ok(name.to_string())
            } else {
                Err(CliError::usage(format!(
                    "unknown scene '{name}' (expected one of {})",
                    SCENE_NAMES.join(", ")
                )))
            }
        })
        .collect()
}

fn query_kind(text: &str) -> Result<QueryKind, CliError> {
    QueryKind::from_name(text).ok_or_else(|| {
        CliError::usage(format!("unknown --kind '{text}' (expected closest or any)"))
    })
}

fn tree_kind(text: &str) -> Result<AccelKind, CliError> {
    AccelKind::from_name(text).ok_or_else(|| {
        CliError::usage(format!(
            "unknown --tree '{text}' (expected {})",
            one_of(&tree_names())
        ))
    })
}

/// `a`, `a or b`, `a, b or c`: the choices of an error message.
fn one_of(names: &[&str]) -> String {
    match names {
        [] => String::new(),
        [only] => only.to_string(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    }
}

fn kernel_named(text: &str) -> Result<Kernel, CliError> {
    Kernel::ALL
        .into_iter()
        .find(|k| k.name() == text)
        .ok_or_else(|| {
            CliError::usage(format!(
                "unknown --kernel '{text}' (expected watertight or moller-trumbore)"
            ))
        })
}
