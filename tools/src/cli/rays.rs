//! `raybatch rays`: writes one of the benchmark ray sets, aimed at a mesh, as a ray file, so
//! that `raybatch query` (and other libraries) can be measured again on exactly these rays.

use raybatch_tools::scenes::{SceneKind, generate};

use crate::args::RaysArgs;
use crate::atomic::write_atomically;
use crate::error::CliError;
use crate::formats::encode_rays;
use crate::inputs::load_mesh;

/// Runs the command.
pub fn run(args: &RaysArgs) -> Result<(), CliError> {
    let mesh = load_mesh(&args.mesh)?;
    let rays = generate(args.set, &mesh, SceneKind::Object, args.count, args.seed);
    write_atomically(&args.out, &encode_rays(&rays))
        .map_err(|e| CliError::input(format!("cannot write {}: {e}", args.out.display())))
}
