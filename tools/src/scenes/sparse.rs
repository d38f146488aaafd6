//! The sparse open world: small clusters of rocks scattered over a huge, empty volume.
//!
//! It is the spatial hash's home ground and a dense grid's worst case: the bounds are vast
//! (10 km across), the geometry occupies a tiny fraction of them (clusters 60 units wide), so
//! almost every cell of a grid over the bounds is empty, and a grid fine enough for the rocks
//! stores billions of empty cells unless only the non-empty ones are kept.

use raybatch::Mesh;
use raybatch::glam::Vec3;

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
            rock(&mut vertices, &mut triangles, at - half, at + half);
        }
    }
    Mesh::new(vertices, triangles).expect("a generated world is always a valid mesh")
}

/// Appends the 12 triangles of the box `[min, max]`.
fn rock(vertices: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>, min: Vec3, max: Vec3) {
    let base = vertices.len() as u32;
    for i in 0..8 {
        let pick = |bit: u32, lo: f32, hi: f32| if i & bit == 0 { lo } else { hi };
        vertices.push(Vec3::new(
            pick(1, min.x, max.x),
            pick(2, min.y, max.y),
            pick(4, min.z, max.z),
        ));
    }
    const FACES: [[u32; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for [a, b, c, d] in FACES {
        triangles.push([base + a, base + b, base + c]);
        triangles.push([base + a, base + c, base + d]);
    }
}
