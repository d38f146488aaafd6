//! The grid's compact storage: an occupancy bit per cell, and for the cells that hold
//! triangles (the *stored* cells) a coarse cull box (`super::cull`, 30 bits) and a start into
//! one array of triangle references; no per-cell containers (the classic array of cells,
//! minus the per-cell allocations) and nothing for an empty cell but its bit and a share of
//! the running counts (1.5 bits in all).
//!
//! A triangle is referenced by every cell of its *block*: the cells whose planes enclose its
//! bounding box (see [`Planes::covering`], and `super::walk` for why that is enough for
//! exactness). Within a cell, references are in increasing triangle id. A reference is the
//! triangle id with [`SHARED`] set when the block has more than one cell (`super::mailbox`).
//!
//! **Why stored cells by rank.** A stored cell's cull box and start are found by its rank
//! among the stored cells: the running count of stored cells before its 64-cell occupancy
//! word plus the set bits below it in that word, both in cache beside the bits. A start per
//! cell, empty or not, takes 8 MB on the 1M-triangle terrain, whose loads miss the cache
//! before the cell's words do; by rank the terrain's grid takes 23% less memory at the same
//! speed (docs/benchmarks.md). A 32-byte record per stored cell (exact cull box and reference
//! range, the references elsewhere) runs no faster on short rays and costs the cells a ray
//! tests a second miss; 4 bytes of coarse cull box per stored cell, by rank, do pay
//! (`super::cull`).

use glam::{Vec3, Vec3A};

use crate::geom::Aabb;
use crate::geom::aabb::SlabRay;
use crate::mesh::Mesh;
use crate::prefetch::prefetch;

use super::cull::{coarse_cull, coarse_hit, coarse_steps, cull_box};
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

/// The stored cells and their references (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Cells {
    /// Number of cells, stored or empty.
    cell_count: usize,
    /// Bit `c % 64` of word `c / 64` set if cell `c` holds a reference: one bit per cell,
    /// small enough to stay in cache, so that the walk crosses empty cells without a miss.
    occupied: Vec<u64>,
    /// The number of stored cells before each word of `occupied`: a stored cell's rank is
    /// that plus the set bits below it in its word.
    stored_before: Vec<u32>,
    /// `starts[k]..starts[k + 1]` are the references of the stored cell of rank `k`.
    starts: Vec<u32>,
    /// Every stored cell's triangle references, cell after cell.
    refs: Vec<u32>,
    /// Every stored cell's cull box, rounded out to whole steps of a thirty-first of a cell
    /// (`super::cull::coarse_cull`), by rank.
    cull: Vec<u32>,
    /// Those steps, per axis (`super::cull::coarse_steps`).
    steps: Vec3A,
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
        let stored: Vec<usize> = (0..cell_count).filter(|&c| counts[c] > 0).collect();
        // Each stored cell's references; `cursor` is the next free word.
        let mut starts = Vec::with_capacity(stored.len() + 1);
        starts.push(0u32);
        let mut cursor = vec![0u32; cell_count];
        for &c in &stored {
            let start = *starts.last().unwrap();
            cursor[c] = start;
            starts.push(start + counts[c]);
        }
        let mut refs = vec![0u32; needed as usize];
        for (&id, block) in live.iter().zip(blocks) {
            let r = reference(id, block);
            for_each_cell(block, |x, y, z| {
                let slot = &mut cursor[index(x, y, z)];
                refs[*slot as usize] = r;
                *slot += 1;
            });
        }
        let steps = coarse_steps(planes);
        let cull = stored
            .iter()
            .enumerate()
            .map(|(rank, &c)| {
                let cell = cell_of(dims, c as u64);
                let cell_refs = &refs[starts[rank] as usize..starts[rank + 1] as usize];
                let triangle_boxes = cell_refs.iter().map(|&r| boxes[(r & !SHARED) as usize]);
                coarse_cull(planes, steps, cell, cull_box(planes, cell, triangle_boxes))
            })
            .collect();
        let (occupied, stored_before) = occupancy(cell_count, &stored);
        Ok(Self {
            cell_count,
            occupied,
            stored_before,
            starts,
            refs,
            cull,
            steps,
        })
    }

    /// The rank of cell `c` (a linear index, [`cell_index`]) among the stored cells, `None`
    /// if it holds no reference.
    #[inline(always)]
    pub(crate) fn rank_of(&self, c: usize) -> Option<usize> {
        let word = self.occupied[c / 64];
        let bit = 1u64 << (c % 64);
        if word & bit == 0 {
            return None;
        }
        Some((self.stored_before[c / 64] + (word & (bit - 1)).count_ones()) as usize)
    }

    /// The references of the stored cell of rank `rank` (cell `cell` of `planes`, the grid
    /// built over them) that the ray (`slab`) must test: all of them if it may meet the cell's
    /// coarse cull box within `[tmin, tmax]`, else `None`.
    #[inline(always)]
    pub(crate) fn refs_to_test(
        &self,
        rank: usize,
        (planes, cell): (&GridPlanes, [u32; 3]),
        slab: &SlabRay,
        tmax: f32,
    ) -> Option<&[u32]> {
        coarse_hit(planes, self.steps, cell, self.cull[rank], slab, tmax).then(|| self.refs(rank))
    }

    /// Prefetches the cull box of the stored cell of rank `rank`.
    #[inline(always)]
    pub(crate) fn prefetch_cull(&self, rank: usize) {
        prefetch(&self.cull[rank]);
    }

    /// The references of the stored cell of rank `rank`.
    #[inline(always)]
    pub(crate) fn refs(&self, rank: usize) -> &[u32] {
        &self.refs[self.starts[rank] as usize..self.starts[rank + 1] as usize]
    }

    /// True if no cell holds a triangle.
    pub(crate) fn is_empty(&self) -> bool {
        self.refs.is_empty()
    }

    /// Number of cells.
    pub(crate) fn len(&self) -> usize {
        self.cell_count
    }

    /// Number of triangle references.
    pub(crate) fn reference_count(&self) -> usize {
        self.refs.len()
    }

    /// Bytes on the heap.
    pub(crate) fn heap_bytes(&self) -> usize {
        self.occupied.len() * size_of::<u64>()
            + (self.stored_before.len() + self.starts.len() + self.refs.len() + self.cull.len())
                * size_of::<u32>()
    }
}

