//! The O(n) reference: every query answered by testing every triangle of the mesh, in id order.
//!
//! Slow and obviously right; the tests compare every tree, node format, ordering and batch
//! size against it. It skips degenerate triangles exactly like the trees do and follows the same
//! tie rule (see [`crate::Hit`]).

use crate::geom::{Kernel, MollerTrumbore, PreparedRay, Ray, TriangleTest, Watertight};
use crate::hit::Hit;
use crate::mesh::Mesh;

/// The closest hit over all triangles, lowest id on equal `t`.
pub fn cast_ray(mesh: &Mesh, ray: &Ray, kernel: Kernel) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for_each_hit(mesh, ray, kernel, |hit| {
        if best.is_none_or(|b| hit.is_before(&b)) {
            best = Some(hit);
        }
    });
    best
}

/// True if any triangle is hit within the ray's range, or if the ray is invalid (line of
/// sight fails closed, as in [`crate::RayQueries::occluded`]).
pub fn occluded(mesh: &Mesh, ray: &Ray, kernel: Kernel) -> bool {
    if !ray.is_valid() {
        return true;
    }
    let mut any = false;
    for_each_hit(mesh, ray, kernel, |_| any = true);
    any
}

/// Every hit, sorted by `t` then triangle id.
pub fn all_hits(mesh: &Mesh, ray: &Ray, kernel: Kernel) -> Vec<Hit> {
    let mut hits = Vec::new();
    for_each_hit(mesh, ray, kernel, |h| hits.push(h));
    Hit::sort(&mut hits);
    hits
}

/// Calls `f` for every hit, in triangle id order.
pub fn for_each_hit(mesh: &Mesh, ray: &Ray, kernel: Kernel, f: impl FnMut(Hit)) {
    match kernel {
        Kernel::Watertight => hits_with::<Watertight>(mesh, ray, f),
        Kernel::MollerTrumbore => hits_with::<MollerTrumbore>(mesh, ray, f),
    }
}

fn hits_with<K: TriangleTest>(mesh: &Mesh, ray: &Ray, mut f: impl FnMut(Hit)) {
    let Some(prepared) = PreparedRay::new(ray) else {
        return;
    };
    for id in 0..mesh.triangle_count() as u32 {
        if mesh.is_degenerate(id) {
            continue;
        }
        if let Some(h) = K::intersect(&prepared, &mesh.triangle(id), prepared.tmax) {
            f(Hit {
                t: h.t,
                triangle: id,
                u: h.u,
                v: h.v,
            });
        }
    }
}
