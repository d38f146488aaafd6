//! Closed meshes and rays that must hit them: what the leak rate is measured on.
//!
//! Three closed meshes (every edge shared by exactly two triangles): an icosphere, the same
//! with every vertex's radius jittered (uneven, non-convex facets), and an icosphere of radius
//! 1 placed 10,000 units from the origin, where `f32` spacing is about 1e-3 and rounding is
//! worst. The rays start inside (within 0.9 of the distance from the centre to the nearest face
//! plane) and are aimed exactly at vertices and edge midpoints, as `tests/suite/watertight.rs`
//! does, so each must hit; a miss is a leak.

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
    /// A lower bound of the distance from the centre to the surface (the nearest face plane;
    /// about 0.99 on the icospheres, 0.18 on the jittered one, whose facets tilt):
    /// every point closer to the centre is inside.
    pub inner_radius: f32,
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
    let closed = |name, v, center| {
        let mesh = Mesh::new(v, triangles.clone()).expect("an icosphere is a valid mesh");
        let inner_radius = inner_radius(&mesh, center);
        ClosedMesh {
            name,
            mesh,
            center,
            inner_radius,
        }
    };
    vec![
        closed("icosphere", vertices.clone(), Vec3::ZERO),
        closed("jittered", jittered, Vec3::ZERO),
        closed("far", far, center),
    ]
}

/// The distance from `center` to the nearest face plane of `mesh` (star-shaped around it).
fn inner_radius(mesh: &Mesh, center: Vec3) -> f32 {
    (0..mesh.triangle_count() as u32)
        .map(|id| {
            let [a, b, c] = mesh.triangle(id).map(|v| (v - center).as_dvec3());
            (b - a).cross(c - a).normalize().dot(a).abs()
        })
        .fold(f64::INFINITY, f64::min) as f32
}

/// `count` rays from inside `closed` (within 0.9 of its inner radius of the centre, so that
/// every origin is inside: an origin outside could graze a vertex and rightly miss) aimed at
/// its vertices (half) and edge midpoints (half).
pub fn aimed_rays(closed: &ClosedMesh, count: usize, seed: u64) -> Vec<Ray> {
    let (vertices, triangles) = (closed.mesh.vertices(), closed.mesh.triangles());
    let mut rng = SplitMix64::new(seed);
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count {
        let reach = 0.9 * closed.inner_radius;
        let origin = closed.center + rng.unit_vector() * rng.range_f32(0.0, reach);
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
            assert!(
                (0.1..1.0).contains(&closed.inner_radius),
                "{}",
                closed.inner_radius
            );
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
