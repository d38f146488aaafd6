//! Worlds of many meshes for the scene benchmarks, in the style of PEEL's
//! "SceneRaycastVsStaticMeshes" cases: thousands of small meshes (a terrain cut into
//! tiles, each tile its own mesh and tree), a few large ones, and small props (crates, rocks)
//! placed with rotations, as a game's world holds them.
//!
//! A [`World`] is plain data (meshes and instance placements); [`World::build`] turns it into a
//! [`raybatch::Scene`] with a chosen tree kind. [`world_rays`] generates the PEEL ray kinds:
//! short, long and vertical.

use std::collections::HashMap;

use raybatch::glam::{Quat, Vec3};
use raybatch::scene::{InstanceDesc, Rigid, Scene, SceneError};
use raybatch::{Aabb, AccelKind, BuildOptions, Mesh, Ray};
use rayon::prelude::*;

use super::rng::SplitMix64;
use super::{city, terrain};

/// Meshes and where their instances sit.
#[derive(Clone, Debug)]
pub struct World {
    /// What the bench calls it.
    pub name: &'static str,
    /// The distinct meshes, in their own (mesh) space.
    pub meshes: Vec<Mesh>,
    /// The instances.
    pub instances: Vec<InstanceDesc>,
}

impl World {
    /// The scene: every mesh built as `kind` (in parallel), placed as the instances say.
    pub fn build(&self, kind: AccelKind) -> Result<Scene, SceneError> {
        let trees = self
            .meshes
            .par_iter()
            .map(|m| kind.build(m.clone(), &BuildOptions::default()))
            .collect::<Result<Vec<_>, _>>()?;
        Scene::new(trees, &self.instances)
    }

    /// Triangles over all instances.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].triangle_count())
            .sum()
    }

    /// The world-space box of every instance's mesh (rounded, for placing rays).
    pub fn bounds(&self) -> Aabb {
        let mut out = Aabb::EMPTY;
        for i in &self.instances {
            let m = self.meshes[i.mesh].bounds();
            if m.is_empty() {
                continue;
            }
            for corner in m.corners() {
                out = out.grow(i.transform.point_to_world(corner));
            }
        }
        out
    }
}

/// `mesh` cut into `tiles_per_side^2` meshes by triangle centre over its `x`, `z` bounds,
/// each in its own space (its tile's corner at the origin) and placed back by a translation.
pub fn split_into_tiles(name: &'static str, mesh: &Mesh, tiles_per_side: u32) -> World {
    let n = tiles_per_side.max(1) as usize;
    let b = mesh.bounds();
    let size = (b.extent() / n as f32).max(Vec3::splat(f32::MIN_POSITIVE));
    let tile_of = |p: Vec3| {
        let i = (((p.x - b.min.x) / size.x) as usize).min(n - 1);
        let j = (((p.z - b.min.z) / size.z) as usize).min(n - 1);
        j * n + i
    };
    let mut tiles: Vec<Vec<u32>> = vec![Vec::new(); n * n];
    for id in 0..mesh.triangle_count() as u32 {
        let [a, c, d] = mesh.triangle(id);
        tiles[tile_of((a + c + d) / 3.0)].push(id);
    }
    let mut world = World {
        name,
        meshes: Vec::new(),
        instances: Vec::new(),
    };
    for (index, ids) in tiles.iter().enumerate() {
        if ids.is_empty() {
            continue;
        }
        let (i, j) = ((index % n) as f32, (index / n) as f32);
        let corner = Vec3::new(b.min.x + i * size.x, 0.0, b.min.z + j * size.z);
        world.meshes.push(submesh(mesh, ids, corner));
        let at = Rigid::from_translation(corner).expect("tile corners are finite");
        world
            .instances
            .push(InstanceDesc::new(world.meshes.len() - 1, at));
    }
    world
}

/// The triangles `ids` of `mesh` as a mesh of their own, moved by `-origin`.
fn submesh(mesh: &Mesh, ids: &[u32], origin: Vec3) -> Mesh {
    let mut remap = HashMap::new();
    let mut vertices = Vec::new();
    let triangles = ids
        .iter()
        .map(|&id| {
            mesh.triangles()[id as usize].map(|v| {
                *remap.entry(v).or_insert_with(|| {
                    vertices.push(mesh.vertices()[v as usize] - origin);
                    vertices.len() as u32 - 1
                })
            })
        })
        .collect();
    Mesh::new(vertices, triangles).expect("a part of a valid mesh is valid")
}

