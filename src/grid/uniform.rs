//! [`UniformGrid`]: cells over the mesh's bounds, every cell stored (an offset each).

use std::sync::Arc;

use crate::accel::{Accel, Footprint, RayStream};
use crate::bvh::BuildError;
use crate::geom::aabb::SlabRay;
use crate::geom::{Aabb, PreparedRay, TriangleTest};
use crate::hit::Visitor;
use crate::mesh::Mesh;
use crate::traverse::single::test_triangles;

use super::cells::{Cells, TriangleBox, blocks, grid_planes, triangle_boxes};
use super::mailbox::{Mailbox, SHARED};
use super::scratch::GridScratch;
use super::sizing::{GridOptions, cap, cell_shape, resolution};
use super::walk::{GridPlanes, bounds, walk};
use crate::traverse::origin_order;

/// The one-ray walk tests a stored cell this many stored cells after meeting it, and
/// prefetches its cull box when it meets it: a short ray on the 1M-triangle terrain meets
/// about four stored cells, each cull box a likely cache miss (the walk's largest stall,
/// `perf`), and taken one after the other they could not overlap. With 4, the grid's short
/// rays on the terrain went from 0.87x the AABB tree's speed per ray to about 0.93x (8 did no
/// better; docs/benchmarks.md).
///
/// Exact: the walk runs ahead with the range end of the last test, never shorter than the
/// current one, so it meets every cell the plain walk would (and a few more); each cell is
/// then tested in walk order with the current range end, as the plain walk would test it. A
/// cell the plain walk would not reach is entered beyond that range end, and so is its cull
/// box, which lies inside it: the cull test lets nothing through (a ray that is done has
/// range end `-inf`, which no box passes).
const LOOKAHEAD: usize = 4;

/// A triangle is stored at most this many times on average; a finer grid is coarsened until
/// it fits (large triangles in a fine grid would otherwise fill memory).
const REFERENCES_PER_TRIANGLE: u64 = 16;

/// A uniform grid over a mesh: cells of one size, each holding
/// the triangles whose boxes overlap it, walked front to back by an exact 3D-DDA.
#[derive(Clone, Debug)]
pub struct UniformGrid {
    mesh: Arc<Mesh>,
    planes: GridPlanes,
    cells: Cells,
}

impl UniformGrid {
    /// Builds the grid. An empty mesh (or one of degenerate triangles only) gives a grid every
    /// ray misses; a mesh of more than `2^31 - 1` triangles is too large (cell references
    /// keep one bit for the mailbox).
    pub fn build(mesh: impl Into<Arc<Mesh>>, options: &GridOptions) -> Result<Self, BuildError> {
        options.validate()?;
        let mesh = mesh.into();
        let (live, boxes, bounds) = live_triangles(&mesh)?;
        if live.is_empty() {
            let planes = grid_planes(&Aabb::new(bounds.min, bounds.min), [1; 3]);
            return Ok(Self {
                mesh,
                planes,
                cells: Cells::default(),
            });
        }
        let shape = cell_shape(&mesh, &live, options);
        let mut dims = resolution(&bounds, live.len(), shape, options);
        let max_refs = REFERENCES_PER_TRIANGLE * live.len() as u64;
        loop {
            let planes = grid_planes(&bounds, dims);
            let blocks = blocks(&live, &boxes, &planes);
            match Cells::build(&planes, &live, &boxes, &blocks, max_refs) {
                Ok(cells) => {
                    return Ok(Self {
                        mesh,
                        planes,
                        cells,
                    });
                }
                // One cell needs exactly one reference per triangle: this ends.
                Err(_) => dims = cap(dims, (cell_count(dims) / 2).max(1) as u32),
            }
        }
    }

    /// The mesh the grid was built over; triangle ids refer to it.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Cells along x, y and z.
    pub fn resolution(&self) -> [u32; 3] {
        self.planes.each_ref().map(|p| p.slabs())
    }

    /// Triangle references stored in the cells (a triangle counts once per cell).
    pub fn reference_count(&self) -> usize {
        self.cells.reference_count()
    }
}

/// Cells of a `dims` grid.
fn cell_count(dims: [u32; 3]) -> u64 {
    dims.iter().map(|&d| u64::from(d)).product()
}

