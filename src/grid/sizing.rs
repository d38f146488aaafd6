//! How many cells a grid gets along each axis.
//!
//! The common rule of thumb, "cell size about the largest object", fails when object sizes
//! vary (one large ground quad would make one cell). The classic count rule (Cleary and Wyvill;
//! Ize et al.) is used instead: about `cells_per_triangle * N` cells in all. Their shape comes
//! from the triangles (`cell_shape`): cube cells for a surface facing every way (a statue),
//! columns for a height field. An axis the bounds are flat along (a height field's up axis may
//! be thin; a planar mesh's is zero) gets one slab, and the size is recomputed over the other
//! axes. The total is capped ([`GridOptions::max_cells`]); the builder coarsens further if
//! triangles would be stored too many times (`super::cells`).
//!
//! **Why columns.** A ray crossing the surface tests the triangles of the cells it crosses
//! there, so what matters is the surface area in a cell the surface crosses. A surface facing
//! axis `a` (projected area `w_a` on the plane across `a`) lies in about `w_a / (c_b c_c)`
//! cells of sides `c`: for a fixed number of cells, the area per crossed cell is smallest with
//! `c_a` proportional to `w_a` (minimise `sum w_a / c_a` at a fixed `c_x c_y c_z`). Long cells
//! cost steps for rays across them, so the shape is a compromise: `c_a` proportional to
//! `w_a^SHAPE_EXPONENT`, at most [`MAX_ASPECT`] times longer than wide (measured on the
//! terrain, bunny, city and sparse world: docs/benchmarks.md).

use crate::bvh::BuildError;
use crate::geom::Aabb;
use crate::mesh::Mesh;

/// The exponent of the projected areas in the cells' sides (see the module docs): 1 is the
/// optimum for the triangles a crossing ray tests, 0 gives cubes (fewest steps).
const SHAPE_EXPONENT: f64 = 1.0;

/// Largest ratio of a cell's longest side to its shortest (from the shape rule).
pub const MAX_ASPECT: f64 = 8.0;

/// How to build a grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridOptions {
    /// Target number of cells per triangle (the grid's density). Measured on the bunny, the
    /// terrain and the city (docs/benchmarks.md): 2 is near the best for closest hits.
    pub cells_per_triangle: f32,
    /// Largest number of cells (1.5 bits each, empty or not, plus the stored cells' cull boxes
    /// and triangle references).
    pub max_cells: u32,
    /// Cells along x, y and z, if given: overrides the density and the shape (still capped
    /// by `max_cells`).
    pub resolution: Option<[u32; 3]>,
    /// Shape the cells after the triangles' orientation: long along the axis the surface faces
    /// most, in proportion to the triangles' projected areas, at most 8:1 (a height field gets
    /// columns: fine across, few slabs up). If false, cube cells.
    pub shaped_cells: bool,
}

impl Default for GridOptions {
    fn default() -> Self {
        Self {
            cells_per_triangle: 2.0,
            max_cells: 1 << 24,
            resolution: None,
            shaped_cells: true,
        }
    }
}

impl GridOptions {
    /// `Ok` if every option is in its range: a finite, positive density, at least one cell,
    /// and at least one cell along each axis of a given resolution.
    pub fn validate(&self) -> Result<(), BuildError> {
        let bad = |option, value: String, expected| {
            Err(BuildError::BadOption {
                option,
                value,
                expected,
            })
        };
        let density = self.cells_per_triangle;
        if !(density.is_finite() && density > 0.0) {
            return bad(
                "cells_per_triangle",
                density.to_string(),
                "finite and above 0",
            );
        }
        if self.max_cells == 0 {
            return bad("max_cells", "0".into(), "at least 1");
        }
        if let Some(dims) = self.resolution
            && dims.contains(&0)
        {
            return bad(
                "resolution",
                format!("{dims:?}"),
                "at least 1 cell per axis",
            );
        }
        Ok(())
    }
}

/// The relative sides of the cells for the triangles `live` of `mesh` (see the module docs):
/// `[1, 1, 1]` for cubes (also if [`GridOptions::shaped_cells`] is off, or the triangles have
/// no area), else `w_a^SHAPE_EXPONENT` for the projected areas `w_a`, scaled so that the
/// longest side is 1 and clamped to at least `1 / MAX_ASPECT`.
pub(crate) fn cell_shape(mesh: &Mesh, live: &[u32], options: &GridOptions) -> [f64; 3] {
    if !options.shaped_cells || options.resolution.is_some() {
        return [1.0; 3];
    }
    let mut projected = [0f64; 3];
    for &id in live {
        let [a, b, c] = mesh.triangle(id);
        let normal = (b - a).cross(c - a).abs();
        for (w, n) in projected.iter_mut().zip(normal.to_array()) {
            *w += f64::from(n);
        }
    }
    let largest = projected.iter().copied().fold(0.0, f64::max);
    if !(largest > 0.0 && largest.is_finite()) {
        return [1.0; 3];
    }
    projected.map(|w| (w / largest).powf(SHAPE_EXPONENT).max(1.0 / MAX_ASPECT))
}

