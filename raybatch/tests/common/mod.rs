//! Shared helpers for the integration tests: mesh generators, proptest strategies for meshes and
//! rays, every tree combination behind one dyn-compatible interface, and the comparison against
//! the brute-force reference.
//!
//! Each test binary uses only part of this module.
#![allow(dead_code)]

use std::collections::HashMap;
use std::sync::Arc;

use glam::{DVec3, Vec3};
use proptest::prelude::*;
use proptest::sample::Index;
use raybatch::query::brute_force;
use raybatch::{
    AabbTree, BuildOptions, ChildOrdering, Hit, Kernel, Mesh, QuantizedAabbTree, Ray, RayQueries,
};

// ---------------------------------------------------------------------------------------------
// Meshes
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Every tree combination behind one dyn-compatible interface
// ---------------------------------------------------------------------------------------------

/// The queries of [`RayQueries`] without its generic method, so that trees of different types
/// can sit in one `Vec<Box<dyn Queries>>`.
pub trait Queries {
    fn cast(&self, ray: &Ray, kernel: Kernel) -> Option<Hit>;
    /// `RayQueries::cast_ray` (the default kernel).
    fn cast_default(&self, ray: &Ray) -> Option<Hit>;
    fn occluded(&self, ray: &Ray, kernel: Kernel) -> bool;
    /// `RayQueries::occluded` (the default kernel).
    fn occluded_default(&self, ray: &Ray) -> bool;
    /// `RayQueries::all_hits` (watertight kernel).
    fn all_hits(&self, ray: &Ray) -> Vec<Hit>;
    /// `RayQueries::for_each_hit`, collected in callback order.
    fn each_hit(&self, ray: &Ray) -> Vec<Hit>;
    /// `RayQueries::for_each_hit_with`, collected in callback order.
    fn each_hit_with(&self, ray: &Ray, kernel: Kernel) -> Vec<Hit>;
    fn node_count(&self) -> usize;
}

impl<B: RayQueries> Queries for B {
    fn cast(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        RayQueries::cast_ray_with(self, ray, kernel)
    }
    fn cast_default(&self, ray: &Ray) -> Option<Hit> {
        RayQueries::cast_ray(self, ray)
    }
    fn occluded(&self, ray: &Ray, kernel: Kernel) -> bool {
        RayQueries::occluded_with(self, ray, kernel)
    }
    fn occluded_default(&self, ray: &Ray) -> bool {
        RayQueries::occluded(self, ray)
    }
    fn all_hits(&self, ray: &Ray) -> Vec<Hit> {
        RayQueries::all_hits(self, ray)
    }
    fn each_hit(&self, ray: &Ray) -> Vec<Hit> {
        let mut hits = Vec::new();
        RayQueries::for_each_hit(self, ray, |h| hits.push(h));
        hits
    }
    fn each_hit_with(&self, ray: &Ray, kernel: Kernel) -> Vec<Hit> {
        let mut hits = Vec::new();
        RayQueries::for_each_hit_with(self, ray, kernel, |h| hits.push(h));
        hits
    }
    fn node_count(&self) -> usize {
        raybatch::Bvh::node_count(self)
    }
}

/// Node format under test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeKind {
    Full,
    Quantized,
}

impl TreeKind {
    pub const ALL: [TreeKind; 2] = [TreeKind::Full, TreeKind::Quantized];
}

pub const LEAF_SIZES: [u32; 3] = [1, 4, 16];

/// One built tree and a name saying how it was built.
pub struct TreeUnderTest {
    pub name: String,
    pub tree: Box<dyn Queries>,
}

