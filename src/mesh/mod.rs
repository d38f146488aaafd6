//! The indexed triangle mesh every structure is built from, validated once at construction.
//!
//! A [`Mesh`] is a vertex array and a triangle array of vertex indices. Triangle ids are the
//! positions in the triangle array; every query reports hits by that id (per-triangle user data
//! such as materials stays with the user, addressed by id). Construction checks everything a
//! query will later rely on and returns a typed [`MeshError`] instead of panicking: indices in
//! range, finite coordinates of bounded magnitude, and counts that fit 32-bit ids.
//!
//! Empty meshes are valid (every query misses). Degenerate triangles (repeated indices or zero
//! area) are valid too: they keep their id but are never hit.

pub mod obj;
pub mod quantized;

use glam::Vec3;
use std::path::Path;

use crate::geom::{Aabb, is_degenerate};
use obj::{ObjError, parse_obj};

/// Largest accepted coordinate magnitude, `2^40` (about `1.1e12`). Bounding coordinates keeps
/// every intermediate product of the triangle kernels finite in `f32`.
pub const MAX_COORDINATE: f32 = (1u64 << 40) as f32;

/// Largest number of triangles a mesh may hold: ids are `u32` and `u32::MAX` marks a miss.
pub const MAX_TRIANGLES: usize = u32::MAX as usize - 1;

/// An indexed triangle mesh: `vertices` and `triangles` (three vertex indices each).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

/// Why a mesh was rejected.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshError {
    /// A triangle refers to a vertex that does not exist.
    IndexOutOfRange {
        /// The triangle's id.
        triangle: usize,
        /// The vertex index it holds.
        index: u32,
        /// Vertices in the mesh.
        vertex_count: usize,
    },
    /// A vertex has a NaN or infinite coordinate.
    NonFiniteVertex {
        /// The vertex's index.
        vertex: usize,
    },
    /// A vertex coordinate exceeds [`MAX_COORDINATE`] in magnitude.
    CoordinateTooLarge {
        /// The vertex's index.
        vertex: usize,
    },
    /// More triangles than [`MAX_TRIANGLES`].
    TooManyTriangles {
        /// Triangles given.
        count: usize,
        /// The most supported.
        max: usize,
    },
    /// More vertices than 32-bit indices can address.
    TooManyVertices {
        /// Vertices given.
        count: usize,
        /// The most supported.
        max: usize,
    },
    /// The OBJ text is malformed (the error names the line).
    Obj(ObjError),
    /// The file could not be read.
    Io {
        /// The file.
        path: String,
        /// What the system said.
        message: String,
    },
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshError::IndexOutOfRange {
                triangle,
                index,
                vertex_count,
            } => write!(
                f,
                "triangle {triangle} uses vertex {index}, but the mesh has {vertex_count} vertices"
            ),
            MeshError::NonFiniteVertex { vertex } => {
                write!(f, "vertex {vertex} has a NaN or infinite coordinate")
            }
            MeshError::CoordinateTooLarge { vertex } => write!(
                f,
                "vertex {vertex} has a coordinate larger than {MAX_COORDINATE:e} in magnitude"
            ),
            MeshError::TooManyTriangles { count, max } => {
                write!(f, "{count} triangles is more than the supported {max}")
            }
            MeshError::TooManyVertices { count, max } => {
                write!(f, "{count} vertices is more than the supported {max}")
            }
            MeshError::Obj(e) => write!(f, "bad OBJ file: {e}"),
            MeshError::Io { path, message } => write!(f, "cannot read {path}: {message}"),
        }
    }
}

impl std::error::Error for MeshError {}

impl From<ObjError> for MeshError {
    fn from(e: ObjError) -> Self {
        MeshError::Obj(e)
    }
}

/// Triangles per run of [`Mesh::bounds`].
const BOUNDS_RUN: usize = 16 * 1024;

