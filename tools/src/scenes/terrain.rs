//! The terrain scene: a heightfield over a regular grid, the classic "large, flat-ish, huge
//! triangles count" benchmark where boxes are thin and rays graze the surface.
//!
//! Heights come from a few octaves of value noise (hashed lattice values, quintic interpolation):
//! only integer hashing and `+ * floor`, so every machine builds the same mesh bit for bit.
//! [`TerrainGrid`] reads a generated mesh back, so ray sets can place points exactly on (or a
//! fixed height above) its triangulated surface.

use raybatch::Mesh;
use raybatch::glam::Vec3;
use rayon::prelude::*;

use super::rng::{bits_to_unit_f32, mix64};

/// Side of the square the terrain covers, `[0, SIZE] x [0, SIZE]` in `x`, `z`.
pub(crate) const SIZE: f32 = 1000.0;
/// Largest height: the noise lies in `[0, 1)` and is scaled by this.
const MAX_HEIGHT: f32 = 100.0;
/// Wavelength of the coarsest octave: a few big hills across the square.
const BASE_WAVELENGTH: f32 = 250.0;
/// Octaves of value noise, each twice the frequency and half the amplitude of the previous.
const OCTAVES: u32 = 5;

/// The heightfield mesh: `(n + 1)^2` vertices in row-major order (`z` rows of `x` columns) and
/// two triangles per cell, all facing up (`+y`). `cells_per_side` below 1 is taken as 1.
///
/// Panics if `(n + 1)^2` vertices do not fit 32-bit indices (`n > 65534`).
pub(crate) fn mesh(cells_per_side: u32, seed: u64) -> Mesh {
    let n = cells_per_side.max(1);
    Mesh::new(vertices(n, seed), triangles(n)).expect("a heightfield grid is always a valid mesh")
}

/// Grid coordinate of column or row `i` of `n` cells.
fn grid_coord(i: u32, n: u32) -> f32 {
    i as f32 * SIZE / n as f32
}

/// The grid vertices, one row per rayon task (the heights are independent and pure, so the
/// result does not depend on the thread count).
fn vertices(n: u32, seed: u64) -> Vec<Vec3> {
    let side = n as usize + 1;
    let mut out = vec![Vec3::ZERO; side * side];
    out.par_chunks_mut(side).enumerate().for_each(|(j, row)| {
        let z = grid_coord(j as u32, n);
        for (i, v) in row.iter_mut().enumerate() {
            let x = grid_coord(i as u32, n);
            *v = Vec3::new(x, height(seed, x, z), z);
        }
    });
    out
}

/// Two triangles per cell, split along the `(i+1, j)`–`(i, j+1)` diagonal, wound so their normals
/// point up (`+y`).
pub(crate) fn triangles(n: u32) -> Vec<[u32; 3]> {
    let side = n + 1;
    let mut out = Vec::with_capacity(2 * n as usize * n as usize);
    for j in 0..n {
        for i in 0..n {
            let v00 = j * side + i;
            let (v10, v01, v11) = (v00 + 1, v00 + side, v00 + side + 1);
            out.push([v00, v01, v10]);
            out.push([v10, v01, v11]);
        }
    }
    out
}

/// The continuous height at `(x, z)`: fractal value noise in `[0, MAX_HEIGHT)`.
pub(crate) fn height(seed: u64, x: f32, z: f32) -> f32 {
    let (mut sum, mut norm) = (0.0, 0.0);
    let (mut freq, mut amp) = (1.0 / BASE_WAVELENGTH, 1.0);
    for octave in 0..OCTAVES {
        let octave_key = mix64(seed.wrapping_add(u64::from(octave)));
        sum += amp * value_noise(octave_key, x * freq, z * freq);
        norm += amp;
        freq *= 2.0;
        amp *= 0.5;
    }
    MAX_HEIGHT * sum / norm
}

/// Value noise: pseudo-random values on the integer lattice, smoothly interpolated; in `[0, 1)`.
/// `key` is the hashed seed of the octave.
fn value_noise(key: u64, x: f32, z: f32) -> f32 {
    let (ix, iz) = (floor_i32(x), floor_i32(z));
    let (u, w) = (fade(x - ix as f32), fade(z - iz as f32));
    let at = |dx: i32, dz: i32| lattice(key, ix + dx, iz + dz);
    let near = lerp(at(0, 0), at(1, 0), u);
    let far = lerp(at(0, 1), at(1, 1), u);
    lerp(near, far, w)
}

/// `floor(x)` as an integer without the `floorf` library call (not inlined on baseline x86-64).
/// Exact for the small coordinates the noise sees.
fn floor_i32(x: f32) -> i32 {
    let i = x as i32;
    if i as f32 > x { i - 1 } else { i }
}

/// The hashed value at lattice point `(ix, iz)`, in `[0, 1)`.
fn lattice(key: u64, ix: i32, iz: i32) -> f32 {
    let point = (u64::from(ix as u32) << 32) | u64::from(iz as u32);
    bits_to_unit_f32(mix64(key ^ point))
}

