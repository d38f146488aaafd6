//! Reading the user's files, with errors worded for the command line.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use raybatch::{Mesh, MeshError, Ray};
use raybatch_tools::formats::read_rays as read_ray_file;

use crate::error::CliError;

/// Loads an OBJ file; the message names the file and, for a parse error, the line. A file
/// without faces is an error: nothing could be hit, and it is most likely not an OBJ file at
/// all (an STL, a PLY or a README parse as OBJ files whose every line is ignored).
pub fn load_mesh(path: &Path) -> Result<Mesh, CliError> {
    let mesh = Mesh::load_obj(path).map_err(|e| match e {
        // Already "cannot read PATH: reason".
        MeshError::Io { .. } => CliError::input(e.to_string()),
        _ => CliError::input(format!("{}: {e}", path.display())),
    })?;
    if mesh.triangle_count() == 0 {
        return Err(CliError::input(format!(
            "{}: no faces found (is this an OBJ file?)",
            path.display()
        )));
    }
    Ok(mesh)
}

/// Reads a ray file (see [`raybatch_tools::formats`]), streaming it into the rays.
pub fn read_rays(path: &Path) -> Result<Vec<Ray>, CliError> {
    let cannot =
        |e: &dyn std::fmt::Display| CliError::input(format!("cannot read {}: {e}", path.display()));
    let file = File::open(path).map_err(|e| cannot(&e))?;
    let len = file.metadata().map_err(|e| cannot(&e))?.len();
    read_ray_file(BufReader::new(file), Some(len)).map_err(|e| cannot(&e))
}