/// Slabs per axis for `triangles` triangles in `bounds` (non-empty), cells of relative sides
/// `shape` ([`cell_shape`]), at most `max_cells` in all. `options` passed
/// [`GridOptions::validate`].
pub(crate) fn resolution(
    bounds: &Aabb,
    triangles: usize,
    shape: [f64; 3],
    options: &GridOptions,
) -> [u32; 3] {
    debug_assert!(options.validate().is_ok(), "{options:?}");
    if let Some(dims) = options.resolution {
        return cap(dims, options.max_cells);
    }
    let max_cells = options.max_cells as f64;
    let density = f64::from(options.cells_per_triangle);
    let target = (density * triangles as f64).clamp(1.0, max_cells);
    let extent = bounds.extent().to_array().map(f64::from);
    let mut flat = extent.map(|e| e.is_nan() || e <= 0.0);
    let mut dims = [1u32; 3];
    // At most three rounds: each either keeps every axis or flattens one more.
    for _ in 0..3 {
        // Cells of sides `scale * shape[a]`: `volume / scale^axes` of them.
        let volume: f64 = (0..3)
            .filter(|&a| !flat[a])
            .map(|a| extent[a] / shape[a])
            .product();
        let axes = flat.iter().filter(|&&f| !f).count();
        if axes == 0 {
            break;
        }
        let scale = (volume / target).powf(1.0 / axes as f64);
        dims = [0, 1, 2].map(|a| {
            if flat[a] {
                1
            } else {
                (extent[a] / (scale * shape[a]))
                    .round()
                    .clamp(1.0, max_cells) as u32
            }
        });
        let newly_flat: Vec<usize> = (0..3).filter(|&a| !flat[a] && dims[a] == 1).collect();
        if newly_flat.is_empty() {
            break;
        }
        newly_flat.into_iter().for_each(|a| flat[a] = true);
    }
    cap(dims, options.max_cells)
}

/// `dims` with its largest axis halved until the product is at most `max_cells`.
pub(crate) fn cap(mut dims: [u32; 3], max_cells: u32) -> [u32; 3] {
    while dims.iter().map(|&d| u64::from(d)).product::<u64>() > u64::from(max_cells) {
        let a = (0..3).max_by_key(|&a| dims[a]).unwrap_or(0);
        dims[a] = (dims[a] / 2).max(1);
    }
    dims
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn dims(min: Vec3, max: Vec3, n: usize) -> [u32; 3] {
        resolution(&Aabb::new(min, max), n, [1.0; 3], &GridOptions::default())
    }

    #[test]
    fn cube_cells_follow_the_bounds() {
        assert_eq!(dims(Vec3::ZERO, Vec3::ONE, 500), [10, 10, 10]);
        assert_eq!(
            dims(Vec3::ZERO, Vec3::new(4.0, 1.0, 1.0), 2000),
            [40, 10, 10]
        );
    }

    #[test]
    fn flat_axes_get_one_slab() {
        assert_eq!(dims(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), 50), [10, 1, 10]);
        // Nearly flat: the cube size is recomputed over the other two axes.
        assert_eq!(dims(Vec3::ZERO, Vec3::new(1.0, 1e-4, 1.0), 50), [10, 1, 10]);
        assert_eq!(dims(Vec3::ZERO, Vec3::ZERO, 50), [1, 1, 1]);
    }

    #[test]
    fn a_height_field_gets_columns_a_closed_surface_cubes() {
        let options = GridOptions::default();
        // A gently sloped sheet facing y (its triangles' normals are mostly +y).
        let v = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(10.0, 1.0, 0.0),
            Vec3::new(0.0, 0.5, 10.0),
            Vec3::new(10.0, 1.5, 10.0),
        ];
        let sheet = Mesh::new(v, vec![[0, 2, 1], [1, 2, 3]]).unwrap();
        let shape = cell_shape(&sheet, &[0, 1], &options);
        assert_eq!(shape[1], 1.0);
        assert!(shape[0] < 0.2 && shape[2] < 0.2, "{shape:?}");
        let bounds = Aabb::new(Vec3::ZERO, Vec3::new(1000.0, 100.0, 1000.0));
        let [x, y, z] = resolution(&bounds, 1_000_000, shape, &options);
        let cube = resolution(&bounds, 1_000_000, [1.0; 3], &options);
        assert!(
            x > cube[0] && z > cube[2] && y < cube[1],
            "{:?} {cube:?}",
            [x, y, z]
        );
        // A cube's six faces: cubes.
        let corners = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2) as f32))
            .collect();
        let faces = vec![
            [0, 1, 3],
            [0, 3, 2],
            [4, 7, 5],
            [4, 6, 7], // z = 0, 1
            [0, 5, 1],
            [0, 4, 5],
            [2, 3, 7],
            [2, 7, 6], // y = 0, 1
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3], // x = 0, 1
        ];
        let cube_mesh = Mesh::new(corners, faces).unwrap();
        let ids: Vec<u32> = (0..12).collect();
        assert_eq!(cell_shape(&cube_mesh, &ids, &options), [1.0; 3]);
        let off = GridOptions {
            shaped_cells: false,
            ..options
        };
        assert_eq!(cell_shape(&sheet, &[0, 1], &off), [1.0; 3]);
    }

    #[test]
    fn huge_counts_are_capped() {
        let options = GridOptions {
            cells_per_triangle: 1e9,
            max_cells: 1000,
            ..GridOptions::default()
        };
        let d = resolution(
            &Aabb::new(Vec3::ZERO, Vec3::ONE),
            1 << 30,
            [1.0; 3],
            &options,
        );
        assert!(
            d.iter().map(|&x| x as u64).product::<u64>() <= 1000,
            "{d:?}"
        );
        assert_eq!(cap([1, 1, 1], 1), [1, 1, 1]);
    }
}