/// The occupancy bits of a grid of `cell_count` cells whose cells `stored` (increasing) hold
/// references, and the number of stored cells before each 64-bit word of them.
fn occupancy(cell_count: usize, stored: &[usize]) -> (Vec<u64>, Vec<u32>) {
    let mut occupied = vec![0u64; cell_count.div_ceil(64)];
    for &c in stored {
        occupied[c / 64] |= 1 << (c % 64);
    }
    let mut before = 0u32;
    let stored_before = occupied
        .iter()
        .map(|word| {
            let this = before;
            before += word.count_ones();
            this
        })
        .collect();
    (occupied, stored_before)
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
    use crate::grid::cull::coarse_box;

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
        let refs = |cell| cells.rank_of(cell_index(dims, cell)).map(|k| cells.refs(k));
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
        let steps = cells.steps;
        let cull = |cell| {
            let rank = cells.rank_of(cell_index([2, 2, 1], cell)).unwrap();
            let (min, max) = coarse_box(&planes, steps, cell, cells.cull[rank]);
            (Vec3::from(min), Vec3::from(max))
        };
        // Within a step (a thirty-first of the cell) outside what the triangles put in the
        // cell: triangle 0's box [0.2, 1.9] x [0.1, 1.9] cut by each cell; triangle 1 in (0, 0).
        let holds = |cell, min: Vec3, max: Vec3| {
            let (lo, hi) = cull(cell);
            let step = Vec3::from(steps);
            assert!(lo.cmple(min).all() && hi.cmpge(max).all(), "{cell:?}");
            assert!(
                (min - lo).cmplt(step).all() && (hi - max).cmplt(step).all(),
                "{cell:?}"
            );
        };
        holds(
            [1, 1, 0],
            Vec3::new(1.0, 1.0, 0.5),
            Vec3::new(1.9, 1.9, 0.5),
        );
        holds(
            [0, 0, 0],
            Vec3::new(0.1, 0.1, 0.25),
            Vec3::new(1.0, 1.0, 0.5),
        );
    }
}
