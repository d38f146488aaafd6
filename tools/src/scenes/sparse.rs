//! The sparse open world: small clusters of rocks scattered over a huge, empty volume.
//!
//! It is the spatial hash's home ground and a dense grid's worst case: the bounds are vast
//! (10 km across), the geometry occupies a tiny fraction of them (clusters 60 units wide), so
//! almost every cell of a grid over the bounds is empty, and a grid fine enough for the rocks
//! stores billions of empty cells unless only the non-empty ones are kept.

use raybatch::glam::Vec3;
use raybatch::{Aabb, Mesh};

use super::push_box;
use super::rng::SplitMix64;

/// Side of the world along x and z.
const WORLD: f32 = 10_000.0;
/// Height of the world (clusters float at any height, like islands or asteroid fields).
const HEIGHT: f32 = 2_000.0;
/// Rocks per cluster.
const ROCKS: u32 = 40;
/// Rocks lie within this distance of their cluster's centre.
const CLUSTER_RADIUS: f32 = 30.0;

/// `clusters` clusters of [`ROCKS`] rocks (boxes of 12 triangles, 1 to 8 units per side).
pub(crate) fn mesh(clusters: u32, seed: u64) -> Mesh {
    let mut rng = SplitMix64::new(seed);
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for _ in 0..clusters {
        let centre = rng.point_in(Vec3::ZERO, Vec3::new(WORLD, HEIGHT, WORLD));
        for _ in 0..ROCKS {
            let at = centre + rng.unit_vector() * rng.range_f32(0.0, CLUSTER_RADIUS);
            let half = Vec3::new(
                rng.range_f32(0.5, 4.0),
                rng.range_f32(0.5, 4.0),
                rng.range_f32(0.5, 4.0),
            );
            push_box(
                &mut vertices,
                &mut triangles,
                Aabb::new(at - half, at + half),
            );
        }
    }
    Mesh::new(vertices, triangles).expect("a generated world is always a valid mesh")
}
