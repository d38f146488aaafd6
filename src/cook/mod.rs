//! Cooked structures: a tree or a scene saved to a file once (offline, when a level is cooked)
//! and loaded at run time without a build.
//!
//! **What a file holds.** A 32-byte header, then the payload:
//!
//! ```text
//! 0   magic          8 bytes, "RAYBATCH"
//! 8   format version u32 (FORMAT_VERSION)
//! 12  content        u32: the structure's kind number, or SCENE for a scene
//! 16  payload bytes  u64
//! 24  CRC-32         u32, of the payload (IEEE, as zlib's)
//! 28  zero           u32
//! ```
//! Every number is little-endian. A structure's payload is its mesh (vertices, then vertex
//! indices) and its body; a scene's is its meshes' structures (kind, mesh, body each), then its
//! instances. The mesh travels with its tree.
//!
//! **What a body holds, and why no boxes.** A tree's body is its shape only: the build's
//! options, each node's children and the triangles of each leaf (the slot order). Loading
//! checks that shape (every node reached once, every triangle that is not degenerate in
//! exactly one leaf, no path deeper than the walks' stacks take) and recomputes every box from
//! the mesh, then makes the nodes as the build does. So a file that passes the checksum but
//! was made by hand cannot give a tree that answers wrongly or walks out of its arrays: its
//! boxes are exact by construction. The boxes are a pass over the triangles, a small part of a
//! build (the SAH search and the partitions are the rest): docs/benchmarks.md has the figures.
//!
//! **Which kinds.** The binary trees and the four wide trees (every kind
//! [`crate::AccelKind::for_mesh`] and [`crate::Scene::kind_for`] pick) cook; the zero-byte
//! trees, the grids and the kd-tree do not yet ([`CookError::Unsupported`]).
//!
//! A loaded structure answers every query bit for bit as the one that was saved.

mod bytes;
mod check;
mod scene;

use std::path::Path;
use std::sync::Arc;

pub(crate) use bytes::{Reader, Writer};
pub(crate) use check::{
    DEGENERATE_IN_LEAF, Depths, NodeRefs, SlotCover, check_slot_order, slots_box,
};

use crate::catalog::{AccelKind, AnyAccel};
use crate::mesh::{Mesh, MeshError};
use crate::scene::SceneError;

/// The first eight bytes of every cooked file.
const MAGIC: [u8; 8] = *b"RAYBATCH";
/// The format this library writes, and the newest it reads.
pub const FORMAT_VERSION: u32 = 1;
/// The header's content number of a scene (structures use their kind's number, below 256).
const SCENE: u32 = 0x100;
/// Header bytes.
const HEADER_BYTES: usize = 32;

