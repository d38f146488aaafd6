//! [`Reference`]: closest hits in `f64` over a simple median-split tree with padded boxes.

use raybatch::glam::DVec3;
use raybatch::{Mesh, Ray};
use rayon::prelude::*;

/// Largest number of triangles in a leaf of the reference tree.
const LEAF: usize = 4;
/// Relative padding of every box (of its extent plus its distance from the origin): covers the
/// `f64` rounding of the slab test many times over, so no touched box is skipped.
const PAD: f64 = 1e-9;

/// The judge's answer for one ray: the triangle and its `f64` distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JudgeHit {
    /// Triangle id in the original mesh (lowest id among equal `f64` distances).
    pub triangle: u32,
    /// Distance along the ray, in `f64`.
    pub t: f64,
}

/// A ray in `f64`, with what the kernel and the slab test need.
struct RayF64 {
    origin: DVec3,
    inv_dir: DVec3,
    /// Axis permutation: `kz` is the dominant axis of the direction.
    k: [usize; 3],
    shear: DVec3,
    tmin: f64,
    tmax: f64,
}

impl RayF64 {
    fn new(ray: &Ray) -> Self {
        let (origin, dir) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let kz = dir.abs().max_position();
        let (kx, ky) = ((kz + 1) % 3, (kz + 2) % 3);
        Self {
            origin,
            inv_dir: dir.recip(),
            k: [kx, ky, kz],
            shear: DVec3::new(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]),
            tmin: f64::from(ray.tmin),
            tmax: f64::from(ray.tmax),
        }
    }
}

/// Where the ray meets the plane of a triangle, with normalized barycentrics (the watertight
/// kernel's edge functions over their sum): `None` for a triangle edge-on to the ray or of
/// zero area.
pub(crate) fn plane_hit(ray: &Ray, tri: &[DVec3; 3]) -> Option<(f64, [f64; 3])> {
    plane_hit_f64(&RayF64::new(ray), tri)
}

fn plane_hit_f64(ray: &RayF64, tri: &[DVec3; 3]) -> Option<(f64, [f64; 3])> {
    let [kx, ky, kz] = ray.k;
    let s = ray.shear;
    let p = tri.map(|v| {
        let a = v - ray.origin;
        (a[kx] - s.x * a[kz], a[ky] - s.y * a[kz], a[kz])
    });
    let (a, b, c) = (p[0], p[1], p[2]);
    let u = c.0 * b.1 - c.1 * b.0;
    let v = a.0 * c.1 - a.1 * c.0;
    let w = b.0 * a.1 - b.1 * a.0;
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t = (u * a.2 + v * b.2 + w * c.2) * s.z / det;
    Some((t, [u / det, v / det, w / det]))
}

/// True if the ray hits the triangle (edges inclusive: all edge functions of one sign) at a
/// distance in its range; the distance.
fn hit(ray: &RayF64, tri: &[DVec3; 3]) -> Option<f64> {
    let (t, b) = plane_hit_f64(ray, tri)?;
    let inside = b.iter().all(|&x| x >= 0.0);
    (inside && t >= ray.tmin && t <= ray.tmax).then_some(t)
}

/// A node of the reference tree: a padded box and either two children or a triangle range.
struct Node {
    min: DVec3,
    max: DVec3,
    /// Leaf: `first..first + count` in `order`; internal (`count == 0`): children
    /// `first` and `first + 1`.
    first: u32,
    count: u32,
}

/// The f64 judge over one mesh (see the module docs).
pub struct Reference {
    triangles: Vec<[DVec3; 3]>,
    order: Vec<u32>,
    nodes: Vec<Node>,
}

impl Reference {
    /// Builds the reference tree over `mesh` (median splits on the longest axis).
    pub fn new(mesh: &Mesh) -> Self {
        let triangles: Vec<[DVec3; 3]> = (0..mesh.triangle_count() as u32)
            .map(|id| mesh.triangle(id).map(|v| v.as_dvec3()))
            .collect();
        let mut reference = Self {
            order: (0..triangles.len() as u32).collect(),
            triangles,
            nodes: Vec::new(),
        };
        if !reference.order.is_empty() {
            reference
                .nodes
                .push(reference.node(0, reference.order.len()));
            reference.split(0);
        }
        reference
    }

    /// A leaf over `order[first..first + count]` with its padded box.
    fn node(&self, first: usize, count: usize) -> Node {
        let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &id in &self.order[first..first + count] {
            for v in self.triangles[id as usize] {
                (min, max) = (min.min(v), max.max(v));
            }
        }
        let pad = ((max - min) + min.abs().max(max.abs())) * PAD;
        Node {
            min: min - pad,
            max: max + pad,
            first: first as u32,
            count: count as u32,
        }
    }

    /// Splits node `index` at the median centroid of its longest axis, recursively.
    fn split(&mut self, index: usize) {
        let (first, count) = (
            self.nodes[index].first as usize,
            self.nodes[index].count as usize,
        );
        if count <= LEAF {
            return;
        }
        let axis = (self.nodes[index].max - self.nodes[index].min).max_position();
        let triangles = &self.triangles;
        let key = |id: &u32| {
            let [a, b, c] = triangles[*id as usize];
            a[axis] + b[axis] + c[axis]
        };
        let half = count / 2;
        self.order[first..first + count]
            .select_nth_unstable_by(half, |x, y| key(x).total_cmp(&key(y)));
        let children = self.nodes.len();
        let (left, right) = (
            self.node(first, half),
            self.node(first + half, count - half),
        );
        self.nodes.extend([left, right]);
        self.nodes[index].first = children as u32;
        self.nodes[index].count = 0;
        self.split(children);
        self.split(children + 1);
    }

