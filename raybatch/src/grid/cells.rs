//! The grid's compact storage: one offset per cell into one array of triangle references, no
//! per-cell containers (the seed's "array of cells", minus the per-cell allocations).
//!
//! A triangle is referenced by every cell of its *block*: the cells whose planes enclose its
//! bounding box (see [`Planes::covering`], and `super::walk` for why that is enough for
//! exactness). Within a cell, references are in increasing triangle id. A reference is the
//! triangle id with [`SHARED`] set when the block has more than one cell (`super::mailbox`).

use crate::geom::Aabb;
use crate::mesh::Mesh;

use super::mailbox::SHARED;
use super::planes::Planes;
use super::walk::GridPlanes;

/// A triangle's cells: `(first, last)` slab along each axis.
pub(crate) type Block = [(u32, u32); 3];

/// The block of every triangle of `live` (ids of non-degenerate triangles), in that order.
pub(crate) fn blocks(mesh: &Mesh, live: &[u32], planes: &GridPlanes) -> Vec<Block> {
    live.iter()
        .map(|&id| {
            let b = Aabb::from_points(&mesh.triangle(id));
            [0, 1, 2].map(|a| planes[a].covering(b.min[a], b.max[a]))
        })
        .collect()
}

/// Cells in a block.
pub(crate) fn block_cells(block: &Block) -> u64 {
    block.iter().map(|&(a, b)| u64::from(b - a + 1)).product()
}

/// The reference a block's cells hold for triangle `id`.
pub(crate) fn reference(id: u32, block: &Block) -> u32 {
    if block_cells(block) > 1 {
        id | SHARED
    } else {
        id
    }
}

/// Calls `f(x, y, z)` for every cell of `block`.
pub(crate) fn for_each_cell(block: &Block, mut f: impl FnMut(u32, u32, u32)) {
    let [(x0, x1), (y0, y1), (z0, z1)] = *block;
    for z in z0..=z1 {
        for y in y0..=y1 {
            for x in x0..=x1 {
                f(x, y, z);
            }
        }
    }
}

/// Every cell's references, cell after cell (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Cells {
    dims: [u32; 3],
    /// `offsets[c]..offsets[c + 1]` are cell `c`'s references.
    offsets: Vec<u32>,
    refs: Vec<u32>,
    /// Bit `c` set if cell `c` holds a reference: one bit per cell, small enough to stay in
    /// cache, so that the walk crosses empty cells without reading their offsets (measured on
    /// the terrain: most of the per-ray time was spent on those cache misses).
    occupied: Vec<u64>,
}

impl Cells {
    /// The cells of a `dims` grid holding the triangles `live` with their `blocks`; `Err` with
    /// the number of references needed if that is more than `max_refs`.
    pub(crate) fn build(
        dims: [u32; 3],
        live: &[u32],
        blocks: &[Block],
        max_refs: u64,
    ) -> Result<Self, u64> {
        let needed: u64 = blocks.iter().map(block_cells).sum();
        if needed > max_refs.min(u64::from(u32::MAX)) {
            return Err(needed);
        }
        let cell_count = dims.iter().map(|&d| d as usize).product::<usize>();
        let index = |x: u32, y: u32, z: u32| cell_index(dims, [x, y, z]);
        let mut offsets = vec![0u32; cell_count + 1];
        for block in blocks {
            for_each_cell(block, |x, y, z| offsets[index(x, y, z) + 1] += 1);
        }
        for c in 0..cell_count {
            offsets[c + 1] += offsets[c];
        }
        let mut cursor = offsets.clone();
        let mut refs = vec![0u32; needed as usize];
        for (&id, block) in live.iter().zip(blocks) {
            let r = reference(id, block);
            for_each_cell(block, |x, y, z| {
                let slot = &mut cursor[index(x, y, z)];
                refs[*slot as usize] = r;
                *slot += 1;
            });
        }
        let mut occupied = vec![0u64; cell_count.div_ceil(64)];
        for c in 0..cell_count {
            if offsets[c + 1] > offsets[c] {
                occupied[c / 64] |= 1 << (c % 64);
            }
        }
        Ok(Self {
            dims,
            offsets,
            refs,
            occupied,
        })
    }

    /// The references of cell `cell` (slab indices), `None` if it holds none.
    #[inline(always)]
    pub(crate) fn occupied(&self, cell: [u32; 3]) -> Option<&[u32]> {
        let c = cell_index(self.dims, cell);
        if self.occupied[c / 64] & (1 << (c % 64)) == 0 {
            return None;
        }
        Some(&self.refs[self.offsets[c] as usize..self.offsets[c + 1] as usize])
    }

    /// True if no cell holds a triangle.
    pub(crate) fn is_empty(&self) -> bool {
        self.refs.is_empty()
    }

    /// Number of cells.
    pub(crate) fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of triangle references.
    pub(crate) fn reference_count(&self) -> usize {
        self.refs.len()
    }

    /// Bytes on the heap.
    pub(crate) fn heap_bytes(&self) -> usize {
        (self.offsets.len() + self.refs.len()) * size_of::<u32>()
            + self.occupied.len() * size_of::<u64>()
    }
}

/// The index of cell `[x, y, z]` in a `dims` grid (x fastest).
#[inline(always)]
pub(crate) fn cell_index(dims: [u32; 3], cell: [u32; 3]) -> usize {
    let [x, y, z] = cell.map(|c| c as usize);
    x + dims[0] as usize * (y + dims[1] as usize * z)
}

/// The planes of a `dims` grid over `bounds` (non-empty).
pub(crate) fn grid_planes(bounds: &Aabb, dims: [u32; 3]) -> GridPlanes {
    [0, 1, 2].map(|a| Planes::new(bounds.min[a], bounds.max[a], dims[a]))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    #[test]
    fn triangles_are_stored_in_their_block_only_in_id_order() {
        let vertices = vec![
            Vec3::new(0.1, 0.1, 0.5),
            Vec3::new(0.9, 0.1, 0.5),
            Vec3::new(0.1, 0.9, 0.5),
            Vec3::new(1.9, 1.9, 0.5),
            Vec3::new(0.2, 0.2, 0.5),
        ];
        // Triangle 0 in cell (0, 0); triangle 1 spans all four cells.
        let mesh = Mesh::new(vertices, vec![[0, 1, 2], [4, 3, 1]]).unwrap();
        let bounds = Aabb::new(Vec3::ZERO, Vec3::new(2.0, 2.0, 1.0));
        let dims = [2, 2, 1];
        let planes = grid_planes(&bounds, dims);
        let blocks = blocks(&mesh, &[0, 1], &planes);
        let cells = Cells::build(dims, &[0, 1], &blocks, 100).unwrap();
        assert_eq!(cells.occupied([0, 0, 0]), Some(&[0, 1 | SHARED][..]));
        assert_eq!(cells.occupied([1, 0, 0]), Some(&[1 | SHARED][..]));
        assert_eq!(cells.occupied([1, 1, 0]), Some(&[1 | SHARED][..]));
        assert_eq!((cells.len(), cells.reference_count()), (4, 5));
        assert_eq!(Cells::build(dims, &[0, 1], &blocks, 4).unwrap_err(), 5);
    }
}
