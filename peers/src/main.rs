//! `peers`: the same mesh and rays through raybatch, Embree 3, obvhs and parry3d, in one run.
//!
//! Every library builds its structure single-threaded and casts every ray single-threaded
//! (closest hit), best of `--runs` passes each; raybatch runs every structure of
//! `AccelKind::ALL`, per ray and batched (the default one also in calls of 4,096 rays). The
//! hits are checked against raybatch's default structure (`AccelKind::DEFAULT`, `cast_ray`)
//! and a Markdown table of build time, query time, Mrays/s and the speed relative to Embree's
//! `rtcIntersect1` goes to stdout; progress goes to stderr. `--race R` times only the
//! headline rows, taking turns (`raybatch_peers::race`); `--build-race R` times only the
//! builds, on every core (`raybatch_peers::build_race`).
//!
//! ```text
//! bash peers/setup.sh && cargo run --release -p raybatch-peers -- --rays 1000000
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use raybatch::{AccelKind, Mesh, Ray};
use raybatch_tools::scenes::{self, SceneKind};

use raybatch_peers::compare::{T_TOLERANCE, compare};
use raybatch_peers::engines::{self, Run};
use raybatch_peers::{embree_ffi, race, rays};

const USAGE: &str = "\
usage: peers [--mesh FILE.obj | --scene NAME] [--rays N] [--sets A,B,..] [--seed S] [--runs R]
             [--race R | --build-race R | --shape-race R]

  --mesh FILE.obj  triangle mesh, treated as one object (default: data/stanford-bunny.obj of
                   the raybatch crate)
  --scene NAME     instead, a built-in scene of `raybatch bench` (bunny, terrain, city, level,
                   sparse) with its own ray sets: the level's line of sight is the game-AI
                   case (agents in the open, 20-80 m apart, mostly blocked), the city's is
                   sightlines between walkers in its streets
  --rays N         rays per set (default 1000000; underscores allowed)
  --sets A,B,..    ray sets of raybatch_tools::scenes (default incoherent,outside-in,line-of-sight;
                   also camera, short); line-of-sight also times any-hit queries
  --seed S         ray seed (default 1)
  --runs R         timed passes per build and per query, best kept (default 3)
  --race R         instead of the full table, the headline rows (Embree's one-ray calls,
                   raybatch bvh4 / bvh8 / bvh8q per ray, batched and in calls of 4096),
                   built once per ray set and timed in turn for R rounds (R at least the
                   rows' count lets each go first once), best pass kept: ratios that hold on
                   a machine whose speed drifts; --runs is not used
  --build-race R   instead of any ray, the build on every core: Embree at qualities MEDIUM
                   (its default) and HIGH against raybatch's default parallel build of
                   AccelKind::for_mesh, bvh8, bvh4 and aabb, in turn for R rounds, best kept
  --shape-race R   instead of any ray, shape queries one at a time (sphere and capsule
                   overlaps and sweeps, --rays of each, at most 200000) against parry3d's
                   TriMesh, in turn for R rounds, best kept, and their agreement";

struct Args {
    mesh: PathBuf,
    /// A built-in scene instead of `mesh` (`--scene NAME`).
    scene: Option<String>,
    rays: usize,
    sets: Vec<rays::SetKind>,
    seed: u64,
    runs: usize,
    /// Rounds of the race, if one was asked for (`--race R`).
    race: Option<usize>,
    /// Rounds of the build race, if one was asked for (`--build-race R`).
    build_race: Option<usize>,
    /// Rounds of the shape race, if one was asked for (`--shape-race R`).
    shape_race: Option<usize>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        mesh: PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../data/stanford-bunny.obj"
        )),
        scene: None,
        rays: 1_000_000,
        sets: rays::DEFAULT_SETS.to_vec(),
        seed: 1,
        runs: 3,
        race: None,
        build_race: None,
        shape_race: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "-h" || flag == "--help" {
            return Err(String::new());
        }
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |v: &str| -> Result<u64, String> {
            v.replace('_', "")
                .parse()
                .map_err(|e| format!("{flag} {v}: {e}"))
        };
        match flag.as_str() {
            "--mesh" => args.mesh = PathBuf::from(value),
            // Checked by `load`: naming a scene builds it.
            "--scene" => args.scene = Some(value),
            "--rays" => args.rays = number(&value)? as usize,
            "--sets" => {
                args.sets = value
                    .split(',')
                    .map(|name| {
                        rays::SetKind::from_name(name.trim())
                            .ok_or_else(|| format!("unknown ray set {name:?}"))
                    })
                    .collect::<Result<_, _>>()?
            }
            "--seed" => args.seed = number(&value)?,
            "--runs" => args.runs = (number(&value)? as usize).max(1),
            "--race" => args.race = Some((number(&value)? as usize).max(1)),
            "--build-race" => args.build_race = Some((number(&value)? as usize).max(1)),
            "--shape-race" => args.shape_race = Some((number(&value)? as usize).max(1)),
            _ => return Err(format!("unknown argument {flag}")),
        }
    }
    Ok(args)
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("error: {e}");
            }
            eprintln!("{USAGE}");
            return if e.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(2)
            };
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The mesh `args` name, its name for the report and its scene kind (an OBJ file is one object).
fn load(args: &Args) -> Result<(String, Mesh, SceneKind), String> {
    if let Some(name) = &args.scene {
        eprintln!("building the {name} scene");
        let scene = scenes::named(name)
            .ok_or_else(|| format!("unknown scene {name:?} ({})", scenes::NAMES.join(", ")))?;
        return Ok((format!("{name} (built-in scene)"), scene.mesh, scene.kind));
    }
    eprintln!("loading {}", args.mesh.display());
    let mesh = Mesh::load_obj(&args.mesh).map_err(|e| e.to_string())?;
    Ok((args.mesh.display().to_string(), mesh, SceneKind::Object))
}

