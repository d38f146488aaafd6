//! How many cells a grid gets along each axis.
//!
//! The seed's rule of thumb, "cell size about the largest object", fails when object sizes
//! vary (one large ground quad would make one cell). The classic count rule (Cleary and Wyvill;
//! Ize et al.) is used instead: about `cells_per_triangle * N` cells in all, cube-shaped (the
//! same size along every axis), so the grid follows the bounds' proportions. An axis the
//! bounds are flat along (a height field's up axis may be thin; a planar mesh's is zero) gets
//! one slab, and the cube size is recomputed over the other axes. The total is capped
//! ([`GridOptions::max_cells`]); the builder coarsens further if triangles would be stored too
//! many times (`super::cells`).

use crate::geom::Aabb;

/// How to build a grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridOptions {
    /// Target number of cells per triangle (the grid's density). Measured on the bunny, the
    /// terrain and the city (see the README): 2 is near the best for closest hits.
    pub cells_per_triangle: f32,
    /// Largest number of cells (4 bytes each, plus the triangle references).
    pub max_cells: u32,
    /// Cells along x, y and z, if given: overrides the density (still capped by
    /// `max_cells`). For scenes whose best shape is not cube cells (a height field may want
    /// fine cells across and few along its up axis): measure.
    pub resolution: Option<[u32; 3]>,
}

impl Default for GridOptions {
    fn default() -> Self {
        Self {
            cells_per_triangle: 2.0,
            max_cells: 1 << 24,
            resolution: None,
        }
    }
}

/// Slabs per axis for `triangles` triangles in `bounds` (non-empty), at most `max_cells` in
/// all.
pub(crate) fn resolution(bounds: &Aabb, triangles: usize, options: &GridOptions) -> [u32; 3] {
    if let Some(dims) = options.resolution {
        return cap(dims.map(|d| d.max(1)), options.max_cells.max(1));
    }
    let max_cells = options.max_cells.max(1) as f64;
    let density = f64::from(options.cells_per_triangle);
    let target = (density * triangles as f64).clamp(1.0, max_cells);
    let extent = bounds.extent().to_array().map(f64::from);
    let mut flat = extent.map(|e| e.is_nan() || e <= 0.0);
    let mut dims = [1u32; 3];
    // At most three rounds: each either keeps every axis or flattens one more.
    for _ in 0..3 {
        let volume: f64 = (0..3).filter(|&a| !flat[a]).map(|a| extent[a]).product();
        let axes = flat.iter().filter(|&&f| !f).count();
        if axes == 0 {
            break;
        }
        let side = (volume / target).powf(1.0 / axes as f64);
        dims = [0, 1, 2].map(|a| {
            if flat[a] {
                1
            } else {
                (extent[a] / side).round().clamp(1.0, max_cells) as u32
            }
        });
        let newly_flat: Vec<usize> = (0..3).filter(|&a| !flat[a] && dims[a] == 1).collect();
        if newly_flat.is_empty() {
            break;
        }
        newly_flat.into_iter().for_each(|a| flat[a] = true);
    }
    cap(dims, options.max_cells.max(1))
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
        resolution(&Aabb::new(min, max), n, &GridOptions::default())
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
    fn huge_counts_are_capped() {
        let options = GridOptions {
            cells_per_triangle: 1e9,
            max_cells: 1000,
            resolution: None,
        };
        let d = resolution(&Aabb::new(Vec3::ZERO, Vec3::ONE), 1 << 30, &options);
        assert!(
            d.iter().map(|&x| x as u64).product::<u64>() <= 1000,
            "{d:?}"
        );
        assert_eq!(cap([1, 1, 1], 1), [1, 1, 1]);
    }
}