/// The PEEL-style scene of many small meshes: the terrain cut into `tiles_per_side^2` tiles of
/// `cells_per_tile^2` cells (two triangles each), every tile its own mesh.
pub fn tiles(tiles_per_side: u32, cells_per_tile: u32) -> World {
    let whole = terrain::mesh(tiles_per_side * cells_per_tile, 0x7e44_a1b0);
    split_into_tiles("tiles", &whole, tiles_per_side)
}

/// A few large meshes: the terrain of `terrain_cells^2` cells, and a city of `city_blocks^2`
/// blocks turned a quarter and set on a plateau beside it.
pub fn large(terrain_cells: u32, city_blocks: u32) -> World {
    let ground = terrain::mesh(terrain_cells, 0x7e44_a1b0);
    let town = city::mesh(city_blocks, 0xc1_7e5);
    let quarter = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let beside = Rigid::new(quarter, Vec3::new(1000.0, 0.0, 1000.0)).expect("rigid");
    World {
        name: "large",
        meshes: vec![ground, town],
        instances: vec![
            InstanceDesc::new(0, Rigid::IDENTITY),
            InstanceDesc::new(1, beside),
        ],
    }
}

/// A closed box of size `extent` with a corner at the origin (12 triangles).
pub fn crate_mesh(extent: Vec3) -> Mesh {
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    super::push_box(&mut vertices, &mut triangles, Aabb::new(Vec3::ZERO, extent));
    Mesh::new(vertices, triangles).expect("a box is a valid mesh")
}

/// `count` props (crates of 8 sizes) over `[0, size]^2` at ground level, each turned by a
/// random yaw: the small, rotated, moving meshes of a game.
pub fn props(count: usize, size: f32, seed: u64) -> World {
    let mut rng = SplitMix64::new(seed);
    let meshes = (0..8)
        .map(|i| crate_mesh(Vec3::new(1.0 + i as f32 * 0.5, 1.0 + (i % 3) as f32, 2.0)))
        .collect();
    let instances = (0..count)
        .map(|_| {
            let at = Vec3::new(rng.range_f32(0.0, size), 0.0, rng.range_f32(0.0, size));
            InstanceDesc::new(
                rng.below(8) as usize,
                yawed(rng.range_f32(0.0, std::f32::consts::TAU), at),
            )
        })
        .collect();
    World {
        name: "props",
        meshes,
        instances,
    }
}

/// A turn by `yaw` radians about `+y`, then a move to `at`.
pub fn yawed(yaw: f32, at: Vec3) -> Rigid {
    Rigid::new(Quat::from_rotation_y(yaw), at).expect("a yaw and a finite point are rigid")
}

/// The PEEL ray kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WorldRays {
    /// Random origins in the box, random directions, 1% of the box diagonal long.
    Short,
    /// Random origins in the box, random directions, unbounded.
    Long,
    /// Straight down from above the box at random `x`, `z`, unbounded.
    Vertical,
}

impl WorldRays {
    /// Every kind.
    pub const ALL: [WorldRays; 3] = [WorldRays::Short, WorldRays::Long, WorldRays::Vertical];

    /// The name in tables.
    pub fn name(self) -> &'static str {
        match self {
            WorldRays::Short => "short",
            WorldRays::Long => "long",
            WorldRays::Vertical => "vertical",
        }
    }
}

/// `count` rays of kind `kind` over `bounds`, reproducible from `seed`.
pub fn world_rays(kind: WorldRays, bounds: &Aabb, count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = SplitMix64::new(seed);
    let length = bounds.extent().length() * 0.01;
    (0..count)
        .map(|_| {
            let p = rng.point_in(bounds.min, bounds.max);
            match kind {
                WorldRays::Short => Ray::with_range(p, rng.unit_vector(), 0.0, length),
                WorldRays::Long => Ray::new(p, rng.unit_vector()),
                WorldRays::Vertical => {
                    Ray::new(Vec3::new(p.x, bounds.max.y + 1.0, p.z), Vec3::NEG_Y)
                }
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_keep_every_triangle() {
        let w = tiles(4, 3);
        assert_eq!(w.meshes.len(), 16);
        assert_eq!(w.triangle_count(), 2 * 12 * 12);
    }

    #[test]
    fn props_and_large_worlds_build() {
        let p = props(50, 100.0, 1);
        assert_eq!(p.instances.len(), 50);
        assert!(p.build(AccelKind::Aabb).is_ok());
        let l = large(8, 2);
        assert_eq!(l.instances.len(), 2);
        assert!(!l.bounds().is_empty());
    }
}
