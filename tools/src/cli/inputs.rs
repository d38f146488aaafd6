//! Reading the user's files, with errors worded for the command line.

use std::path::Path;

use raybatch::{Mesh, MeshError, Ray};

use crate::error::CliError;
use crate::formats::decode_rays;

/// Loads an OBJ file; the message names the file and, for a parse error, the line.
pub fn load_mesh(path: &Path) -> Result<Mesh, CliError> {
    Mesh::load_obj(path).map_err(|e| match e {
        // Already "cannot read PATH: reason".
        MeshError::Io { .. } => CliError::input(e.to_string()),
        _ => CliError::input(format!("{}: {e}", path.display())),
    })
}

/// Reads a ray file (see [`crate::formats`]).
pub fn read_rays(path: &Path) -> Result<Vec<Ray>, CliError> {
    let bytes = std::fs::read(path)
        .map_err(|e| CliError::input(format!("cannot read {}: {e}", path.display())))?;
    decode_rays(&bytes).map_err(|e| CliError::input(format!("truncated {}: {e}", path.display())))
}