/// Builds one tree.
pub fn build_tree(
    mesh: &Arc<Mesh>,
    kind: TreeKind,
    leaf: u32,
    ordering: ChildOrdering,
) -> TreeUnderTest {
    let options = BuildOptions::default()
        .with_leaf_size(leaf)
        .with_ordering(ordering);
    let name = format!("{kind:?}/leaf{leaf}/{}", ordering.name());
    let tree: Box<dyn Queries> = match kind {
        TreeKind::Full => Box::new(
            <AabbTree>::build(mesh.clone(), &options)
                .unwrap_or_else(|e| panic!("{name}: build failed: {e}")),
        ),
        TreeKind::Quantized => Box::new(
            QuantizedAabbTree::build(mesh.clone(), &options)
                .unwrap_or_else(|e| panic!("{name}: build failed: {e}")),
        ),
    };
    TreeUnderTest { name, tree }
}

/// Every combination of the chosen formats, leaf sizes and orderings.
pub fn trees_with(
    mesh: &Mesh,
    kinds: &[TreeKind],
    leaves: &[u32],
    orderings: &[ChildOrdering],
) -> Vec<TreeUnderTest> {
    let mesh = Arc::new(mesh.clone());
    let mut out = Vec::new();
    for &kind in kinds {
        for &leaf in leaves {
            for &ordering in orderings {
                out.push(build_tree(&mesh, kind, leaf, ordering));
            }
        }
    }
    out
}

/// All 18 trees: {AabbTree, QuantizedAabbTree} x {leaf 1, 4, 16} x {Fixed, SplitAxis, Pns}.
pub fn all_trees(mesh: &Mesh) -> Vec<TreeUnderTest> {
    trees_with(mesh, &TreeKind::ALL, &LEAF_SIZES, &ChildOrdering::ALL)
}

// ---------------------------------------------------------------------------------------------
// Comparison with the brute-force reference
// ---------------------------------------------------------------------------------------------

/// A hit as exact bits: (triangle, t, u, v).
pub type HitBits = (u32, u32, u32, u32);

pub fn bits(h: &Hit) -> HitBits {
    (h.triangle, h.t.to_bits(), h.u.to_bits(), h.v.to_bits())
}

pub fn opt_bits(h: Option<Hit>) -> Option<HitBits> {
    h.as_ref().map(bits)
}

pub fn all_bits(hits: &[Hit]) -> Vec<HitBits> {
    hits.iter().map(bits).collect()
}

/// Brute-force answers for one ray, computed once and compared with every tree.
pub struct Reference {
    pub ray: Ray,
    /// Per kernel (in [`Kernel::ALL`] order): closest hit, occluded, all hits sorted.
    pub answers: Vec<(Kernel, Option<Hit>, bool, Vec<Hit>)>,
}

impl Reference {
    pub fn new(mesh: &Mesh, ray: &Ray) -> Self {
        let answers = Kernel::ALL
            .iter()
            .map(|&k| {
                (
                    k,
                    brute_force::cast_ray(mesh, ray, k),
                    brute_force::occluded(mesh, ray, k),
                    brute_force::all_hits(mesh, ray, k),
                )
            })
            .collect();
        Self { ray: *ray, answers }
    }
}

