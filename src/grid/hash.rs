//! [`SpatialHash`]: the uniform grid's cells and walk, with only the non-empty cells stored,
//! in a hash table (a spatial hash).
//!
//! A dense grid pays 4 bytes (an offset) for every cell, empty or not, which limits how fine
//! it can be over a large, mostly empty world. The hash stores a 16-byte slot per *non-empty*
//! cell (and keeps its table at most half full), so its memory follows the geometry, not the
//! bounds, and the cells can be as fine as the triangles. The price is a table probe for each
//! cell the walk crosses, where the dense grid reads one bit. Cells are those of the same
//! exact walk ([`super::walk`]'s argument applies unchanged: only the lookup differs).

use std::sync::Arc;

use crate::accel::{Accel, Footprint, RayStream};
use crate::bvh::BuildError;
use crate::geom::aabb::SlabRay;
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::mesh::Mesh;

use super::cells::{Block, TriangleBox, blocks, cell_of, for_each_cell, grid_planes, reference};
use super::cull::{self, CULL_WORDS, cull_words};
use super::mailbox::SHARED;
use super::scratch::GridScratch;
use super::sizing::{GridOptions, cap, cell_shape, resolution};
use super::table::CellTable;
use super::uniform::{live_triangles, test_cell};
use super::walk::{GridPlanes, bounds, linear_index, walk};
use crate::traverse::origin_order;

/// A triangle is stored at most this many times on average (else the cells are coarsened).
const REFERENCES_PER_TRIANGLE: u64 = 16;

/// Cells per triangle the hash aims at by default: 8 times the dense grid's, since empty
/// cells cost it nothing.
pub const HASH_CELLS_PER_TRIANGLE: f32 = 16.0;

/// Largest number of cells along an axis (so that linear cell indices stay far below 2^63).
const MAX_SLABS: u32 = 1 << 20;

/// A spatial hash grid over a mesh (see the module docs).
#[derive(Clone, Debug)]
pub struct SpatialHash {
    mesh: Arc<Mesh>,
    planes: GridPlanes,
    dims: [u32; 3],
    table: CellTable,
    /// Each stored cell's cull box, then its references (`super::cull`).
    words: Vec<u32>,
    coarse: Coarse,
}

/// One bit per block of `2^shift` cells along each axis, set if the block holds a stored cell:
/// the walk skips the table probe (a cache miss) for cells of empty blocks, which in a sparse
/// world are almost all the cells a ray crosses. The block size is the smallest that keeps the
/// bits at most [`COARSE_BITS_PER_CELL`] per *stored* cell, so the map never makes the hash's
/// memory follow the bounds.
#[derive(Clone, Debug, Default)]
struct Coarse {
    shift: u32,
    dims: [u64; 3],
    bits: Vec<u64>,
}

/// Bits of the coarse map per stored cell, at most.
const COARSE_BITS_PER_CELL: u64 = 8;

impl Coarse {
    /// The map of the cells `keys` (linear indices) of a `dims` grid.
    fn new(dims: [u32; 3], cells: &[[u32; 3]]) -> Self {
        let budget = COARSE_BITS_PER_CELL * cells.len().max(1) as u64;
        let mut shift = 0;
        let blocks = |shift: u32| dims.map(|d| u64::from(d).div_ceil(1 << shift));
        while blocks(shift).iter().product::<u64>() > budget {
            shift += 1;
        }
        let dims = blocks(shift);
        let mut map = Self {
            shift,
            dims,
            bits: vec![0; (dims.iter().product::<u64>() as usize).div_ceil(64)],
        };
        for &cell in cells {
            let b = map.block(cell);
            map.bits[b / 64] |= 1 << (b % 64);
        }
        map
    }

    /// The block holding `cell`.
    #[inline(always)]
    fn block(&self, cell: [u32; 3]) -> usize {
        let [x, y, z] = cell.map(|c| u64::from(c >> self.shift));
        (x + self.dims[0] * (y + self.dims[1] * z)) as usize
    }

    /// True if `cell`'s block may hold a stored cell.
    #[inline(always)]
    fn may_hold(&self, cell: [u32; 3]) -> bool {
        let b = self.block(cell);
        self.bits[b / 64] & (1 << (b % 64)) != 0
    }

