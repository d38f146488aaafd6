//! `raybatch rays`: writes one of the benchmark ray sets, aimed at a mesh, as a ray file, so
//! that `raybatch query` (and other libraries) can be measured again on exactly these rays.

use raybatch_tools::formats::write_rays;
use raybatch_tools::scenes::{SceneKind, generate};

use crate::args::RaysArgs;
use crate::error::CliError;
use crate::inputs::load_mesh;
use crate::output::Output;

/// Runs the command.
pub fn run(args: &RaysArgs) -> Result<(), CliError> {
    let output = Output::plan(&args.out, &[&args.mesh])?;
    let mesh = load_mesh(&args.mesh)?;
    let rays = generate(args.set, &mesh, SceneKind::Object, args.count, args.seed);
    output.write(|out| write_rays(out, &rays))
}
