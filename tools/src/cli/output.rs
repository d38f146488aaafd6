//! Where a command's output (`--out`) goes, decided before any work, and writing it there.
//!
//! - `-`: stdout.
//! - A path that does not exist, or a regular file: written next to it and renamed over it once
//!   complete, so a failure never leaves a partial (or any new) file behind.
//! - A symbolic link: followed; its target gets the same treatment and the link stays a link.
//!   A link to nothing is refused.
//! - A device, FIFO or socket (`/dev/null`, a named pipe): written straight into, since it
//!   cannot be replaced by a rename (which would put a regular file in its place) and writing
//!   into it is what the user asked.
//! - A directory: refused.
//! - The same file as an input, by any path (a symbolic or hard link: the device and inode
//!   are compared): refused, since writing it would destroy the input.

use std::ffi::OsString;
use std::fs::{self, File, Metadata, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::CliError;

/// Where the output goes (see the module docs).
enum Target {
    Stdout,
    /// A regular file (or none yet) at this path, links resolved: replaced by a rename.
    Replace(PathBuf),
    /// A device, FIFO or socket at this path: written into.
    Stream(PathBuf),
}

/// A checked `--out`.
pub struct Output {
    target: Target,
    /// The path as the user gave it, for messages.
    shown: PathBuf,
}

impl Output {
    /// Checks `path`, the value of `--out`, against the command's `inputs`, before any work.
    pub fn plan(path: &Path, inputs: &[&Path]) -> Result<Self, CliError> {
        let shown = path.to_path_buf();
        if path.as_os_str() == "-" {
            return Ok(Self {
                target: Target::Stdout,
                shown,
            });
        }
        let refuse = |why: String| CliError::usage(format!("--out {}: {why}", path.display()));
        let link = fs::symlink_metadata(path).ok();
        let is_link = link.as_ref().is_some_and(|m| m.file_type().is_symlink());
        let (resolved, existing) = if is_link {
            let target = fs::canonicalize(path)
                .map_err(|_| refuse("a symbolic link to nothing; refusing to follow it".into()))?;
            let metadata = fs::metadata(&target).ok();
            (target, metadata)
        } else {
            (path.to_path_buf(), link)
        };
        for input in inputs {
            if same_file(existing.as_ref(), &resolved, input) {
                return Err(refuse(format!(
                    "the same file as the input {}; refusing to overwrite it",
                    input.display()
                )));
            }
        }
        let target = match existing {
            Some(m) if m.is_dir() => return Err(refuse("a directory".into())),
            Some(m) if !m.is_file() => Target::Stream(resolved),
            _ => {
                check_directory(&resolved).map_err(refuse)?;
                Target::Replace(resolved)
            }
        };
        Ok(Self { target, shown })
    }

    /// Writes the output with `fill`, all or nothing where the target allows it.
    pub fn write(
        &self,
        fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
    ) -> Result<(), CliError> {
        let result = match &self.target {
            Target::Stdout => {
                let mut out = BufWriter::new(io::stdout().lock());
                fill(&mut out).and_then(|()| out.flush())
            }
            Target::Replace(path) => write_atomically(path, fill),
            Target::Stream(path) => OpenOptions::new().write(true).open(path).and_then(|file| {
                let mut out = BufWriter::new(file);
                fill(&mut out).and_then(|()| out.flush())
            }),
        };
        result.map_err(|e| CliError::input(format!("cannot write {}: {e}", self.shown.display())))
    }
}

/// Whether `input` is the existing output file `output` (at `path`).
fn same_file(output: Option<&Metadata>, path: &Path, input: &Path) -> bool {
    let (Some(output), Ok(input_meta)) = (output, fs::metadata(input)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let _ = path;
        output.dev() == input_meta.dev() && output.ino() == input_meta.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (output, input_meta);
        fs::canonicalize(input).ok() == fs::canonicalize(path).ok()
    }
}

/// Fails unless `path` names a file in an existing directory.
fn check_directory(path: &Path) -> Result<(), String> {
    if path.file_name().is_none() {
        return Err("does not name a file".into());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(format!("{} is not a directory", dir.display()));
    }
    Ok(())
}

/// Writes through a temporary file in the same directory, renamed over `path` once complete.
fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let temp = temp_path(path)?;
    let result = write_synced(&temp, fill).and_then(|()| fs::rename(&temp, path));
    if result.is_err() {
        // Best effort: the temporary file may not even exist.
        let _ = fs::remove_file(&temp);
    }
    result
}

/// `dir/.name.PID.tmp` for `dir/name`.
fn temp_path(path: &Path) -> io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(io::ErrorKind::InvalidInput, "the path does not name a file")
    })?;
    let mut temp = OsString::from(".");
    temp.push(name);
    temp.push(format!(".{}.tmp", std::process::id()));
    Ok(path.with_file_name(temp))
}

fn write_synced(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    let mut out = BufWriter::new(File::create(path)?);
    fill(&mut out)?;
    out.into_inner().map_err(|e| e.into_error())?.sync_all()
}
