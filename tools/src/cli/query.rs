//! `raybatch query`: answers a file of rays against an OBJ mesh and writes the answers to a file.
//!
//! `--out` is checked first ([`Output::plan`]: never an input, never a directory); every input
//! is then read and checked, the tree built and every ray answered before the output is
//! touched, and the output is written all or nothing where the target allows it. Statistics go to
//! stderr as one JSON line, naming the engine (`per-ray` or `batched`) and the thread count.
//!
//! `--batched` answers through the batched engine (by-octant ordering, the CPU's fastest
//! partition kernel), in calls of `--batch-size` rays; `--threads N` runs the query in a rayon
//! pool of `N` threads (see [`crate::runner`]); `--passes N` times N passes after a warm-up
//! and reports their median. Every combination writes the same bytes.

use raybatch::{AccelKind, AnyAccel, Footprint, Mesh, Ray};
use raybatch_tools::formats::{write_closest, write_occluded};

use crate::args::QueryArgs;
use crate::error::CliError;
use crate::heap;
use crate::inputs::{MeshFile, check_cooked_kind, read_mesh_file, read_rays};
use crate::json::JsonLine;
use crate::measure::{Measurement, measure, measure_passes, time_ms};
use crate::output::Output;
use crate::progress;
use crate::runner::Measured;
use crate::runner::{Engine, Query, QueryKind, QueryRunner};

/// What answering the rays produced.
struct Answers<'t> {
    /// The runner, holding the answers of the last pass.
    runner: QueryRunner<'t>,
    build_ms: f64,
    /// The median pass with `--passes`, else the one pass.
    query: Measurement,
    /// Seconds of every timed pass (empty without `--passes`).
    passes: Vec<f64>,
    engine: Engine,
    threads: usize,
}

/// Runs the command.
pub fn run(args: &QueryArgs) -> Result<(), CliError> {
    let output = Output::plan(&args.out, &[&args.mesh, &args.rays])?;
    progress::step(format!("loading {}", args.mesh.display()));
    let file = read_mesh_file(&args.mesh)?;
    progress::step(format!("reading {}", args.rays.display()));
    let rays = read_rays(&args.rays)?;
    // The JSON key of the time the tree took: its build, or its loading from a cooked file.
    let time_key = match file {
        MeshFile::Obj(_) => "build_ms",
        MeshFile::Cooked(..) => "load_ms",
    };
    let (tree, build_ms, build_peak) = match file {
        MeshFile::Obj(mesh) => build(mesh, args)?,
        MeshFile::Cooked(tree, load_ms) => {
            check_cooked_kind(&args.mesh, tree.kind(), args.build.tree)?;
            (*tree, load_ms, 0)
        }
    };
    let (kind, triangles) = (tree.kind(), tree.triangle_count());
    progress::step(format!("answering {} rays", rays.len()));
    let answers = answer(&tree, build_ms, &rays, args)?;
    progress::step("writing the answers");
    output.write(|out| match args.kind {
        QueryKind::Closest => write_closest(out, answers.runner.closest()),
        QueryKind::Any => write_occluded(out, answers.runner.occluded()),
    })?;
    progress::done();
    let memory = Memory {
        tree_bytes: tree.heap_bytes(),
        build_peak_bytes: build_peak,
        time_key,
    };
    eprintln!(
        "{}",
        report(args, kind, triangles, &answers, memory).render()
    );
    Ok(())
}

/// The tree `--tree` names (or the library's choice) over `mesh`, the milliseconds its build
/// took and the most heap it had in use.
fn build(mesh: Mesh, args: &QueryArgs) -> Result<(AnyAccel, f64, usize), CliError> {
    let kind = args
        .build
        .tree
        .unwrap_or_else(|| AccelKind::for_mesh(&mesh));
    progress::step(format!("building {}", kind.name()));
    let options = args.build.options();
    let ((tree, build_ms), build_peak) =
        heap::peak_during(|| time_ms(|| kind.build(mesh, &options)));
    let tree = tree.map_err(|e| CliError::input(format!("{}: {e}", args.mesh.display())))?;
    Ok((tree, build_ms, build_peak))
}

/// Answers every ray with `tree`, timing as `--passes` asks.
fn answer<'t>(
    tree: &'t dyn Measured,
    build_ms: f64,
    rays: &[Ray],
    args: &QueryArgs,
) -> Result<Answers<'t>, CliError> {
    let query = query_for(args);
    let mut runner = QueryRunner::new(tree, query, rays.len()).map_err(|e| {
        CliError::input(format!(
            "cannot start {} threads: {e}",
            query.thread_count()
        ))
    })?;
    let (measurement, passes) = match args.passes {
        Some(n) => {
            let passes = measure_passes(rays, n, &mut runner);
            (passes.median, passes.seconds)
        }
        None => (measure(rays, 1, &mut runner), Vec::new()),
    };
    Ok(Answers {
        runner,
        build_ms,
        query: measurement,
        passes,
        engine: query.engine,
        threads: query.thread_count(),
    })
}

/// The query the flags ask for: `--batched` picks the engine, `--threads` the pool.
fn query_for(args: &QueryArgs) -> Query {
    let engine = if args.batched {
        Engine::batched(args.ordering)
    } else {
        Engine::PerRay
    };
    let mut query = Query::new(args.kind, args.kernel, engine);
    if let Some(n) = args.threads {
        query = query.with_threads(n);
    }
    if let Some(n) = args.batch_size {
        query = query.with_batch_size(n);
    }
    if let Some(n) = args.max_chunk {
        query = query.with_max_chunk(n);
    }
    query.with_interleave(args.interleave)
}

/// What the structure keeps beside the mesh, and the most heap its build had in use at once
/// (the structure included, the mesh not).
struct Memory {
    tree_bytes: usize,
    build_peak_bytes: usize,
    /// `build_ms`, or `load_ms` for a cooked tree (whose peak is then 0: nothing was built).
    time_key: &'static str,
}

fn report(
    args: &QueryArgs,
    kind: AccelKind,
    triangles: usize,
    answers: &Answers,
    memory: Memory,
) -> JsonLine {
    let line = JsonLine::default()
        .int("rays", answers.query.rays)
        .int("triangles", triangles)
        .str("tree", kind.name())
        .str("kind", args.kind.name())
        .str("kernel", args.kernel.name())
        .str("engine", answers.engine.name())
        .int("threads", answers.threads)
        .num(memory.time_key, answers.build_ms)
        .int("tree_bytes", memory.tree_bytes)
        .int("build_peak_bytes", memory.build_peak_bytes)
        .num("query_ms", answers.query.seconds * 1e3)
        .num("mrays_per_s", answers.query.mrays_per_s())
        .int("hits", answers.query.hits);
    let line = match args.max_chunk {
        Some(n) => line.int("max_chunk", n),
        None => line,
    };
    let line = if kind.is_wide() {
        line.int("wide_leaf", args.build.wide_leaf as usize)
    } else {
        line
    };
    let line = line.str("leaf_copy", args.build.leaf_copy.name());
    let line = if args.batched {
        line.str("ordering", args.ordering.name())
    } else {
        line
    };
    match (args.passes, args.batch_size) {
        (None, None) => line,
        _ => {
            let passes_ms: Vec<f64> = answers.passes.iter().map(|s| s * 1e3).collect();
            line.int("passes", passes_ms.len())
                .nums("passes_ms", &passes_ms)
                .int("batch_size", args.batch_size.unwrap_or(answers.query.rays))
        }
    }
}
