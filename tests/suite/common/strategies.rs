//! Proptest strategies: random triangle soups full of shared vertices, ties and degenerate
//! triangles, and random rays described relative to the mesh (resolved by [`RaySpec::resolve`]).

use glam::Vec3;
use proptest::prelude::*;
use proptest::sample::Index;
use raybatch::{Mesh, Ray};

use super::meshes::icosphere_parts;

/// A coordinate: mostly on a grid of quarters (exactly representable, so that many triangles
/// are coplanar, axis-aligned, share positions or edges exactly), sometimes arbitrary.
pub fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => (-8i32..=8).prop_map(|i| i as f32 * 0.25),
        2 => -2.0f32..2.0,
    ]
}

pub fn grid_coord() -> impl Strategy<Value = f32> {
    (-8i32..=8).prop_map(|i| i as f32 * 0.25)
}

pub fn vertex() -> impl Strategy<Value = Vec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A vertex on one of three planes `z = -0.5, 0, 0.5`: triangles on them are coplanar and
/// overlap, so rays see many equal or nearly equal `t`.
pub fn layered_vertex() -> impl Strategy<Value = Vec3> {
    (coord(), coord(), -1i32..=1).prop_map(|(x, y, z)| Vec3::new(x, y, z as f32 * 0.5))
}

/// How an extra triangle is derived from an existing one.
#[derive(Clone, Copy, Debug)]
pub enum Extra {
    /// Same three indices: an exact duplicate (same `t`, `u`, `v` bits).
    Duplicate,
    /// Same corners rotated (`b, c, a`): same plane, `t` may differ in the last bits.
    Rotated,
    /// Opposite winding (`a, c, b`).
    Flipped,
    /// Same positions through fresh vertex indices.
    CopiedVertices,
    /// Repeated index (`a, a, b`): degenerate.
    RepeatedIndex,
    /// `a, b, midpoint(a, b)`: zero area whenever the midpoint rounds onto the line.
    Collinear,
    /// `a, b, a`-like zero-area triangle with all corners at one point.
    Point,
}

pub fn extra() -> impl Strategy<Value = Extra> {
    prop_oneof![
        3 => Just(Extra::Duplicate),
        1 => Just(Extra::Rotated),
        1 => Just(Extra::Flipped),
        2 => Just(Extra::CopiedVertices),
        1 => Just(Extra::RepeatedIndex),
        1 => Just(Extra::Collinear),
        1 => Just(Extra::Point),
    ]
}

/// A random triangle soup: shared vertices, degenerate triangles, duplicated and coplanar
/// triangles (to force `t` ties), extras inserted at random ids.
pub fn mesh_strategy() -> impl Strategy<Value = Mesh> {
    let vertices = prop_oneof![
        2 => prop::collection::vec(vertex(), 3..32),
        1 => prop::collection::vec(layered_vertex(), 3..32),
    ];
    let base = prop_oneof![
        4 => Just(None),
        1 => (0u32..=1).prop_map(Some),
    ];
    (
        base,
        vertices,
        prop::collection::vec((any::<Index>(), any::<Index>(), any::<Index>()), 1..40),
        prop::collection::vec((any::<Index>(), extra(), any::<Index>()), 0..16),
    )
        .prop_map(|(base, mut vertices, tris, extras)| {
            let mut triangles: Vec<[u32; 3]> = Vec::new();
            if let Some(sub) = base {
                // A closed icosphere of radius 1.5 under the soup.
                let (v, t) = icosphere_parts(sub);
                let offset = vertices.len() as u32;
                vertices.extend(v.iter().map(|p| *p * 1.5));
                triangles.extend(t.iter().map(|tri| tri.map(|i| i + offset)));
            }
            let n = vertices.len();
            triangles.extend(
                tris.iter()
                    .map(|(a, b, c)| [a.index(n), b.index(n), c.index(n)].map(|i| i as u32)),
            );
            for (source, kind, at) in extras {
                let [a, b, c] = triangles[source.index(triangles.len())];
                let new = match kind {
                    Extra::Duplicate => [a, b, c],
                    Extra::Rotated => [b, c, a],
                    Extra::Flipped => [a, c, b],
                    Extra::CopiedVertices => {
                        let first = vertices.len() as u32;
                        for i in [a, b, c] {
                            vertices.push(vertices[i as usize]);
                        }
                        [first, first + 1, first + 2]
                    }
                    Extra::RepeatedIndex => [a, a, b],
                    Extra::Collinear => {
                        let m = (vertices[a as usize] + vertices[b as usize]) * 0.5;
                        vertices.push(m);
                        [a, b, vertices.len() as u32 - 1]
                    }
                    Extra::Point => {
                        let p = vertices[a as usize];
                        vertices.extend([p, p]);
                        let last = vertices.len() as u32;
                        [a, last - 2, last - 1]
                    }
                };
                let pos = at.index(triangles.len() + 1);
                triangles.insert(pos, new);
            }
            Mesh::new(vertices, triangles).expect("generated mesh is valid")
        })
}