/// Compares every query of one tree with the brute-force reference on one ray, bit for bit:
/// closest hit (id, `t`, `u`, `v`), occlusion and every hit, for both kernels, plus the
/// default-kernel methods. Returns a description of the first difference.
pub fn compare_tree(t: &TreeUnderTest, reference: &Reference) -> Result<(), String> {
    let name = &t.name;
    let ray = &reference.ray;
    for (kernel, expected, expected_occ, expected_all) in &reference.answers {
        let (kernel, expected, expected_occ) = (*kernel, *expected, *expected_occ);
        let got = t.tree.cast(ray, kernel);
        let got_occ = t.tree.occluded(ray, kernel);
        if opt_bits(got) != opt_bits(expected) || got_occ != expected_occ {
            return Err(format!(
                "{name} {kernel:?}: cast_ray {got:?} / occluded {got_occ}, brute force \
                 {expected:?} / occluded {expected_occ}, for {ray:?}"
            ));
        }
        // Every hit from the callback, as a multiset (compared in a canonical order).
        let mut each = all_bits(&t.tree.each_hit_with(ray, kernel));
        each.sort_unstable();
        let mut sorted_expected = all_bits(expected_all);
        sorted_expected.sort_unstable();
        if each != sorted_expected {
            return Err(format!(
                "{name} {kernel:?} for_each_hit: got {each:?}, brute force {expected_all:?} \
                 for {ray:?}"
            ));
        }
    }
    let (_, wt, wt_occ, wt_all) = &reference.answers[0];
    if opt_bits(t.tree.cast_default(ray)) != opt_bits(*wt) {
        return Err(format!(
            "{name}: cast_ray differs from cast_ray_with(Watertight)"
        ));
    }
    if t.tree.occluded_default(ray) != *wt_occ {
        return Err(format!(
            "{name}: occluded differs from occluded_with(Watertight)"
        ));
    }
    let got_all = all_bits(&t.tree.all_hits(ray));
    if got_all != all_bits(wt_all) {
        return Err(format!(
            "{name} all_hits: got {got_all:?}, brute force {wt_all:?} for {ray:?}"
        ));
    }
    let mut each = all_bits(&t.tree.each_hit(ray));
    each.sort_unstable();
    let mut sorted = got_all.clone();
    sorted.sort_unstable();
    if each != sorted {
        return Err(format!(
            "{name}: for_each_hit differs from all_hits for {ray:?}"
        ));
    }
    Ok(())
}

/// [`compare_tree`] for every tree (brute force evaluated once).
pub fn compare_all(mesh: &Mesh, trees: &[TreeUnderTest], ray: &Ray) -> Result<(), String> {
    assert_eq!(Kernel::ALL[0], Kernel::Watertight);
    let reference = Reference::new(mesh, ray);
    trees.iter().try_for_each(|t| compare_tree(t, &reference))
}

/// [`compare_all`], panicking with the difference.
#[track_caller]
pub fn assert_matches_brute_force(mesh: &Mesh, trees: &[TreeUnderTest], ray: &Ray) {
    if let Err(e) = compare_all(mesh, trees, ray) {
        panic!("{e}\nmesh: {}", describe(mesh));
    }
}

/// The tie rule on the brute-force reference: the closest hit is the first of `all_hits`,
/// bit for bit (which requires `all_hits` to order equal `t` by id).
pub fn closest_is_first_of_all_hits(mesh: &Mesh, ray: &Ray) -> Result<(), String> {
    for kernel in Kernel::ALL {
        let all = brute_force::all_hits(mesh, ray, kernel);
        let closest = brute_force::cast_ray(mesh, ray, kernel);
        if opt_bits(all.first().copied()) != opt_bits(closest) {
            return Err(format!(
                "{kernel:?}: cast_ray {closest:?} is not all_hits()[0] in {all:?} for {ray:?}"
            ));
        }
    }
    Ok(())
}

/// A compact description of a mesh: `id: [a, b, c]` for every non-degenerate triangle.
pub fn describe(mesh: &Mesh) -> String {
    (0..mesh.triangle_count() as u32)
        .filter(|&id| !mesh.is_degenerate(id))
        .map(|id| format!("{id}: {:?}", mesh.triangle(id).map(|p| p.to_array())))
        .collect::<Vec<_>>()
        .join("; ")
}

/// The triangles hit at the smallest `t` (brute force, watertight), lowest id first.
pub fn closest_ids(mesh: &Mesh, ray: &Ray) -> Vec<u32> {
    let hits = brute_force::all_hits(mesh, ray, Kernel::Watertight);
    match hits.first() {
        None => vec![],
        Some(first) => hits
            .iter()
            .filter(|h| h.t == first.t)
            .map(|h| h.triangle)
            .collect(),
    }
}

// ---------------------------------------------------------------------------------------------
// Proptest strategies
// ---------------------------------------------------------------------------------------------

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