fn run(args: &Args) -> Result<(), String> {
    let (name, mesh, scene) = load(args)?;
    let mesh = Arc::new(mesh);
    if let Some(rounds) = args.build_race {
        println!(
            "# Builds on every core\n\nMesh `{name}` ({} triangles); best of {rounds} rounds \
             taking turns.\n",
            mesh.triangle_count()
        );
        println!("{}", raybatch_peers::build_race::build_race(&mesh, rounds)?);
        return Ok(());
    }
    if let Some(rounds) = args.shape_race {
        let count = args.rays.min(200_000);
        println!(
            "# Shape queries against parry3d\n\nMesh `{name}` ({} triangles); one query at a \
             time, one thread; best of {rounds} rounds taking turns.\n",
            mesh.triangle_count()
        );
        let table = raybatch_peers::shape_race::shape_race(&mesh, count, rounds, args.seed)?;
        println!("{table}");
        return Ok(());
    }
    let device = embree_ffi::Device::new("threads=1")?;
    eprintln!(
        "Embree {} ({} tasking), {} triangles",
        device.version_string(),
        device.tasking_system(),
        mesh.triangle_count()
    );

    println!("# raybatch vs peers\n");
    println!(
        "Mesh `{}` ({} triangles, {} vertices); {} rays per set, seed {}; best of {}; \
         build and query single-threaded; Embree {} ({} tasking).\n",
        name,
        mesh.triangle_count(),
        mesh.vertices().len(),
        args.rays,
        args.seed,
        match args.race {
            Some(rounds) => format!("{rounds} rounds taking turns"),
            None => format!("{} runs", args.runs),
        },
        device.version_string(),
        device.tasking_system(),
    );

    for set in rays::ray_sets((&mesh, scene), &args.sets, args.rays, args.seed) {
        eprintln!("ray set {}: {} rays", set.name(), set.rays.len());
        if let Some(rounds) = args.race {
            println!("## {} rays ({})\n", set.name(), set.description);
            for (query, placings) in race::race(&device, &mesh, &set.rays, rounds, set.any_hit)? {
                println!("{}", race::table(query, &placings));
            }
            continue;
        }
        let runs = run_all(&device, &mesh, &set.rays, args.runs, set.any_hit)?;
        print_table(&set, &runs);
        if set.any_hit {
            print_any_hit_table(&runs);
        }
    }
    if args.race.is_some() {
        println!(
            "Answers differing: rays whose hit/miss (closest hit) or occlusion (any hit) \
             differs from the first row's. Speed = the first row's best pass over the row's."
        );
        return Ok(());
    }
    println!(
        "Disagreements are against `{}` (`cast_ray`, watertight kernel): \
         hit/miss = one hits and the other misses (peer misses / peer extra hits); \
         t = both hit but |dt| > {T_TOLERANCE:e} * max(1, t); triangle = same t but another \
         triangle (a tie on a shared edge or vertex; each library breaks ties its own way). \
         Speed vs Embree = Mrays/s over Embree rtcIntersect1's (> 1 is faster).",
        engines::raybatch_engine(AccelKind::DEFAULT)
    );
    Ok(())
}

/// Every library on one ray set; the reference (raybatch's default structure, per ray) first,
/// then raybatch's other structures per ray, then every structure batched, then the peers.
fn run_all(
    device: &embree_ffi::Device,
    mesh: &Arc<Mesh>,
    rays: &[Ray],
    runs: usize,
    any_hit: bool,
) -> Result<Vec<Run>, String> {
    let reference = AccelKind::DEFAULT;
    let others = AccelKind::ALL.into_iter().filter(|&k| k != reference);
    let mut out = Vec::new();
    for kind in std::iter::once(reference).chain(others) {
        out.push(engines::raybatch(kind, mesh, rays, runs, any_hit)?);
    }
    for kind in AccelKind::ALL {
        out.push(engines::raybatch_batched(
            kind,
            mesh,
            rays,
            (runs, None),
            any_hit,
        )?);
    }
    // The default structure in calls of a game frame's size, like for like with the peers.
    let frame = (runs, Some(engines::FRAME_CALL));
    out.push(engines::raybatch_batched(
        reference, mesh, rays, frame, any_hit,
    )?);
    out.extend(engines::embree(device, mesh, rays, runs, any_hit, false)?);
    out.extend(engines::embree(device, mesh, rays, runs, any_hit, true)?);
    out.push(engines::obvhs_cwbvh(mesh, rays, runs, any_hit));
    out.push(engines::obvhs_bvh2(mesh, rays, runs, any_hit));
    out.push(engines::parry(mesh, rays, runs, any_hit)?);
    #[cfg(target_feature = "avx2")]
    out.extend(engines::tinybvh_bvh8(mesh, rays, runs));
    Ok(out)
}