/// Where a generated ray starts.
#[derive(Clone, Copy, Debug)]
pub enum OriginSpec {
    Point(Vec3),
    /// Exactly on a mesh vertex (on the surface).
    AtVertex(Index),
}

/// Where a generated ray points.
#[derive(Clone, Copy, Debug)]
pub enum DirSpec {
    /// Any direction, components possibly `+0`, `-0` or on the grid.
    Free(Vec3),
    /// Parallel to an axis, the two other components `+0` or `-0`.
    Axis {
        axis: usize,
        negative: bool,
        magnitude: f32,
        neg_zero: [bool; 2],
    },
    /// `dir = vertex - origin`.
    AtVertex(Index),
    /// `dir = (a + b) / 2 - origin` for an edge `(a, b)` of a triangle.
    AtEdgeMidpoint(Index, usize),
    /// `dir = p - origin`, `p` a point of a triangle given by barycentrics.
    AtTrianglePoint(Index, f32, f32),
}

/// The ray's range.
#[derive(Clone, Copy, Debug)]
pub enum RangeSpec {
    Unbounded,
    /// `[tmin, tmin + extra]`.
    Window(f32, f32),
    /// `[0, 1]`: a segment ending exactly at the target.
    Segment,
    /// `[1, inf]`: starting exactly at the target.
    FromTarget,
}

#[derive(Clone, Copy, Debug)]
pub struct RaySpec {
    pub origin: OriginSpec,
    pub dir: DirSpec,
    pub range: RangeSpec,
}

fn dir_component() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1.0f32..1.0,
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => grid_coord(),
    ]
}

pub fn origin_spec() -> impl Strategy<Value = OriginSpec> {
    prop_oneof![
        3 => (grid_coord(), grid_coord(), grid_coord())
            .prop_map(|(x, y, z)| OriginSpec::Point(Vec3::new(x, y, z) * 1.5)),
        3 => (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0)
            .prop_map(|(x, y, z)| OriginSpec::Point(Vec3::new(x, y, z))),
        1 => any::<Index>().prop_map(OriginSpec::AtVertex),
    ]
}

/// Directions aimed exactly at a vertex or an edge midpoint of the mesh.
pub fn aimed_dir_spec() -> impl Strategy<Value = DirSpec> {
    prop_oneof![
        3 => any::<Index>().prop_map(DirSpec::AtVertex),
        2 => (any::<Index>(), 0usize..3).prop_map(|(i, e)| DirSpec::AtEdgeMidpoint(i, e)),
    ]
}