/// Why a cooked file could not be written or read.
#[derive(Debug)]
pub enum CookError {
    /// The file could not be read or written.
    Io(std::io::Error),
    /// The bytes are not a cooked file (too short for a header, or another magic number).
    NotCooked,
    /// The file was written by a newer format than this library reads.
    NewerVersion {
        /// The file's format version.
        found: u32,
        /// The newest version this library reads ([`FORMAT_VERSION`]).
        supported: u32,
    },
    /// The file is shorter than its header says.
    Truncated {
        /// Payload bytes the header announces.
        expected: u64,
        /// Payload bytes present.
        found: u64,
    },
    /// The payload's CRC-32 differs from the header's: the file was damaged.
    Checksum {
        /// The header's.
        stored: u32,
        /// The payload's.
        computed: u32,
    },
    /// The file holds a scene where a structure was asked for, or the other way round.
    WrongContent {
        /// What was asked for.
        expected: &'static str,
        /// What the file holds.
        found: &'static str,
    },
    /// The file names a structure kind this library does not know.
    UnknownKind(u32),
    /// The structure kind cannot be cooked (yet).
    Unsupported(AccelKind),
    /// The file's mesh is invalid.
    Mesh(MeshError),
    /// The file's scene is invalid (an instance of a missing mesh, a bad transform).
    Scene(SceneError),
    /// The payload passed its checksum but does not describe a valid structure (what is wrong).
    Corrupt(&'static str),
    /// An array is longer than a file can number (`u32::MAX` items).
    TooLarge {
        /// Its length.
        count: usize,
    },
}

impl std::fmt::Display for CookError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CookError::Io(e) => write!(f, "cooked file: {e}"),
            CookError::NotCooked => write!(f, "not a cooked raybatch file"),
            CookError::NewerVersion { found, supported } => write!(
                f,
                "cooked file of format {found}; this library reads up to format {supported}"
            ),
            CookError::Truncated { expected, found } => write!(
                f,
                "cooked file truncated: {found} of {expected} payload bytes"
            ),
            CookError::Checksum { stored, computed } => write!(
                f,
                "cooked file damaged: CRC-32 {computed:08x}, header says {stored:08x}"
            ),
            CookError::WrongContent { expected, found } => {
                write!(f, "cooked file holds a {found}, not a {expected}")
            }
            CookError::UnknownKind(code) => write!(f, "cooked file of unknown kind {code}"),
            CookError::Unsupported(kind) => {
                write!(f, "{} structures cannot be cooked", kind.name())
            }
            CookError::Mesh(e) => write!(f, "cooked file's mesh: {e}"),
            CookError::Scene(e) => write!(f, "cooked file's scene: {e}"),
            CookError::Corrupt(what) => write!(f, "cooked file corrupt: {what}"),
            CookError::TooLarge { count } => {
                write!(f, "{count} items are more than a cooked file numbers")
            }
        }
    }
}

impl std::error::Error for CookError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CookError::Io(e) => Some(e),
            CookError::Mesh(e) => Some(e),
            CookError::Scene(e) => Some(e),
            _ => None,
        }
    }
}

impl From<std::io::Error> for CookError {
    fn from(e: std::io::Error) -> Self {
        CookError::Io(e)
    }
}

/// Whether `bytes` start as a cooked file does (its magic number): a file to read with
/// [`AnyAccel::from_cooked`] or [`crate::Scene::from_cooked`] rather than as a mesh.
pub fn is_cooked(bytes: &[u8]) -> bool {
    bytes.starts_with(&MAGIC)
}

/// What a structure writes after its mesh, and reads back over it. The kinds that do not
/// cook keep the defaults, which refuse.
pub(crate) trait Cook: Sized {
    /// Whether the structure cooks (checked before anything is written).
    const COOKS: bool = false;

    /// Writes the body (the mesh is written before it by the caller).
    fn write_body(&self, kind: AccelKind, _out: &mut Writer) -> Result<(), CookError> {
        Err(CookError::Unsupported(kind))
    }

    /// The mesh whose triangle ids the structure answers in, if it keeps it in that order
    /// (the zero-byte trees keep theirs reordered).
    fn own_mesh(&self) -> Option<&Mesh> {
        None
    }

    /// Writes the mesh and the body.
    fn write(&self, kind: AccelKind, out: &mut Writer) -> Result<(), CookError> {
        let mesh = self.own_mesh().filter(|_| Self::COOKS);
        write_mesh(out, mesh.ok_or(CookError::Unsupported(kind))?)?;
        self.write_body(kind, out)
    }

    /// Reads a body written by [`Cook::write_body`] over `mesh`, checking it (see the module
    /// docs).
    fn read_body(kind: AccelKind, _mesh: Arc<Mesh>, _body: &mut Reader) -> Result<Self, CookError> {
        Err(CookError::Unsupported(kind))
    }
}

impl Cook for crate::permuted::Permuted<crate::zbt::ZeroByteTree> {}
impl Cook for crate::permuted::Permuted<crate::zbt::HybridTree> {}
impl Cook for crate::grid::UniformGrid {
    fn own_mesh(&self) -> Option<&Mesh> {
        Some(self.mesh())
    }
}
impl Cook for crate::grid::SpatialHash {
    fn own_mesh(&self) -> Option<&Mesh> {
        Some(self.mesh())
    }
}
impl Cook for crate::kdtree::KdTree {
    fn own_mesh(&self) -> Option<&Mesh> {
        Some(self.mesh())
    }
}