/// The ids of the non-degenerate triangles, the box of every triangle (by id) and the box
/// around the non-degenerate ones (empty if none); fails if the ids do not leave the mailbox
/// bit free.
pub(crate) fn live_triangles(
    mesh: &Mesh,
) -> Result<(Vec<u32>, Vec<TriangleBox>, Aabb), BuildError> {
    let max = SHARED as usize - 1;
    if mesh.triangle_count() > max {
        return Err(BuildError::TooLarge {
            format: "grid (31-bit triangle references)",
            needed: mesh.triangle_count(),
            max,
        });
    }
    let live: Vec<u32> = (0..mesh.triangle_count() as u32)
        .filter(|&id| !mesh.is_degenerate(id))
        .collect();
    let boxes = triangle_boxes(mesh);
    let bounds = live.iter().fold(Aabb::EMPTY, |b, &id| {
        let (min, max) = boxes[id as usize];
        b.union(Aabb::new(min, max))
    });
    Ok((live, boxes, bounds))
}

/// Tests the triangles of one cell's references `refs` that the ray has not met yet; true if
/// the visitor ended the ray. Shared by the dense and the sparse grid.
///
/// Not inlined: the walk's loop (and its cheap test for an empty cell) stays small enough
/// that its state lives in registers across the cells that need no test (measured with
/// callgrind on the terrain: inlined, every cell paid for spilling and reloading it).
#[inline(never)]
pub(crate) fn test_cell<K: TriangleTest, V: Visitor>(
    mesh: &Mesh,
    refs: &[u32],
    ray: &PreparedRay,
    id: u32,
    mailbox: &mut Mailbox,
    tmax: &mut f32,
    visitor: &mut V,
) -> bool {
    prefetch_triangles(mesh, refs);
    let triangles = refs.iter().filter(|&&r| mailbox.first_visit(r)).map(|&r| {
        let triangle = r & !SHARED;
        (triangle, mesh.triangle(triangle))
    });
    test_triangles::<K, V>(ray, id, triangles, tmax, visitor)
}

/// Prefetches the vertex indices of the triangles of `refs`, then their corners: a cell's
/// triangles lie anywhere in a large mesh, and tested one after the other each is a chain of
/// two misses (indices, then corners) that the next one's cannot overlap.
#[inline(always)]
fn prefetch_triangles(mesh: &Mesh, refs: &[u32]) {
    let ids = refs.iter().map(|&r| r & !SHARED);
    ids.clone().for_each(|id| mesh.prefetch_indices(id));
    ids.for_each(|id| mesh.prefetch_corners(&mesh.triangles()[id as usize]));
}

impl Accel for UniformGrid {
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
        if self.cells.is_empty() {
            return tmax;
        }
        mailbox.next_ray();
        let slab = SlabRay::new(ray);
        // A stored cell is tested LOOKAHEAD stored cells after the walk met it (see
        // `LOOKAHEAD`), with the range end of that moment.
        let test =
            |(rank, slabs): (usize, [u32; 3]), tmax: &mut f32, mailbox: &mut _, visitor: &mut V| {
                let cell = (&self.planes, slabs);
                if let Some(refs) = self.cells.refs_to_test(rank, cell, &slab, *tmax) {
                    test_cell::<K, V>(&self.mesh, refs, ray, id, mailbox, tmax, visitor);
                }
            };
        let mut queue = [(0usize, [0u32; 3]); LOOKAHEAD];
        let (mut head, mut len) = (0, 0);
        walk(&self.planes, ray, &mut tmax, |cell, tmax| {
            visitor.enter_node(id);
            let Some(rank) = self.cells.rank_of(cell.index as usize) else {
                return;
            };
            self.cells.prefetch_cull(rank);
            if len == LOOKAHEAD {
                test(queue[head], tmax, mailbox, visitor);
                (head, len) = ((head + 1) % LOOKAHEAD, len - 1);
            }
            queue[(head + len) % LOOKAHEAD] = (rank, cell.slabs);
            len += 1;
        });
        for k in 0..len {
            test(queue[(head + k) % LOOKAHEAD], &mut tmax, mailbox, visitor);
        }
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

crate::query::compiled_queries!(UniformGrid);

impl crate::accel::Corners for UniformGrid {
    fn corners(&self, id: u32) -> [glam::Vec3; 3] {
        self.mesh().triangle(id)
    }
}

impl Footprint for UniformGrid {
    fn name(&self) -> &'static str {
        "grid"
    }

    fn triangle_count(&self) -> usize {
        self.mesh.triangle_count()
    }

    fn node_count(&self) -> usize {
        self.cells.len()
    }

