//! `raybatch cook`: builds a tree over an OBJ mesh (or a built-in scene's) and writes it, with the mesh, to a cooked
//! file (see `raybatch::cook`), which `query`, `render` and `AnyAccel::load` read without a
//! build. Then it loads the bytes it wrote back `--loads` times and reports, as one JSON line on
//! stderr, the build, the save (encoding) and the fastest load, each in milliseconds, and the
//! file's size: the load is the time a game pays at start-up in place of the build, the file
//! already in memory.

use std::path::{Path, PathBuf};

use raybatch::{AccelKind, AnyAccel, Footprint};

use crate::args::CookArgs;
use crate::error::CliError;
use crate::inputs::load_mesh;
use crate::json::JsonLine;
use crate::measure::time_ms;
use crate::output::Output;
use crate::progress;

/// Runs the command.
pub fn run(args: &CookArgs) -> Result<(), CliError> {
    let inputs: Vec<&Path> = args.mesh.iter().map(PathBuf::as_path).collect();
    let output = Output::plan(&args.out, &inputs)?;
    let (mesh, name) = match (&args.mesh, &args.scene) {
        (Some(path), _) => {
            progress::step(format!("loading {}", path.display()));
            (load_mesh(path)?, path.display().to_string())
        }
        (None, scene) => {
            let name = scene.as_deref().expect("clap asks for --mesh or --scene");
            progress::step(format!("making {name}"));
            let scene = raybatch_tools::scenes::named(name).expect("clap passes known names");
            (scene.mesh, name.to_string())
        }
    };
    let kind = args
        .build
        .tree
        .unwrap_or_else(|| AccelKind::for_mesh(&mesh));
    progress::step(format!("building {}", kind.name()));
    let named = |e: &dyn std::fmt::Display| CliError::input(format!("{name}: {e}"));
    let (tree, build_ms) = time_ms(|| kind.build(mesh, &args.build.options()));
    let tree = tree.map_err(|e| named(&e))?;
    progress::step("cooking");
    let (bytes, save_ms) = time_ms(|| tree.to_cooked());
    let bytes = bytes.map_err(|e| named(&e))?;
    progress::step("loading it back");
    let load_ms = fastest_load(&bytes, args.loads)?;
    progress::step("writing the file");
    output.write(|out| out.write_all(&bytes))?;
    progress::done();
    let line = JsonLine::default()
        .int("triangles", tree.triangle_count())
        .str("tree", kind.name())
        .num("build_ms", build_ms)
        .num("save_ms", save_ms)
        .num("load_ms", load_ms)
        .num("build_over_load", build_ms / load_ms)
        .int("file_bytes", bytes.len())
        .int("tree_bytes", tree.heap_bytes());
    eprintln!("{}", line.render());
    Ok(())
}

/// The fastest of `loads` loads of `bytes`, in milliseconds, after checking that a loaded
/// tree cooks to the same bytes (the same mesh, shape and leaves).
pub fn fastest_load(bytes: &[u8], loads: usize) -> Result<f64, CliError> {
    let load = || AnyAccel::from_cooked(bytes).map_err(|e| CliError::input(e.to_string()));
    let again = load()?
        .to_cooked()
        .map_err(|e| CliError::input(e.to_string()))?;
    if again != bytes {
        return Err(CliError::input(
            "the loaded tree differs from the cooked one",
        ));
    }
    let mut fastest = f64::INFINITY;
    for _ in 0..loads {
        let (loaded, ms) = time_ms(load);
        loaded?;
        fastest = fastest.min(ms);
    }
    Ok(fastest)
}