fn write_mesh(out: &mut Writer, mesh: &Mesh) -> Result<(), CookError> {
    out.points(mesh.vertices())?;
    out.u32s(mesh.triangles().as_flattened())
}

fn read_mesh(body: &mut Reader) -> Result<Mesh, CookError> {
    let vertices = body.points()?;
    let indices = body.u32s()?;
    if indices.len() % 3 != 0 {
        return Err(CookError::Corrupt("vertex indices not in threes"));
    }
    let triangles = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    Mesh::new(vertices, triangles).map_err(CookError::Mesh)
}

/// Writes `structure` (its kind, mesh and body) into a payload.
fn write_structure(out: &mut Writer, structure: &AnyAccel) -> Result<(), CookError> {
    out.u32(structure.kind().code());
    structure.write_cooked(out)
}

/// Reads a structure written by [`write_structure`].
fn read_structure(body: &mut Reader) -> Result<AnyAccel, CookError> {
    let code = body.u32()?;
    read_mesh_and_body(code, body)
}

/// Reads the mesh and the body of a structure of kind number `code`.
fn read_mesh_and_body(code: u32, body: &mut Reader) -> Result<AnyAccel, CookError> {
    let kind = AccelKind::from_code(code).ok_or(CookError::UnknownKind(code))?;
    let mesh = Arc::new(read_mesh(body)?);
    AnyAccel::read_cooked(kind, mesh, body)
}

/// The file of `payload`, whose header says `content`.
fn file(content: u32, payload: Vec<u8>) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES + payload.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&content.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&payload);
    out
}

/// The content number and the checked payload of the file `bytes`.
fn payload(bytes: &[u8]) -> Result<(u32, &[u8]), CookError> {
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    if bytes.len() < HEADER_BYTES || bytes[..8] != MAGIC {
        return Err(CookError::NotCooked);
    }
    let version = word(8);
    if version > FORMAT_VERSION {
        return Err(CookError::NewerVersion {
            found: version,
            supported: FORMAT_VERSION,
        });
    }
    if version == 0 || word(28) != 0 {
        return Err(CookError::Corrupt("header"));
    }
    let expected = u64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes"));
    let payload = &bytes[HEADER_BYTES..];
    let found = payload.len() as u64;
    if found < expected {
        return Err(CookError::Truncated { expected, found });
    }
    if found > expected {
        return Err(CookError::Corrupt("bytes after the payload"));
    }
    let (stored, computed) = (word(24), crc32fast::hash(payload));
    if stored != computed {
        return Err(CookError::Checksum { stored, computed });
    }
    Ok((word(12), payload))
}

impl AnyAccel {
    /// The structure as a cooked file's bytes (see [`crate::cook`]): its kind, mesh and tree.
    /// [`CookError::Unsupported`] for the kinds that do not cook.
    pub fn to_cooked(&self) -> Result<Vec<u8>, CookError> {
        let mut out = Writer::default();
        self.write_cooked(&mut out)?;
        Ok(file(self.kind().code(), out.into_bytes()))
    }

    /// The structure of a cooked file's bytes, answering bit for bit as the one saved. A
    /// truncated, damaged, foreign or newer file, or one whose structure does not check, is
    /// a [`CookError`].
    pub fn from_cooked(bytes: &[u8]) -> Result<Self, CookError> {
        let (content, payload) = payload(bytes)?;
        if content == SCENE {
            return Err(CookError::WrongContent {
                expected: "structure",
                found: "scene",
            });
        }
        let mut body = Reader::new(payload);
        let structure = read_mesh_and_body(content, &mut body)?;
        body.finish()?;
        Ok(structure)
    }

    /// Writes [`AnyAccel::to_cooked`] to `path`.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), CookError> {
        Ok(std::fs::write(path, self.to_cooked()?)?)
    }

    /// Reads the structure cooked in `path` ([`AnyAccel::from_cooked`]).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, CookError> {
        Self::from_cooked(&std::fs::read(path)?)
    }
}

#[cfg(test)]
mod tests;
