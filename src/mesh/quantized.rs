//! Quantized vertices: a mesh whose positions are stored as small integers on a per-mesh grid
//! and decoded on the fly, trading position accuracy for vertex memory.
//!
//! Each axis has its own grid: `position = origin + q * step`, with `q` an integer of `bits`
//! bits (1 to 16). Storage per vertex: 3 bytes up to 8 bits, 4 bytes (three 10-bit fields in a
//! `u32`) up to 10, 6 bytes up to 16, against 12 for `f32` positions: **16 bits take half the
//! vertex bytes**, 10 bits a third, 8 bits a quarter. The triangles (vertex indices) are
//! unchanged, so triangle ids are the original mesh's.
//!
//! **The guarantee**: every decoded position is within half a grid step of the original, per
//! axis (`|decoded - original| <= step / 2`, [`VertexGrid::max_error`]). Steps are powers of two
//! and origins multiples of their step, chosen so that `q * step` and `origin + q * step` are
//! exact in `f32` (no rounding in the decode, which is what makes the bound exact rather than
//! "half a step plus some ulps"); the price is a step up to twice the finest one `bits`
//! allow over the mesh's extent, and at least about 2^-22 of the largest coordinate (finer
//! would be below `f32`'s own spacing there).
//!
//! **What answers mean**: the quantized mesh *is* a mesh, the one [`QuantizedMesh::dequantize`]
//! returns; a structure over it (the crate's
//! [`QuantizedVertexTree`](crate::bvh::QuantizedVertexTree)) answers exactly for that mesh, with
//! every property of the crate (watertight, tie rule, batched == per ray). The difference from
//! the original mesh is the position error above, nothing else.

use glam::{DVec3, Vec3};

use super::Mesh;

/// The per-axis grid of a [`QuantizedMesh`] (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexGrid {
    /// The grid point `q = 0` per axis, a multiple of `step`.
    pub origin: Vec3,
    /// The grid spacing per axis, a power of two.
    pub step: Vec3,
    /// Bits per coordinate, 1 to 16.
    pub bits: u32,
}

impl VertexGrid {
    /// The largest distance, per axis, between a decoded position and the original: half a
    /// step (the guarantee of the module docs).
    pub fn max_error(&self) -> Vec3 {
        self.step * 0.5
    }

    /// The grid for `bits` bits over the vertices of `mesh` (an empty mesh: origin 0, step 1).
    fn fit(mesh: &Mesh, bits: u32) -> Self {
        let levels = ((1u32 << bits) - 1) as f64;
        let (lo, hi) = mesh.vertices().iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(v.as_dvec3()), hi.max(v.as_dvec3())),
        );
        if !lo.is_finite() {
            return Self {
                origin: Vec3::ZERO,
                step: Vec3::ONE,
                bits,
            };
        }
        let axis = |a: usize| {
            // Every q rounds to at most `levels` (see `quantize`): the extent spans at most
            // `levels - 0.5` steps, the origin being up to one step below the lowest vertex.
            let for_extent = (hi[a] - lo[a]) / (levels - 0.5);
            // origin + q * step exact in f32: |origin / step + q| stays below 2^24.
            let for_exactness = lo[a].abs().max(hi[a].abs()) / f64::from(1u32 << 22);
            let step = power_of_two_at_least(for_extent.max(for_exactness));
            ((lo[a] / step).floor() * step, step)
        };
        let [(ox, sx), (oy, sy), (oz, sz)] = [axis(0), axis(1), axis(2)];
        Self {
            origin: DVec3::new(ox, oy, oz).as_vec3(),
            step: DVec3::new(sx, sy, sz).as_vec3(),
            bits,
        }
    }

    /// The grid coordinates of `p`: the nearest grid point per axis.
    fn quantize(&self, p: Vec3) -> [u32; 3] {
        let max = (1u32 << self.bits) - 1;
        std::array::from_fn(|a| {
            let (x, o, s) = (
                f64::from(p[a]),
                f64::from(self.origin[a]),
                f64::from(self.step[a]),
            );
            let q = ((x - o) / s).round().clamp(0.0, f64::from(max)) as u32;
            // The f64 quotient may round a coordinate a hair from a half step to the wrong
            // side: keep whichever neighbour decodes nearer (exactly compared in f64).
            let err = |q: u32| (f64::from(self.decode_axis(a, q)) - x).abs();
            [q.saturating_sub(1), q + 1]
                .into_iter()
                .filter(|&n| n <= max)
                .fold(q, |best, n| if err(n) < err(best) { n } else { best })
        })
    }

    fn decode_axis(&self, axis: usize, q: u32) -> f32 {
        q as f32 * self.step[axis] + self.origin[axis]
    }

    /// The position at grid coordinates `q`. Both operations are exact (see the module docs).
    #[inline(always)]
    pub fn decode(&self, q: [u32; 3]) -> Vec3 {
        Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32) * self.step + self.origin
    }
}

