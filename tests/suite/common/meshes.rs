//! Meshes shared by several test files: the icosphere (closed, shared vertices), transformed
//! copies, icospheres with duplicate triangles (ties), small hand-written meshes, the Stanford
//! bunny; and checks on them (edges, closed and outward).

use std::collections::HashMap;

use glam::{DVec3, Vec3};
use raybatch::Mesh;

/// Vertices and triangles of an icosphere of radius 1 centred on the origin: an icosahedron
/// whose faces are split in four `subdivisions` times, midpoints pushed onto the sphere. Shared
/// vertices (every edge midpoint is created once), closed, every face wound counter-clockwise
/// seen from outside.
pub fn icosphere_parts(subdivisions: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5.0f64.sqrt()) / 2.0;
    let mut verts: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
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
        let mut midpoint = |a: u32, b: u32, verts: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                let m = ((verts[a as usize] + verts[b as usize]) * 0.5).normalize();
                verts.push(m);
                (verts.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let ab = midpoint(a, b, &mut verts);
            let bc = midpoint(b, c, &mut verts);
            let ca = midpoint(c, a, &mut verts);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let verts = verts.iter().map(|v| v.as_vec3()).collect();
    (verts, faces)
}

/// The unit icosphere as a [`Mesh`] (see [`icosphere_parts`]).
pub fn icosphere(subdivisions: u32) -> Mesh {
    let (v, t) = icosphere_parts(subdivisions);
    Mesh::new(v, t).expect("icosphere is a valid mesh")
}

/// `mesh` with every vertex mapped to `v * scale + offset` (computed in f64, rounded once).
pub fn transformed(mesh: &Mesh, scale: f64, offset: DVec3) -> Mesh {
    let v = mesh
        .vertices()
        .iter()
        .map(|v| (v.as_dvec3() * scale + offset).as_vec3())
        .collect();
    Mesh::new(v, mesh.triangles().to_vec()).expect("transformed mesh is valid")
}

/// Every undirected edge `(min, max)` of the mesh, once.
pub fn edges(mesh: &Mesh) -> Vec<(u32, u32)> {
    let mut seen = std::collections::BTreeSet::new();
    for &[a, b, c] in mesh.triangles() {
        for (p, q) in [(a, b), (b, c), (c, a)] {
            seen.insert((p.min(q), p.max(q)));
        }
    }
    seen.into_iter().collect()
}

/// Panics unless every directed edge appears exactly once and its reverse exactly once (closed,
/// manifold, consistently wound) and every face normal points away from `center`.
pub fn assert_closed_and_outward(mesh: &Mesh, center: Vec3) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for &[a, b, c] in mesh.triangles() {
        for e in [(a, b), (b, c), (c, a)] {
            *directed.entry(e).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "directed edge {a}->{b} used {n} times");
        assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
    }
    for id in 0..mesh.triangle_count() as u32 {
        let [a, b, c] = mesh.triangle(id).map(|p| p.as_dvec3());
        let n = (b - a).cross(c - a);
        let centroid = (a + b + c) / 3.0;
        assert!(
            n.dot(centroid - center.as_dvec3()) > 0.0,
            "triangle {id} faces inward"
        );
    }
}

/// A mesh from literal vertex coordinates and triangles.
pub fn tri_mesh(vertices: &[[f32; 3]], triangles: &[[u32; 3]]) -> Mesh {
    Mesh::new(
        vertices.iter().map(|&v| Vec3::from_array(v)).collect(),
        triangles.to_vec(),
    )
    .unwrap()
}

/// The unit icosphere with extra copies of some of its triangles: exact duplicates inserted at
/// low and high ids (ties broken by id), plus rotated and flipped copies (same plane).
pub fn icosphere_with_duplicates(subdivisions: u32) -> Mesh {
    let (v, t) = icosphere_parts(subdivisions);
    let mut tris = t.clone();
    for (k, &[a, b, c]) in t.iter().enumerate().step_by(3) {
        let at = (k * 37) % (tris.len() + 1);
        match k % 4 {
            0 => tris.insert(at, [a, b, c]),
            1 => tris.push([a, b, c]),
            2 => tris.insert(at, [b, c, a]),
            _ => tris.insert(at, [a, c, b]),
        }
    }
    Mesh::new(v, tris).unwrap()
}

/// The unit icosphere, every triangle present twice (ids `k` and `2n - 1 - k`) plus a third
/// copy of every fifth triangle at the front: every hit is a tie between exact duplicates.
pub fn icosphere_all_duplicated(subdivisions: u32) -> Mesh {
    let (v, t) = icosphere_parts(subdivisions);
    let mut tris: Vec<[u32; 3]> = t.iter().step_by(5).copied().collect();
    tris.extend(t.iter().copied());
    tris.extend(t.iter().rev().copied());
    Mesh::new(v, tris).unwrap()
}

/// Triangles of the Stanford bunny in `data/stanford-bunny.obj` (the mesh the built-in `bunny`
/// scene of the tools crate loads).
pub const BUNNY_TRIANGLES: usize = 69_451;

/// The Stanford bunny, read from the workspace's `data/` folder.
pub fn bunny() -> Mesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/stanford-bunny.obj");
    let mesh = Mesh::load_obj(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    assert_eq!(mesh.triangle_count(), BUNNY_TRIANGLES, "{path}");
    mesh
}