    /// The closest hit of `ray` in `f64`, lowest id among equal distances.
    pub fn closest(&self, ray: &Ray) -> Option<JudgeHit> {
        if self.nodes.is_empty() {
            return None;
        }
        let r = RayF64::new(ray);
        let mut best: Option<JudgeHit> = None;
        let mut stack = vec![0u32];
        while let Some(index) = stack.pop() {
            let node = &self.nodes[index as usize];
            let tmax = best.map_or(r.tmax, |b| b.t);
            if !slab(&r, node, tmax) {
                continue;
            }
            if node.count == 0 {
                stack.extend([node.first, node.first + 1]);
                continue;
            }
            for &id in &self.order[node.first as usize..(node.first + node.count) as usize] {
                let Some(t) = hit(&r, &self.triangles[id as usize]) else {
                    continue;
                };
                let better = best.is_none_or(|b| t < b.t || (t == b.t && id < b.triangle));
                if better {
                    best = Some(JudgeHit { triangle: id, t });
                }
            }
        }
        best
    }

    /// [`Reference::closest`] for every ray, on rayon's threads.
    pub fn closest_all(&self, rays: &[Ray]) -> Vec<Option<JudgeHit>> {
        rays.par_iter().map(|r| self.closest(r)).collect()
    }

    /// The corners of triangle `id` in `f64`.
    pub(crate) fn triangle(&self, id: u32) -> &[DVec3; 3] {
        &self.triangles[id as usize]
    }
}

/// The slab test of a padded box over `[tmin, tmax]`, inclusive (NaN from `0 * inf` on a
/// face the ray runs along counts as touching: the padding makes that face an inside one).
fn slab(r: &RayF64, node: &Node, tmax: f64) -> bool {
    let t0 = (node.min - r.origin) * r.inv_dir;
    let t1 = (node.max - r.origin) * r.inv_dir;
    let near = t0.min(t1);
    let far = t0.max(t1);
    let enter = near.max_element().max(r.tmin);
    let exit = far.min_element().min(tmax);
    enter <= exit || enter.is_nan() || exit.is_nan()
}

/// The judge tests' mesh: two triangles sharing the edge x = 0 in the plane z = 2, and one
/// behind them at z = 5.
#[cfg(test)]
pub(crate) fn test_mesh() -> Mesh {
    use raybatch::glam::Vec3;
    let v = vec![
        Vec3::new(0.0, -1.0, 2.0),
        Vec3::new(0.0, 1.0, 2.0),
        Vec3::new(-1.0, 0.0, 2.0),
        Vec3::new(1.0, 0.0, 2.0),
        Vec3::new(-4.0, -4.0, 5.0),
        Vec3::new(4.0, -4.0, 5.0),
        Vec3::new(0.0, 4.0, 5.0),
    ];
    Mesh::new(v, vec![[0, 1, 2], [1, 0, 3], [4, 5, 6]]).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use raybatch::glam::Vec3;

    #[test]
    fn known_hits_in_f64() {
        let judge = Reference::new(&test_mesh());
        let down = |x, y| Ray::new(Vec3::new(x, y, 0.0), Vec3::Z);
        let hit = |ray| judge.closest(&ray).map(|h| (h.triangle, h.t));
        assert_eq!(hit(down(-0.25, 0.0)), Some((0, 2.0)));
        assert_eq!(hit(down(0.25, 0.0)), Some((1, 2.0)));
        // On the shared edge: both at t = 2, the lower id wins.
        assert_eq!(hit(down(0.0, 0.5)), Some((0, 2.0)));
        // Beside both: the far triangle.
        assert_eq!(hit(down(2.0, -2.0)), Some((2, 5.0)));
        // A range that ends before the near pair.
        let short = Ray::with_range(Vec3::new(0.25, 0.0, 0.0), Vec3::Z, 0.0, 1.5);
        assert_eq!(judge.closest(&short), None);
        // Backwards and beside everything.
        assert_eq!(hit(Ray::new(Vec3::ZERO, -Vec3::Z)), None);
        assert_eq!(hit(down(9.0, 9.0)), None);
        // A slanted ray: t is the distance in units of the direction's length.
        let slanted = Ray::new(Vec3::new(-0.5, 0.0, 0.0), Vec3::new(0.25, 0.0, 1.0));
        assert_eq!(hit(slanted), Some((0, 2.0)));
    }

    #[test]
    fn tree_matches_a_scan_on_many_triangles() {
        let mut rng = raybatch_rng();
        let mut v = Vec::new();
        for _ in 0..600 {
            let c = rng.point_in(Vec3::splat(-5.0), Vec3::splat(5.0));
            v.extend((0..3).map(|_| c + rng.unit_vector()));
        }
        let tris = (0..200u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let mesh = Mesh::new(v, tris).unwrap();
        let judge = Reference::new(&mesh);
        let scan = |ray: &Ray| {
            let r = RayF64::new(ray);
            (0..mesh.triangle_count() as u32)
                .filter_map(|id| hit(&r, judge.triangle(id)).map(|t| (t, id)))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        };
        let mut hits = 0;
        for _ in 0..2_000 {
            let ray = Ray::new(
                rng.point_in(Vec3::splat(-6.0), Vec3::splat(6.0)),
                rng.unit_vector(),
            );
            let got = judge.closest(&ray).map(|h| (h.t, h.triangle));
            assert_eq!(got, scan(&ray), "{ray:?}");
            hits += usize::from(got.is_some());
        }
        assert!(hits > 200, "{hits}");
    }

    fn raybatch_rng() -> crate::scenes::SplitMix64 {
        crate::scenes::SplitMix64::new(11)
    }
}