/// The smallest power of two `>= x` (at least the smallest normal `f32`).
fn power_of_two_at_least(x: f64) -> f64 {
    let mut p = f64::from(f32::MIN_POSITIVE);
    while p < x {
        p *= 2.0;
    }
    p
}

/// The grid coordinates of every vertex, in the smallest container for the bit count.
#[derive(Clone, Debug, PartialEq)]
enum Positions {
    /// Up to 8 bits: one byte per coordinate.
    Bytes(Vec<[u8; 3]>),
    /// Up to 10 bits: three 10-bit fields in one `u32` (x in bits 0..10, y 10..20, z 20..30).
    Packed10(Vec<u32>),
    /// Up to 16 bits: one `u16` per coordinate.
    Halves(Vec<[u16; 3]>),
}

impl Positions {
    fn new(bits: u32, coords: impl Iterator<Item = [u32; 3]>) -> Self {
        match bits {
            0..=8 => Self::Bytes(coords.map(|q| q.map(|c| c as u8)).collect()),
            9..=10 => Self::Packed10(coords.map(|[x, y, z]| x | (y << 10) | (z << 20)).collect()),
            _ => Self::Halves(coords.map(|q| q.map(|c| c as u16)).collect()),
        }
    }

    #[inline(always)]
    fn get(&self, index: usize) -> [u32; 3] {
        match self {
            Self::Bytes(v) => v[index].map(u32::from),
            Self::Packed10(v) => {
                let w = v[index];
                [w & 0x3ff, (w >> 10) & 0x3ff, (w >> 20) & 0x3ff]
            }
            Self::Halves(v) => v[index].map(u32::from),
        }
    }

    fn len(&self) -> usize {
        match self {
            Self::Bytes(v) => v.len(),
            Self::Packed10(v) => v.len(),
            Self::Halves(v) => v.len(),
        }
    }

    fn heap_bytes(&self) -> usize {
        match self {
            Self::Bytes(v) => size_of_val(v.as_slice()),
            Self::Packed10(v) => size_of_val(v.as_slice()),
            Self::Halves(v) => size_of_val(v.as_slice()),
        }
    }
}

/// Why a mesh could not be quantized.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum QuantizeError {
    /// Bits per coordinate outside 1..=16.
    BadBits(u32),
}

impl std::fmt::Display for QuantizeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            QuantizeError::BadBits(b) => {
                write!(f, "bits per coordinate must be between 1 and 16, not {b}")
            }
        }
    }
}

impl std::error::Error for QuantizeError {}

/// A mesh with quantized vertex positions (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct QuantizedMesh {
    grid: VertexGrid,
    positions: Positions,
    triangles: Vec<[u32; 3]>,
}

impl QuantizedMesh {
    /// Quantizes `mesh`'s vertices to `bits` bits per coordinate (1 to 16) on a grid fitted to
    /// its vertices; the triangles are kept as they are.
    pub fn new(mesh: &Mesh, bits: u32) -> Result<Self, QuantizeError> {
        if !(1..=16).contains(&bits) {
            return Err(QuantizeError::BadBits(bits));
        }
        let grid = VertexGrid::fit(mesh, bits);
        let coords = mesh.vertices().iter().map(|&v| grid.quantize(v));
        Ok(Self {
            grid,
            positions: Positions::new(bits, coords),
            triangles: mesh.triangles().to_vec(),
        })
    }