    fn heap_bytes(&self) -> usize {
        self.bits.len() * size_of::<u64>()
    }
}

impl SpatialHash {
    /// The default options: `HASH_CELLS_PER_TRIANGLE` cells per triangle, no cap on the total cell count
    /// beyond `2^20` per axis.
    pub fn default_options() -> GridOptions {
        GridOptions {
            cells_per_triangle: HASH_CELLS_PER_TRIANGLE,
            max_cells: u32::MAX,
            ..GridOptions::default()
        }
    }

    /// Builds the hash grid. `options` size the cells as for the dense grid, but `max_cells`
    /// may be far larger (only non-empty cells are stored). An empty mesh gives a grid every
    /// ray misses.
    pub fn build(mesh: impl Into<Arc<Mesh>>, options: &GridOptions) -> Result<Self, BuildError> {
        options.validate()?;
        let mesh = mesh.into();
        let (live, boxes, bounds) = live_triangles(&mesh)?;
        if live.is_empty() {
            return Ok(Self {
                mesh,
                planes: grid_planes(&Aabb::new(bounds.min, bounds.min), [1; 3]),
                dims: [1; 3],
                table: CellTable::default(),
                words: Vec::new(),
                coarse: Coarse::default(),
            });
        }
        let shape = cell_shape(&mesh, &live, options);
        let mut dims = resolution(&bounds, live.len(), shape, options).map(|d| d.min(MAX_SLABS));
        // (Each cell adds at most CULL_WORDS words to its references: all fit in `u32` offsets.)
        let max_words = u64::from(u32::MAX) / (CULL_WORDS as u64 + 1);
        let max_refs = (REFERENCES_PER_TRIANGLE * live.len() as u64).min(max_words);
        loop {
            let planes = grid_planes(&bounds, dims);
            let blocks = blocks(&live, &boxes, &planes);
            let needed: u64 = blocks.iter().map(super::cells::block_cells).sum();
            if needed <= max_refs || dims == [1; 3] {
                let (table, words, cells) = fill(&planes, &live, &boxes, &blocks);
                return Ok(Self {
                    mesh,
                    planes,
                    dims,
                    table,
                    words,
                    coarse: Coarse::new(dims, &cells),
                });
            }
            let cells: u64 = dims.iter().map(|&d| u64::from(d)).product();
            dims = cap(dims, (cells / 2).clamp(1, u64::from(u32::MAX)) as u32);
        }
    }

    /// The mesh the grid was built over; triangle ids refer to it.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Cells along x, y and z (most of them empty and not stored).
    pub fn resolution(&self) -> [u32; 3] {
        self.dims
    }

    /// Non-empty cells (the only ones stored).
    pub fn stored_cells(&self) -> usize {
        self.table.len()
    }

    /// Triangle references stored in the cells.
    pub fn reference_count(&self) -> usize {
        self.words.len() - CULL_WORDS * self.table.len()
    }
}

/// The table, the word array (each non-empty cell's cull box, then its references) and the
/// non-empty cells: every (cell, reference) pair sorted by cell, then reference, so that each
/// non-empty cell's references are one run. `boxes` are all triangles' boxes, by id.
fn fill(
    planes: &GridPlanes,
    live: &[u32],
    boxes: &[TriangleBox],
    blocks: &[Block],
) -> (CellTable, Vec<u32>, Vec<[u32; 3]>) {
    let dims = planes.each_ref().map(|p| p.slabs());
    let mut pairs: Vec<(u64, u32)> = Vec::new();
    for (&id, block) in live.iter().zip(blocks) {
        let r = reference(id, block);
        for_each_cell(block, |x, y, z| {
            pairs.push((linear_index(planes, [x, y, z]), r))
        });
    }
    pairs.sort_unstable();
    let cells = pairs.chunk_by(|a, b| a.0 == b.0).count();
    let mut table = CellTable::with_capacity(cells);
    let mut words = Vec::with_capacity(pairs.len() + CULL_WORDS * cells);
    let mut stored = Vec::with_capacity(cells);
    for run in pairs.chunk_by(|a, b| a.0 == b.0) {
        let key = run[0].0;
        let cell = cell_of(dims, key);
        let triangle_box = |p: &(u64, u32)| boxes[(p.1 & !SHARED) as usize];
        table.insert(key, words.len() as u32, (CULL_WORDS + run.len()) as u32);
        words.extend(cull_words(planes, cell, run.iter().map(triangle_box)));
        words.extend(run.iter().map(|p| p.1));
        stored.push(cell);
    }
    (table, words, stored)
}

