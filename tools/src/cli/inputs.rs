//! Reading the user's files, with errors worded for the command line.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use raybatch::{AccelKind, AnyAccel, Mesh, MeshError, Ray};
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
    with_faces(mesh, path)
}

/// What `--mesh` names: an OBJ file, or a cooked structure (`raybatch cook`), which brings
/// its own tree.
pub enum MeshFile {
    Obj(Mesh),
    /// The structure and the milliseconds its loading took (the file already read).
    Cooked(Box<AnyAccel>, f64),
}

/// Reads `path` as a cooked structure if it starts as one, else as an OBJ file ([`load_mesh`]).
pub fn read_mesh_file(path: &Path) -> Result<MeshFile, CliError> {
    let bytes = std::fs::read(path)
        .map_err(|e| CliError::input(format!("cannot read {}: {e}", path.display())))?;
    let named = |e: &dyn std::fmt::Display| CliError::input(format!("{}: {e}", path.display()));
    if raybatch::cook::is_cooked(&bytes) {
        let (tree, ms) = crate::measure::time_ms(|| AnyAccel::from_cooked(&bytes));
        return Ok(MeshFile::Cooked(Box::new(tree.map_err(|e| named(&e))?), ms));
    }
    let mesh = Mesh::from_obj_bytes(&bytes).map_err(|e| named(&e))?;
    Ok(MeshFile::Obj(with_faces(mesh, path)?))
}

/// Fails if a cooked structure of kind `cooked` is asked to be a `tree` of another kind.
pub fn check_cooked_kind(
    path: &Path,
    cooked: AccelKind,
    tree: Option<AccelKind>,
) -> Result<(), CliError> {
    match tree {
        Some(tree) if tree != cooked => Err(CliError::usage(format!(
            "{} holds a cooked {} tree, not {}: drop --tree or cook it again",
            path.display(),
            cooked.name(),
            tree.name()
        ))),
        _ => Ok(()),
    }
}

/// `mesh`, unless it has no face.
fn with_faces(mesh: Mesh, path: &Path) -> Result<Mesh, CliError> {
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
