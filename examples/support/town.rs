//! A small game town for the examples: square blocks of box buildings between streets, one
//! mesh per block (its ground tile and its buildings), and a crate mesh for vehicles. Every
//! triangle the examples trace comes from here; nothing is read from disk. Each example uses
//! part of it.
#![allow(dead_code)]

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use raybatch::Mesh;
use raybatch::glam::{Quat, Vec3};
use raybatch::scene::{InstanceDesc, Rigid};

/// Side of a block between streets, in metres.
pub const BLOCK: f32 = 80.0;
/// Width of a street.
pub const STREET: f32 = 20.0;
/// Distance between the starts of neighbouring blocks.
pub const PITCH: f32 = BLOCK + STREET;
/// Height of an agent's eyes and of a sound source.
pub const EYE: f32 = 1.7;

/// Meshes (in their own space) and the instances that place them.
pub struct Town {
    /// One mesh per block, then the crate mesh.
    pub meshes: Vec<Mesh>,
    /// One instance per block (at the identity), then the vehicles.
    pub instances: Vec<InstanceDesc>,
    /// The index of the first vehicle instance.
    pub first_vehicle: usize,
    /// Blocks per side.
    pub blocks: usize,
}

impl Town {
    /// `blocks` x `blocks` blocks and `vehicles` crates parked in the streets.
    pub fn new(blocks: usize, vehicles: usize, seed: u64) -> Town {
        let mut rng = StdRng::seed_from_u64(seed);
        let mut meshes = Vec::new();
        for bz in 0..blocks {
            for bx in 0..blocks {
                meshes.push(block_mesh(&mut rng, blocks, bx, bz));
            }
        }
        let mut instances: Vec<InstanceDesc> = (0..meshes.len())
            .map(|m| InstanceDesc::new(m, Rigid::IDENTITY))
            .collect();
        let first_vehicle = instances.len();
        let crate_mesh = meshes.len();
        meshes.push(box_mesh(
            Vec3::new(-2.0, 0.0, -1.0),
            Vec3::new(2.0, 1.6, 1.0),
        ));
        let mut town = Town {
            meshes,
            instances: Vec::new(),
            first_vehicle,
            blocks,
        };
        for _ in 0..vehicles {
            // On wheels: the crate's bottom face stays clear of the ground's plane.
            let at = town.street_point(&mut rng) - Vec3::Y * (EYE - 0.3);
            let yaw = rng.random_range(0.0..std::f32::consts::TAU);
            instances.push(InstanceDesc::new(crate_mesh, yawed(yaw, at)));
        }
        town.instances = instances;
        town
    }

    /// Side of the town's square, streets around the edge included.
    pub fn size(&self) -> f32 {
        self.blocks as f32 * PITCH + STREET
    }

    /// A random point in a street at eye height: where agents stand and sounds play.
    pub fn street_point(&self, rng: &mut StdRng) -> Vec3 {
        let along = rng.random_range(0.0..self.size());
        let street = rng.random_range(0..=self.blocks) as f32 * PITCH;
        let across = street + rng.random_range(2.0..STREET - 2.0);
        if rng.random_bool(0.5) {
            Vec3::new(along, EYE, across)
        } else {
            Vec3::new(across, EYE, along)
        }
    }
}

/// A placement turned by `yaw` about the vertical axis.
pub fn yawed(yaw: f32, at: Vec3) -> Rigid {
    Rigid::new(Quat::from_rotation_y(yaw), at).expect("a yaw and a finite point are rigid")
}

/// Block `(bx, bz)`: its ground tile (the block and the streets on its low sides) as two
/// large triangles, and two to six buildings of 12 triangles each.
fn block_mesh(rng: &mut StdRng, blocks: usize, bx: usize, bz: usize) -> Mesh {
    let (x0, z0) = (bx as f32 * PITCH, bz as f32 * PITCH);
    // The last row and column also cover the street along the town's far edges.
    let edge = |k: usize| if k + 1 == blocks { STREET } else { 0.0 };
    let (x1, z1) = (x0 + PITCH + edge(bx), z0 + PITCH + edge(bz));
    let mut vertices = vec![
        Vec3::new(x0, 0.0, z0),
        Vec3::new(x1, 0.0, z0),
        Vec3::new(x1, 0.0, z1),
        Vec3::new(x0, 0.0, z1),
    ];
    let mut triangles = vec![[0, 2, 1], [0, 3, 2]];
    let lot = BLOCK / 2.0;
    for lz in 0..2 {
        for lx in 0..2 {
            if rng.random_bool(0.15) {
                continue; // a park: some sightlines cross the block
            }
            let min_x = x0 + STREET + lx as f32 * lot + rng.random_range(1.0..6.0);
            let min_z = z0 + STREET + lz as f32 * lot + rng.random_range(1.0..6.0);
            let max_x = x0 + STREET + (lx + 1) as f32 * lot - rng.random_range(1.0..6.0);
            let max_z = z0 + STREET + (lz + 1) as f32 * lot - rng.random_range(1.0..6.0);
            let height = rng.random_range(6.0..40.0);
            // Buildings start below the ground so that no face lies in the ground's plane.
            let b = box_mesh(
                Vec3::new(min_x, -1.0, min_z),
                Vec3::new(max_x, height, max_z),
            );
            let base = vertices.len() as u32;
            vertices.extend_from_slice(b.vertices());
            triangles.extend(b.triangles().iter().map(|t| t.map(|i| i + base)));
        }
    }
    Mesh::new(vertices, triangles).expect("a generated block is a valid mesh")
}

/// A closed box of 12 triangles, faces wound outwards.
pub fn box_mesh(min: Vec3, max: Vec3) -> Mesh {
    let corner = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let vertices = (0..8).map(corner).collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    Mesh::new(vertices, triangles).expect("a box is a valid mesh")
}