/// Quintic smoothstep (Perlin 2002): zero first and second derivatives at the lattice, so the
/// hills have no visible grid creases.
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// A read-only view of a mesh built by [`mesh`]: recovers the grid size from the vertex count and
/// interpolates the triangulated surface exactly as the triangles do.
pub(crate) struct TerrainGrid<'a> {
    vertices: &'a [Vec3],
    n: u32,
}

impl<'a> TerrainGrid<'a> {
    /// `None` unless `mesh` has the layout of a terrain built by [`mesh`] (square vertex count,
    /// `2n^2` triangles, corners at `(0, 0)` and `(SIZE, SIZE)`).
    pub(crate) fn from_mesh(mesh: &'a Mesh) -> Option<Self> {
        let vertices = mesh.vertices();
        let side = vertices.len().isqrt();
        if side < 2 || side * side != vertices.len() {
            return None;
        }
        let n = side - 1;
        let (first, last) = (vertices[0], vertices[vertices.len() - 1]);
        let corners_ok = (first.x, first.z) == (0.0, 0.0) && (last.x, last.z) == (SIZE, SIZE);
        let count_ok = mesh.triangle_count() == 2 * n * n;
        (corners_ok && count_ok).then_some(Self {
            vertices,
            n: n as u32,
        })
    }

    fn height_at(&self, i: u32, j: u32) -> f32 {
        self.vertices[(j * (self.n + 1) + i) as usize].y
    }

    /// Height of the triangulated surface at `(x, z)`, clamped to the square.
    pub(crate) fn surface_height(&self, x: f32, z: f32) -> f32 {
        let scale = self.n as f32 / SIZE;
        let (fx, fz) = (
            (x * scale).clamp(0.0, self.n as f32),
            (z * scale).clamp(0.0, self.n as f32),
        );
        let (i, j) = ((fx as u32).min(self.n - 1), (fz as u32).min(self.n - 1));
        let (u, w) = (fx - i as f32, fz - j as f32);
        let h00 = self.height_at(i, j);
        let h10 = self.height_at(i + 1, j);
        let h01 = self.height_at(i, j + 1);
        let h11 = self.height_at(i + 1, j + 1);
        // The cell's diagonal runs from (1, 0) to (0, 1): the same split as `triangles`.
        if u + w <= 1.0 {
            h00 + u * (h10 - h00) + w * (h01 - h00)
        } else {
            h11 + (1.0 - u) * (h01 - h11) + (1.0 - w) * (h10 - h11)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_grid_formula() {
        for n in [1u32, 2, 7, 40] {
            let m = mesh(n, 3);
            assert_eq!(m.vertices().len(), ((n + 1) * (n + 1)) as usize);
            assert_eq!(m.triangle_count(), (2 * n * n) as usize);
        }
        assert_eq!(mesh(0, 3).triangle_count(), 2, "n = 0 is taken as 1");
    }

    #[test]
    fn same_seed_same_terrain() {
        assert_eq!(mesh(30, 5), mesh(30, 5));
        assert_ne!(mesh(30, 5), mesh(30, 6));
    }

    #[test]
    fn bounds_and_heights_are_sane() {
        let m = mesh(64, 1);
        let b = m.bounds();
        assert_eq!((b.min.x, b.min.z, b.max.x, b.max.z), (0.0, 0.0, SIZE, SIZE));
        assert!(b.min.y >= 0.0 && b.max.y < MAX_HEIGHT, "{b:?}");
        // Hills, not a plane: the heights span a good part of the range.
        assert!(b.max.y - b.min.y > 0.3 * MAX_HEIGHT, "{b:?}");
    }

    #[test]
    fn floor_matches_the_float_floor() {
        for x in [-2.5f32, -2.0, -0.25, -0.0, 0.0, 0.75, 1.0, 3.999, 63.5] {
            assert_eq!(floor_i32(x) as f32, x.floor(), "{x}");
        }
    }

    #[test]
    fn every_triangle_faces_up() {
        let m = mesh(16, 2);
        for id in 0..m.triangle_count() as u32 {
            let [a, b, c] = m.triangle(id);
            assert!((b - a).cross(c - a).y > 0.0, "triangle {id}");
        }
    }

    #[test]
    fn surface_height_matches_the_triangles() {
        let m = mesh(10, 4);
        let grid = TerrainGrid::from_mesh(&m).expect("a terrain mesh");
        // At vertices the surface is the vertex height; at a triangle's centroid, its mean.
        for v in m.vertices() {
            assert!((grid.surface_height(v.x, v.z) - v.y).abs() < 1e-3, "{v}");
        }
        for id in 0..m.triangle_count() as u32 {
            let [a, b, c] = m.triangle(id);
            let g = (a + b + c) / 3.0;
            assert!(
                (grid.surface_height(g.x, g.z) - g.y).abs() < 1e-3,
                "triangle {id}"
            );
        }
        let other = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Z], vec![[0, 1, 2]]).unwrap();
        assert!(TerrainGrid::from_mesh(&other).is_none());
    }
}