pub fn dir_spec() -> impl Strategy<Value = DirSpec> {
    prop_oneof![
        3 => (dir_component(), dir_component(), dir_component())
            .prop_map(|(x, y, z)| DirSpec::Free(Vec3::new(x, y, z))),
        2 => (
            0usize..3,
            any::<bool>(),
            prop_oneof![Just(1.0f32), 0.01f32..100.0],
            any::<[bool; 2]>(),
        )
            .prop_map(|(axis, negative, magnitude, neg_zero)| DirSpec::Axis {
                axis,
                negative,
                magnitude,
                neg_zero,
            }),
        5 => aimed_dir_spec(),
        1 => (any::<Index>(), 0.0f32..1.0, 0.0f32..1.0)
            .prop_map(|(i, u, v)| DirSpec::AtTrianglePoint(i, u, v)),
    ]
}

pub fn range_spec() -> impl Strategy<Value = RangeSpec> {
    prop_oneof![
        6 => Just(RangeSpec::Unbounded),
        2 => (0.0f32..2.0, 0.0f32..3.0).prop_map(|(a, b)| RangeSpec::Window(a, b)),
        1 => Just(RangeSpec::Window(0.0, 0.0)),
        2 => Just(RangeSpec::Segment),
        1 => Just(RangeSpec::FromTarget),
    ]
}

/// Any ray: see [`OriginSpec`], [`DirSpec`], [`RangeSpec`].
pub fn ray_spec() -> impl Strategy<Value = RaySpec> {
    (origin_spec(), dir_spec(), range_spec()).prop_map(|(origin, dir, range)| RaySpec {
        origin,
        dir,
        range,
    })
}

/// Rays aimed exactly at vertices and edge midpoints.
pub fn aimed_ray_spec() -> impl Strategy<Value = RaySpec> {
    (origin_spec(), aimed_dir_spec(), range_spec()).prop_map(|(origin, dir, range)| RaySpec {
        origin,
        dir,
        range,
    })
}

impl RaySpec {
    /// The concrete ray for `mesh` (targets are picked among its vertices and triangles).
    pub fn resolve(&self, mesh: &Mesh) -> Ray {
        let verts = mesh.vertices();
        let tris = mesh.triangles();
        let origin = match self.origin {
            OriginSpec::Point(p) => p,
            OriginSpec::AtVertex(i) if !verts.is_empty() => verts[i.index(verts.len())],
            OriginSpec::AtVertex(_) => Vec3::ZERO,
        };
        let target = |p: Vec3| p - origin;
        let dir = match self.dir {
            DirSpec::Free(d) => d,
            DirSpec::Axis {
                axis,
                negative,
                magnitude,
                neg_zero,
            } => {
                let mut d = [0.0f32; 3];
                let others = [(axis + 1) % 3, (axis + 2) % 3];
                for (k, &o) in others.iter().enumerate() {
                    d[o] = if neg_zero[k] { -0.0 } else { 0.0 };
                }
                d[axis] = if negative { -magnitude } else { magnitude };
                Vec3::from_array(d)
            }
            DirSpec::AtVertex(i) if !verts.is_empty() => target(verts[i.index(verts.len())]),
            DirSpec::AtEdgeMidpoint(i, e) if !tris.is_empty() => {
                let tri = mesh.triangle(i.index(tris.len()) as u32);
                target((tri[e] + tri[(e + 1) % 3]) * 0.5)
            }
            DirSpec::AtTrianglePoint(i, u, v) if !tris.is_empty() => {
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                let [a, b, c] = mesh.triangle(i.index(tris.len()) as u32);
                target(a * (1.0 - u - v) + b * u + c * v)
            }
            _ => Vec3::new(0.3, -0.7, 0.2),
        };
        match self.range {
            RangeSpec::Unbounded => Ray::new(origin, dir),
            RangeSpec::Window(tmin, extra) => Ray::with_range(origin, dir, tmin, tmin + extra),
            RangeSpec::Segment => Ray::with_range(origin, dir, 0.0, 1.0),
            RangeSpec::FromTarget => Ray::with_range(origin, dir, 1.0, f32::INFINITY),
        }
    }
}