/// Table rows in print order: Embree first, then raybatch, then the other peers.
fn print_order(runs: &[Run]) -> Vec<&Run> {
    let rank = |r: &Run| match r.engine.as_str() {
        e if e.starts_with("Embree") => 0,
        e if e.starts_with("raybatch") => 1,
        _ => 2,
    };
    let mut rows: Vec<&Run> = runs.iter().collect();
    rows.sort_by_key(|r| rank(r));
    rows
}

fn print_table(set: &rays::RaySet, runs: &[Run]) {
    let reference = &runs[0];
    let embree = runs
        .iter()
        .find(|r| r.engine == "Embree rtcIntersect1")
        .map(Run::mrays_per_s);
    println!("## Ray set `{}`: {}\n", set.name(), set.description);
    println!("Closest hit:\n");
    println!(
        "| engine | build (ms) | query (ms) | Mrays/s | speed vs Embree | hits | \
         hit/miss (peer misses / extra) | t | triangle (same t) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for run in print_order(runs) {
        let agreement = if std::ptr::eq(run, reference) {
            None
        } else {
            let mut examples = Vec::new();
            let a = compare(&reference.hits, &run.hits, &mut examples, 3);
            report_examples(run, reference, &set.rays, &examples);
            Some(a)
        };
        let ratio = embree.map_or("-".into(), |e| format!("{:.2}", run.mrays_per_s() / e));
        let hits = run.hits.iter().filter(|h| h.is_some()).count();
        let (hit_miss, t, tri) = match agreement {
            None => ("reference".to_string(), "-".to_string(), "-".to_string()),
            Some(a) => (
                format!(
                    "{} ({} / {})",
                    a.hit_miss(),
                    a.peer_misses,
                    a.peer_extra_hits
                ),
                a.t_differs.to_string(),
                a.triangle_differs.to_string(),
            ),
        };
        println!(
            "| {} | {:.1} | {:.1} | {:.2} | {} | {} | {} | {} | {} |",
            run.engine,
            run.build.as_secs_f64() * 1e3,
            run.query.as_secs_f64() * 1e3,
            run.mrays_per_s(),
            ratio,
            hits,
            hit_miss,
            t,
            tri
        );
    }
    println!("\nStructures and settings:\n");
    for run in print_order(runs) {
        println!("- {}: {}", run.engine, run.structure);
    }
    println!();
}

/// Occlusion queries on the same structures, checked against raybatch's `occluded` and against
/// each library's own closest hit (occluded must equal "the closest hit exists").
fn print_any_hit_table(runs: &[Run]) {
    let Some(reference) = runs[0].any_hit.as_ref() else {
        return;
    };
    let embree = runs
        .iter()
        .find(|r| r.engine == "Embree rtcIntersect1")
        .and_then(|r| r.any_hit.as_ref())
        .map(engines::AnyHit::mrays_per_s);
    println!("Any hit (occlusion) on the same structures and rays:\n");
    println!(
        "| engine | call | query (ms) | Mrays/s | speed vs Embree | occluded | \
         differs from raybatch occluded | differs from own closest hit |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    for run in print_order(runs) {
        let Some(a) = run.any_hit.as_ref() else {
            continue;
        };
        let vs_reference = if std::ptr::eq(a, reference) {
            "reference".to_string()
        } else {
            let n = a
                .occluded
                .iter()
                .zip(&reference.occluded)
                .filter(|(x, y)| x != y)
                .count();
            n.to_string()
        };
        let vs_own = a
            .occluded
            .iter()
            .zip(&run.hits)
            .filter(|(o, h)| **o != h.is_some())
            .count();
        let ratio = embree.map_or("-".into(), |e| format!("{:.2}", a.mrays_per_s() / e));
        let engine = run.engine.replace(" rtcIntersect1", "");
        println!(
            "| {} | {} | {:.1} | {:.2} | {} | {} | {} | {} |",
            engine,
            a.call,
            a.query.as_secs_f64() * 1e3,
            a.mrays_per_s(),
            ratio,
            a.occluded.iter().filter(|&&o| o).count(),
            vs_reference,
            vs_own
        );
    }
    println!();
}

/// The first few disagreements, on stderr, to see what kind they are.
fn report_examples(run: &Run, reference: &Run, rays: &[Ray], examples: &[usize]) {
    for &i in examples {
        let r = &rays[i];
        eprintln!(
            "  {} vs {}: ray {i} (origin {:?}, dir {:?}): {:?} vs {:?}",
            run.engine, reference.engine, r.origin, r.dir, run.hits[i], reference.hits[i]
        );
    }
}