    fn heap_bytes(&self) -> usize {
        self.cells.heap_bytes() + self.planes.iter().map(|p| p.heap_bytes()).sum::<usize>()
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::geom::Kernel;
    use crate::geom::Ray;
    use crate::grid::SpatialHash;
    use crate::hit::Hit;
    use crate::query::RayQueries;
    use crate::query::brute_force;

    /// A large triangle across every cell of a 10 x 10 x 1 grid, and 100 small ones.
    fn spanning_mesh() -> Mesh {
        let mut v = vec![
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(30.0, -1.0, 0.5),
            Vec3::new(-1.0, 30.0, 0.5),
        ];
        let mut t = vec![[0, 1, 2]];
        for i in 0..100u32 {
            let o = Vec3::new((i % 10) as f32, (i / 10) as f32, 0.25);
            v.extend([o, o + Vec3::X * 0.5, o + Vec3::Y * 0.5]);
            t.push([3 * i + 3, 3 * i + 4, 3 * i + 5]);
        }
        Mesh::new(v, t).unwrap()
    }

    /// A bumpy height field of 2 x 16 x 16 triangles on a lattice of quarter units, so that
    /// cull-box faces, cell planes and triangle edges coincide often.
    fn lattice_terrain() -> Mesh {
        let height = |x: u32, z: u32| ((x * 7 + z * 3) % 5) as f32 * 0.25;
        let mut v = Vec::new();
        for z in 0..=16 {
            for x in 0..=16 {
                v.push(Vec3::new(x as f32 * 0.5, height(x, z), z as f32 * 0.5));
            }
        }
        let mut t = Vec::new();
        for z in 0..16u32 {
            for x in 0..16u32 {
                let i = z * 17 + x;
                t.extend([[i, i + 1, i + 17], [i + 1, i + 18, i + 17]]);
            }
        }
        Mesh::new(v, t).unwrap()
    }

    #[test]
    fn cull_boxes_lose_no_hit_on_lattice_rays() {
        let mesh = Arc::new(lattice_terrain());
        let mut rng = crate::test_support::TestRng::new(5);
        let mut hits = 0;
        for resolution in [None, Some([5, 3, 7]), Some([16, 1, 16])] {
            let options = GridOptions {
                resolution,
                ..GridOptions::default()
            };
            let grid = UniformGrid::build(mesh.clone(), &options).unwrap();
            let hash = SpatialHash::build(mesh.clone(), &options).unwrap();
            for _ in 0..400 {
                // Origins and directions on a quarter-unit lattice: rays along planes, through
                // edges and vertices, short and long.
                let o = (rng.vec3(5.0) * 4.0).round() * 0.25 + Vec3::new(4.0, 0.5, 4.0);
                let d = (rng.vec3(2.0) * 2.0).round() * 0.5;
                let ray = Ray::with_range(o, d, 0.0, rng.range(0.25, 12.0));
                if !ray.is_valid() {
                    continue;
                }
                let want = brute_force::cast_ray(&mesh, &ray, Kernel::Watertight);
                hits += usize::from(want.is_some());
                let bits = |h: Option<Hit>| h.map(|h| (h.triangle, h.t.to_bits()));
                assert_eq!(bits(grid.cast_ray(&ray)), bits(want), "grid {ray:?}");
                assert_eq!(bits(hash.cast_ray(&ray)), bits(want), "hash {ray:?}");
                let mut all = brute_force::all_hits(&mesh, &ray, Kernel::Watertight);
                Hit::sort(&mut all);
                let mut got = grid.all_hits(&ray);
                Hit::sort(&mut got);
                assert_eq!(got, all, "grid all hits {ray:?}");
            }
        }
        assert!(
            hits > 150,
            "only {hits} rays hit: the test would prove little"
        );
    }

    #[test]
    fn a_triangle_in_many_cells_is_reported_once() {
        let mesh = Arc::new(spanning_mesh());
        let options = GridOptions {
            resolution: Some([10, 10, 1]),
            ..GridOptions::default()
        };
        let grid = UniformGrid::build(mesh.clone(), &options).unwrap();
        let hash = SpatialHash::build(mesh.clone(), &options).unwrap();
        assert!(grid.reference_count() > 100 + 50);
        // Rays grazing along the big triangle's plane and across it, through many cells.
        for ray in [
            Ray::new(Vec3::new(-2.0, 0.3, 0.5), Vec3::new(1.0, 0.37, 0.0)),
            Ray::new(Vec3::new(-2.0, -2.0, 3.0), Vec3::new(1.0, 1.0, -0.25)),
            Ray::new(Vec3::new(5.0, 5.0, 0.5), Vec3::X),
        ] {
            let mut want = brute_force::all_hits(&mesh, &ray, Kernel::Watertight);
            Hit::sort(&mut want);
            for (name, mut got) in [("grid", grid.all_hits(&ray)), ("hash", hash.all_hits(&ray))] {
                Hit::sort(&mut got);
                assert_eq!(got, want, "{name} {ray:?}");
            }
        }
    }
}
