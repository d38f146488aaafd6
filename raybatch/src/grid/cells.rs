//! The grid's compact storage: one offset per cell into one array of triangle references, no
//! per-cell containers (the seed's "array of cells", minus the per-cell allocations).
//!
//! A triangle is referenced by every cell of its *block*: the cells whose planes enclose its
//! bounding box (see [`Planes::covering`], and `super::walk` for why that is enough for
//! exactness). Within a cell, references are in increasing triangle id. A reference is the
//! triangle id with [`SHARED`] set when the block has more than one cell (`super::mailbox`).
//! A non-empty cell's references follow its cull box (`super::cull`) in the same array.

use glam::Vec3;

use crate::geom::Aabb;
use crate::mesh::Mesh;

use super::cull::{CULL_WORDS, cull_words};
use super::mailbox::SHARED;
use super::planes::Planes;
use super::walk::GridPlanes;

/// A triangle's cells: `(first, last)` slab along each axis.
pub(crate) type Block = [(u32, u32); 3];

/// A triangle's box as `(min, max)`.
pub(crate) type TriangleBox = (Vec3, Vec3);

/// The box of every triangle of `mesh`, by triangle id.
pub(crate) fn triangle_boxes(mesh: &Mesh) -> Vec<TriangleBox> {
    (0..mesh.triangle_count() as u32)
        .map(|id| {
            let b = Aabb::from_points(&mesh.triangle(id));
            (b.min, b.max)
        })
        .collect()
}

