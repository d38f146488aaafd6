//! Closed meshes and rays that must hit them: what the leak rate is measured on.
//!
//! Three closed meshes (every edge shared by exactly two triangles): an icosphere, the same
//! with every vertex's radius jittered (uneven, non-convex facets), and an icosphere of radius
//! 1 placed 10,000 units from the origin, where `f32` spacing is about 1e-3 and rounding is
//! worst. The rays start inside (within 0.9 of the centre) and are aimed exactly at vertices
//! and edge midpoints, as `raybatch/tests/watertight.rs` does, so each must hit; a miss is a
//! leak.

use std::collections::HashMap;

use raybatch::glam::Vec3;
use raybatch::{Mesh, Ray};

use super::SplitMix64;

/// A closed mesh and its centre (every ray starts near it).
pub struct ClosedMesh {
    /// `icosphere`, `jittered`, `far`.
    pub name: &'static str,
    /// The triangles.
    pub mesh: Mesh,
    /// The centre of the sphere.
    pub center: Vec3,
}

/// Subdivisions of the icospheres: 5,120 triangles.
const SUBDIVISIONS: u32 = 4;
/// Where the far sphere sits.
pub const FAR: f32 = 1e4;

/// The three closed meshes of the module docs.
pub fn closed_meshes() -> Vec<ClosedMesh> {
    let (vertices, triangles) = icosphere(SUBDIVISIONS);
    let mut rng = SplitMix64::new(0x1ea6);
    let jittered = vertices
        .iter()
        .map(|&v| v * rng.range_f32(0.85, 1.15))
        .collect();
    let center = Vec3::splat(FAR);
    let far = vertices.iter().map(|&v| v + center).collect();
    let mesh = |v| Mesh::new(v, triangles.clone()).expect("an icosphere is a valid mesh");
    vec![
        ClosedMesh {
            name: "icosphere",
            mesh: mesh(vertices.clone()),
            center: Vec3::ZERO,
        },
        ClosedMesh {
            name: "jittered",
            mesh: mesh(jittered),
            center: Vec3::ZERO,
        },
        ClosedMesh {
            name: "far",
            mesh: mesh(far),
            center,
        },
    ]
}

/// `count` rays from inside `closed` aimed at its vertices (half) and edge midpoints (half).
pub fn aimed_rays(closed: &ClosedMesh, count: usize, seed: u64) -> Vec<Ray> {
    let (vertices, triangles) = (closed.mesh.vertices(), closed.mesh.triangles());
    let mut rng = SplitMix64::new(seed);
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count {
        let origin = closed.center + rng.unit_vector() * rng.range_f32(0.0, 0.9);
        let tri = triangles[rng.below(triangles.len() as u64) as usize];
        let corner = rng.below(3) as usize;
        let a = vertices[tri[corner] as usize];
        let target = if rng.chance(0.5) {
            a
        } else {
            (a + vertices[tri[(corner + 1) % 3] as usize]) * 0.5
        };
        let ray = Ray::new(origin, target - origin);
        if ray.is_valid() {
            rays.push(ray);
        }
    }
    rays
}

/// A unit icosphere: the icosahedron with each triangle split in four `subdivisions` times,
/// shared midpoints (so it stays closed), every vertex pushed onto the sphere.
fn icosphere(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let p = (1.0 + 5f32.sqrt()) / 2.0;
    let mut vertices: Vec<Vec3> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = (vertices[a as usize] + vertices[b as usize]).normalize();
                vertices.push(m);
                vertices.len() as u32 - 1
            })
        };
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = midpoint(a, b, &mut vertices);
                let bc = midpoint(b, c, &mut vertices);
                let ca = midpoint(c, a, &mut vertices);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    (vertices, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshes_are_closed_and_rays_start_inside() {
        for closed in closed_meshes() {
            let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
            for t in closed.mesh.triangles() {
                for i in 0..3 {
                    let (a, b) = (t[i], t[(i + 1) % 3]);
                    *uses.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            assert!(
                uses.values().all(|&n| n == 2),
                "{} is not closed",
                closed.name
            );
            assert_eq!(closed.mesh.triangle_count(), 5_120);
            for ray in aimed_rays(&closed, 100, 1) {
                assert!(
                    (ray.origin - closed.center).length() < 0.91,
                    "{}",
                    closed.name
                );
            }
        }
    }
}