impl Accel for SpatialHash {
    type Scratch = GridScratch;
    const GROUP_BY_OCTANT: bool = false;

    fn trace<K: TriangleTest, V: Visitor>(
        &self,
        ray: &PreparedRay,
        id: u32,
        scratch: &mut GridScratch,
        visitor: &mut V,
    ) -> f32 {
        let mailbox = &mut scratch.mailbox;
        let mut tmax = ray.tmax;
        if self.words.is_empty() {
            return tmax;
        }
        mailbox.next_ray();
        let slab = SlabRay::new(ray);
        walk(&self.planes, ray, &mut tmax, |cell, tmax| {
            visitor.enter_node(id);
            if !self.coarse.may_hold(cell.slabs) {
                return;
            }
            let (first, count) = self.table.get(cell.index);
            let words = &self.words[first as usize..(first + count) as usize];
            if let Some(refs) = cull::refs_to_test(words, &slab, *tmax) {
                test_cell::<K, V>(&self.mesh, refs, ray, id, mailbox, tmax, visitor);
            }
        });
        tmax
    }

    /// One ray at a time, in Morton order of their origins (`crate::traverse::origin_order`).
    fn trace_stream<K: TriangleTest, V: Visitor>(
        &self,
        stream: &mut RayStream<'_>,
        scratch: &mut GridScratch,
        visitor: &mut V,
    ) {
        let grid = (&bounds(&self.planes), &*self.mesh);
        origin_order::trace_stream::<_, K, V>(self, grid, stream, scratch, visitor);
    }
}

crate::query::compiled_queries!(SpatialHash);

impl crate::accel::Corners for SpatialHash {
    fn corners(&self, id: u32) -> [glam::Vec3; 3] {
        self.mesh().triangle(id)
    }
}

impl Footprint for SpatialHash {
    fn name(&self) -> &'static str {
        "hash"
    }

    fn triangle_count(&self) -> usize {
        self.mesh.triangle_count()
    }

    fn node_count(&self) -> usize {
        self.table.len()
    }

    fn heap_bytes(&self) -> usize {
        self.table.heap_bytes()
            + self.coarse.heap_bytes()
            + self.words.len() * size_of::<u32>()
            + self.planes.iter().map(|p| p.heap_bytes()).sum::<usize>()
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::grid::UniformGrid;

    /// Two small triangles at opposite corners of a large box: almost every cell is empty.
    fn sparse_mesh() -> Mesh {
        let v = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(99.0, 99.0, 100.0),
            Vec3::new(100.0, 99.0, 100.0),
            Vec3::new(100.0, 100.0, 100.0),
        ];
        Mesh::new(v, vec![[0, 1, 2], [3, 4, 5]]).unwrap()
    }

    #[test]
    fn only_non_empty_cells_are_stored() {
        let options = GridOptions {
            resolution: Some([50, 50, 50]),
            ..SpatialHash::default_options()
        };
        let hash = SpatialHash::build(sparse_mesh(), &options).unwrap();
        assert_eq!(hash.resolution(), [50, 50, 50]);
        // Each triangle's box lies within one cell of 2 x 2 x 2 units.
        assert_eq!(hash.stored_cells(), 2);
        assert_eq!(hash.reference_count(), 2);
        let dense = UniformGrid::build(sparse_mesh(), &options).unwrap();
        // The dense grid pays 1.5 bits per cell, empty or not (its occupancy bits and their
        // running counts: 24 KB here); the hash pays for its two stored cells only.
        assert!(hash.heap_bytes() * 20 < dense.heap_bytes());
    }
}