/// The block of every triangle of `live` (ids of non-degenerate triangles, whose boxes are
/// `boxes[id]`), in that order.
pub(crate) fn blocks(live: &[u32], boxes: &[TriangleBox], planes: &GridPlanes) -> Vec<Block> {
    live.iter()
        .map(|&id| {
            let (min, max) = boxes[id as usize];
            [0, 1, 2].map(|a| planes[a].covering(min[a], max[a]))
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

/// Every cell's cull box and references, cell after cell (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Cells {
    /// `offsets[c]..offsets[c + 1]` are cell `c`'s words: nothing if it is empty, else its
    /// cull box ([`CULL_WORDS`]) then its references.
    offsets: Vec<u32>,
    words: Vec<u32>,
    /// Triangle references stored (the words minus the cull boxes).
    references: usize,
    /// Bit `c` set if cell `c` holds a reference: one bit per cell, small enough to stay in
    /// cache, so that the walk crosses empty cells without reading their offsets (measured on
    /// the terrain: most of the per-ray time was spent on those cache misses).
    occupied: Vec<u64>,
}

impl Cells {
    /// The cells of grid `planes` holding the triangles `live` with their `blocks` (the boxes
    /// of all triangles, by id: `boxes`); `Err` with the number of references needed if that
    /// is more than `max_refs`.
    pub(crate) fn build(
        planes: &GridPlanes,
        live: &[u32],
        boxes: &[TriangleBox],
        blocks: &[Block],
        max_refs: u64,
    ) -> Result<Self, u64> {
        let needed: u64 = blocks.iter().map(block_cells).sum();
        if needed > max_refs.min(u64::from(u32::MAX)) {
            return Err(needed);
        }
        let dims = planes.each_ref().map(|p| p.slabs());
        let cell_count = dims.iter().map(|&d| d as usize).product::<usize>();
        let index = |x: u32, y: u32, z: u32| cell_index(dims, [x, y, z]);
        let mut counts = vec![0u32; cell_count];
        for block in blocks {
            for_each_cell(block, |x, y, z| counts[index(x, y, z)] += 1);
        }
        let occupied_cells = counts.iter().filter(|&&n| n > 0).count();
        let total = needed as usize + CULL_WORDS * occupied_cells;
        if u32::try_from(total).is_err() {
            return Err(needed);
        }
        let mut offsets = vec![0u32; cell_count + 1];
        for c in 0..cell_count {
            let header = if counts[c] > 0 { CULL_WORDS as u32 } else { 0 };
            offsets[c + 1] = offsets[c] + header + counts[c];
        }
        // References go after each cell's header, at the end of its words; `cursor` is the
        // next free word.
        let mut cursor: Vec<u32> = (0..cell_count)
            .map(|c| offsets[c + 1] - counts[c])
            .collect();
        let mut words = vec![0u32; total];
        for (&id, block) in live.iter().zip(blocks) {
            let r = reference(id, block);
            for_each_cell(block, |x, y, z| {
                let slot = &mut cursor[index(x, y, z)];
                words[*slot as usize] = r;
                *slot += 1;
            });
        }
        let mut occupied = vec![0u64; cell_count.div_ceil(64)];
        let mut cells = Self {
            offsets,
            words,
            references: needed as usize,
            occupied: Vec::new(),
        };
        for c in 0..cell_count {
            if counts[c] == 0 {
                continue;
            }
            occupied[c / 64] |= 1 << (c % 64);
            let start = cells.offsets[c] as usize;
            let cell = cell_of(dims, c as u64);
            let refs = &cells.words[start + CULL_WORDS..cells.offsets[c + 1] as usize];
            let cull = cull_words(
                planes,
                cell,
                refs.iter().map(|&r| boxes[(r & !SHARED) as usize]),
            );
            cells.words[start..start + CULL_WORDS].copy_from_slice(&cull);
        }
        cells.occupied = occupied;
        Ok(cells)
    }

    /// The words of cell `c` (a linear index, [`cell_index`]: its cull box, then its
    /// references), `None` if it holds none.
    #[inline(always)]
    pub(crate) fn occupied_at(&self, c: usize) -> Option<&[u32]> {
        if self.occupied[c / 64] & (1 << (c % 64)) == 0 {
            return None;
        }
        Some(&self.words[self.offsets[c] as usize..self.offsets[c + 1] as usize])
    }

    /// True if no cell holds a triangle.
    pub(crate) fn is_empty(&self) -> bool {
        self.words.is_empty()
    }

    /// Number of cells.
    pub(crate) fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Number of triangle references.
    pub(crate) fn reference_count(&self) -> usize {
        self.references
    }

    /// Bytes on the heap.
    pub(crate) fn heap_bytes(&self) -> usize {
        (self.offsets.len() + self.words.len()) * size_of::<u32>()
            + self.occupied.len() * size_of::<u64>()
    }
}

/// The index of cell `[x, y, z]` in a `dims` grid (x fastest).
#[inline(always)]
pub(crate) fn cell_index(dims: [u32; 3], cell: [u32; 3]) -> usize {
    let [x, y, z] = cell.map(|c| c as usize);
    x + dims[0] as usize * (y + dims[1] as usize * z)
}

/// The slab indices of cell `c` of a `dims` grid (the inverse of [`cell_index`]).
pub(crate) fn cell_of(dims: [u32; 3], c: u64) -> [u32; 3] {
    let [nx, ny, _] = dims.map(u64::from);
    [c % nx, c / nx % ny, c / nx / ny].map(|i| i as u32)
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
        let boxes = triangle_boxes(&mesh);
        let blocks = blocks(&[0, 1], &boxes, &planes);
        let cells = Cells::build(&planes, &[0, 1], &boxes, &blocks, 100).unwrap();
        let refs = |cell| {
            cells
                .occupied_at(cell_index(dims, cell))
                .map(|words| &words[CULL_WORDS..])
        };
        assert_eq!(refs([0, 0, 0]), Some(&[0, 1 | SHARED][..]));
        assert_eq!(refs([1, 0, 0]), Some(&[1 | SHARED][..]));
        assert_eq!(refs([1, 1, 0]), Some(&[1 | SHARED][..]));
        assert_eq!((cells.len(), cells.reference_count()), (4, 5));
        assert_eq!(
            Cells::build(&planes, &[0, 1], &boxes, &blocks, 4).unwrap_err(),
            5
        );
    }

    #[test]
    fn cull_boxes_hold_what_the_triangles_put_in_the_cell() {
        let vertices = vec![
            Vec3::new(0.2, 0.1, 0.5),
            Vec3::new(1.9, 1.9, 0.5),
            Vec3::new(0.9, 0.1, 0.5),
            Vec3::new(0.1, 0.1, 0.25),
            Vec3::new(0.3, 0.1, 0.25),
            Vec3::new(0.1, 0.4, 0.25),
        ];
        let mesh = Mesh::new(vertices, vec![[0, 1, 2], [3, 4, 5]]).unwrap();
        let bounds = Aabb::new(Vec3::ZERO, Vec3::new(2.0, 2.0, 1.0));
        let planes = grid_planes(&bounds, [2, 2, 1]);
        let boxes = triangle_boxes(&mesh);
        let blocks = blocks(&[0, 1], &boxes, &planes);
        let cells = Cells::build(&planes, &[0, 1], &boxes, &blocks, 100).unwrap();
        let cull = |cell| {
            let c = cell_index([2, 2, 1], cell);
            let words: Vec<f32> = cells.occupied_at(c).unwrap()[..CULL_WORDS]
                .iter()
                .map(|&w| f32::from_bits(w))
                .collect();
            (Vec3::from_slice(&words[..3]), Vec3::from_slice(&words[3..]))
        };
        // Triangle 0's box [0.2, 1.9] x [0.1, 1.9] cut by each cell; triangle 1 in (0, 0).
        assert_eq!(
            cull([1, 1, 0]),
            (Vec3::new(1.0, 1.0, 0.5), Vec3::new(1.9, 1.9, 0.5))
        );
        assert_eq!(
            cull([0, 0, 0]),
            (Vec3::new(0.1, 0.1, 0.25), Vec3::new(1.0, 1.0, 0.5))
        );
    }
}