impl Mesh {
    /// Validates and wraps the arrays. Nothing is reordered or changed.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        validate_counts(vertices.len(), triangles.len())?;
        validate_vertices(&vertices)?;
        validate_indices(&triangles, vertices.len())?;
        Ok(Self {
            vertices,
            triangles,
        })
    }

    /// Wraps arrays known to be valid (taken from a [`Mesh`] and only reordered), skipping
    /// the checks in release builds.
    pub(crate) fn from_valid_parts(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        debug_assert!(Self::new(vertices.clone(), triangles.clone()).is_ok());
        Self {
            vertices,
            triangles,
        }
    }

    /// Parses OBJ text (see [`obj`]): polygons are fan-triangulated in file order, and
    /// triangle ids follow that order.
    pub fn from_obj_str(text: &str) -> Result<Self, MeshError> {
        let (vertices, triangles) = parse_obj(text)?;
        Self::new(vertices, triangles)
    }

    /// [`Mesh::from_obj_str`] on the file's bytes: comments may hold any bytes, the rest must
    /// be UTF-8 (see [`obj`]).
    pub fn from_obj_bytes(bytes: &[u8]) -> Result<Self, MeshError> {
        let (vertices, triangles) = obj::parse_obj_bytes(bytes)?;
        Self::new(vertices, triangles)
    }

    /// Reads and parses an OBJ file.
    pub fn load_obj(path: impl AsRef<Path>) -> Result<Self, MeshError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| MeshError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_obj_bytes(&bytes)
    }

    /// The vertex positions.
    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }

    /// The triangles, three vertex indices each; a triangle's id is its index here.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Prefetches the vertex indices of triangle `id`: the first link of the chain of
    /// dependent reads (id -> indices -> corners) behind a triangle test.
    #[inline(always)]
    pub(crate) fn prefetch_indices(&self, id: u32) {
        crate::prefetch::prefetch(&self.triangles[id as usize]);
    }

    /// Prefetches the corners at vertex indices `indices` (the chain's second link; reads
    /// the indices, so prefetch them first).
    #[inline(always)]
    pub(crate) fn prefetch_corners(&self, indices: &[u32; 3]) {
        for &i in indices {
            crate::prefetch::prefetch(&self.vertices[i as usize]);
        }
    }

    /// Number of triangles (degenerate ones included).
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// True if the mesh has no triangle.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The three corners of triangle `id`. Panics if `id` is out of range (ids come from this
    /// mesh, so that is a caller bug, not bad data).
    #[inline(always)]
    pub fn triangle(&self, id: u32) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[id as usize];
        [
            self.vertices[a as usize],
            self.vertices[b as usize],
            self.vertices[c as usize],
        ]
    }

    /// True if triangle `id` has repeated indices or zero area: it is never hit.
    pub fn is_degenerate(&self, id: u32) -> bool {
        let [a, b, c] = self.triangles[id as usize];
        a == b || b == c || a == c || is_degenerate(&self.triangle(id))
    }

    /// The box around every vertex used by a triangle (empty for an empty mesh).
    pub fn bounds(&self) -> Aabb {
        // Fixed runs of triangles, on rayon's pool for large meshes, joined in order: the
        // same box whatever the thread count.
        let runs: Vec<&[[u32; 3]]> = self.triangles.chunks(BOUNDS_RUN).collect();
        let box_of = |run: &[[u32; 3]]| {
            run.iter()
                .flatten()
                .fold(Aabb::EMPTY, |b, &i| b.grow(self.vertices[i as usize]))
        };
        let parallel = runs.len() > 4;
        let boxes = crate::parallel::map(parallel, runs, box_of);
        boxes.into_iter().fold(Aabb::EMPTY, Aabb::union)
    }

    /// Bytes held by the vertex and index arrays.
    pub fn heap_bytes(&self) -> usize {
        self.vertices.len() * size_of::<Vec3>() + self.triangles.len() * size_of::<[u32; 3]>()
    }

    /// Gives the arrays back.
    pub fn into_parts(self) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        (self.vertices, self.triangles)
    }
}

fn validate_counts(vertex_count: usize, triangle_count: usize) -> Result<(), MeshError> {
    if triangle_count > MAX_TRIANGLES {
        return Err(MeshError::TooManyTriangles {
            count: triangle_count,
            max: MAX_TRIANGLES,
        });
    }
    let max_vertices = u32::MAX as usize + 1;
    if vertex_count > max_vertices {
        return Err(MeshError::TooManyVertices {
            count: vertex_count,
            max: max_vertices,
        });
    }
    Ok(())
}

fn validate_vertices(vertices: &[Vec3]) -> Result<(), MeshError> {
    for (vertex, v) in vertices.iter().enumerate() {
        if !v.is_finite() {
            return Err(MeshError::NonFiniteVertex { vertex });
        }
        if v.abs().max_element() > MAX_COORDINATE {
            return Err(MeshError::CoordinateTooLarge { vertex });
        }
    }
    Ok(())
}

fn validate_indices(triangles: &[[u32; 3]], vertex_count: usize) -> Result<(), MeshError> {
    for (triangle, tri) in triangles.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertex_count) {
            return Err(MeshError::IndexOutOfRange {
                triangle,
                index,
                vertex_count,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_meshes_with_typed_errors() {
        let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        assert_eq!(
            Mesh::new(v.clone(), vec![[0, 1, 3]]),
            Err(MeshError::IndexOutOfRange {
                triangle: 0,
                index: 3,
                vertex_count: 3
            })
        );
        let mut nan = v.clone();
        nan[1].y = f32::NAN;
        assert_eq!(
            Mesh::new(nan, vec![]),
            Err(MeshError::NonFiniteVertex { vertex: 1 })
        );
        let mut inf = v.clone();
        inf[2].z = f32::NEG_INFINITY;
        assert_eq!(
            Mesh::new(inf, vec![]),
            Err(MeshError::NonFiniteVertex { vertex: 2 })
        );
        let mut huge = v;
        huge[0].x = 1e20;
        assert_eq!(
            Mesh::new(huge, vec![]),
            Err(MeshError::CoordinateTooLarge { vertex: 0 })
        );
    }

    #[test]
    fn empty_and_degenerate_meshes_are_valid() {
        let empty = Mesh::new(vec![], vec![]).unwrap();
        assert!(empty.is_empty());
        assert!(empty.bounds().is_empty());
        let m = Mesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::Y],
            vec![[0, 0, 1], [0, 1, 2], [0, 1, 3]],
        )
        .unwrap();
        assert!(m.is_degenerate(0) && m.is_degenerate(1) && !m.is_degenerate(2));
    }

    #[test]
    fn malformed_obj_is_an_error_naming_the_line() {
        let err = Mesh::from_obj_str("v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap_err();
        match err {
            MeshError::Obj(e) => assert_eq!(e.line, 3),
            other => panic!("unexpected {other:?}"),
        }
        assert!(matches!(
            Mesh::load_obj("/nonexistent/file.obj"),
            Err(MeshError::Io { .. })
        ));
    }
}