    /// The grid (origin, step, bits): [`VertexGrid::max_error`] is the position error bound.
    pub fn grid(&self) -> &VertexGrid {
        &self.grid
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The triangles, as in the original mesh.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Vertex `index`, decoded.
    #[inline(always)]
    pub fn vertex(&self, index: u32) -> Vec3 {
        self.grid.decode(self.positions.get(index as usize))
    }

    /// The decoded corners of triangle `id`.
    #[inline(always)]
    pub fn triangle(&self, id: u32) -> [Vec3; 3] {
        self.triangles[id as usize].map(|i| self.vertex(i))
    }

    /// The mesh this one stands for: every vertex decoded. Queries on a structure over the
    /// quantized mesh answer exactly as they would on this mesh.
    pub fn dequantize(&self) -> Mesh {
        let vertices = (0..self.vertex_count() as u32)
            .map(|i| self.vertex(i))
            .collect();
        // Decoded positions lie within half a step of valid ones, on grid points no farther
        // from zero than the original extreme (a power-of-two multiple of the step): finite
        // and within MAX_COORDINATE; the indices are the validated mesh's.
        Mesh::from_valid_parts(vertices, self.triangles.clone())
    }

    /// Bytes of the quantized positions alone.
    pub fn vertex_bytes(&self) -> usize {
        self.positions.heap_bytes()
    }

    /// Bytes of the positions and the index array.
    pub fn heap_bytes(&self) -> usize {
        self.vertex_bytes() + size_of_val(self.triangles.as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(vertices: Vec<Vec3>) -> Mesh {
        let n = vertices.len() as u32;
        let triangles = (0..n.saturating_sub(2))
            .map(|i| [i, i + 1, i + 2])
            .collect();
        Mesh::new(vertices, triangles).unwrap()
    }

    /// Every decoded vertex within half a step of the original, per axis, exactly (f64).
    fn assert_bound(m: &Mesh, q: &QuantizedMesh) {
        let half = q.grid().max_error().as_dvec3();
        for (i, v) in m.vertices().iter().enumerate() {
            let err = (q.vertex(i as u32).as_dvec3() - v.as_dvec3()).abs();
            assert!(
                err.cmple(half).all(),
                "vertex {i} {v}: error {err} > {half}"
            );
        }
    }

    #[test]
    fn error_at_most_half_a_step_for_every_bit_count() {
        let mut rng = crate::test_support::TestRng::new(7);
        let scales = [1e-3f32, 1.0, 1e3, 1e6];
        for bits in 1..=16 {
            for &scale in &scales {
                let offset = Vec3::new(1e4, -3.0, 0.0) * scale;
                let vertices: Vec<Vec3> = (0..200)
                    .map(|_| rng.vec3(1.0) * scale + offset)
                    .chain([Vec3::splat(1e-30), offset])
                    .collect();
                let m = mesh(vertices);
                let q = QuantizedMesh::new(&m, bits).unwrap();
                assert_bound(&m, &q);
                assert!(q.grid().step.cmpgt(Vec3::ZERO).all());
            }
        }
    }

    #[test]
    fn sixteen_bits_take_half_the_vertex_bytes() {
        let m = mesh((0..100).map(|i| Vec3::splat(i as f32)).collect());
        let f32_bytes = size_of_val(m.vertices());
        for (bits, bytes) in [(16, f32_bytes / 2), (10, f32_bytes / 3), (8, f32_bytes / 4)] {
            assert_eq!(QuantizedMesh::new(&m, bits).unwrap().vertex_bytes(), bytes);
        }
    }

    #[test]
    fn decode_is_exact_and_grid_points_survive() {
        // Vertices on the grid (here integers with 16 bits) come back unchanged.
        let m = mesh(
            (0..50)
                .map(|i| Vec3::new(i as f32, -(i as f32), 7.0))
                .collect(),
        );
        let q = QuantizedMesh::new(&m, 16).unwrap();
        assert_eq!(q.dequantize(), m);
        assert_eq!(q.triangles(), m.triangles());
    }

    #[test]
    fn bad_bits_and_empty_meshes() {
        let m = mesh(vec![Vec3::ZERO; 3]);
        assert_eq!(QuantizedMesh::new(&m, 0), Err(QuantizeError::BadBits(0)));
        assert_eq!(QuantizedMesh::new(&m, 17), Err(QuantizeError::BadBits(17)));
        let empty = QuantizedMesh::new(&Mesh::default(), 16).unwrap();
        assert_eq!(empty.dequantize(), Mesh::default());
    }
}
