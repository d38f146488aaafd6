//! Single-ray traversal, the reference every other engine must match bit for bit.
//!
//! A depth-first loop with a fixed-size stack (trees are at most
//! [`crate::tree::build::MAX_DEPTH`] deep, so it cannot overflow): pop a node, test its box
//! against the ray clipped to the best hit so far, test its triangles, push its children with
//! the nearer one (by the precomputed ordering byte) on top.

use crate::geom::{Kernel, MollerTrumbore, PreparedRay, Ray, TriangleTest, Watertight};
use crate::query::Hit;
use crate::tree::build::MAX_DEPTH;
use crate::tree::ordering::second_child_first;
use crate::tree::{Bvh, NodeView};

/// Stack entries needed: at most one pending sibling per level, plus the node being expanded.
const STACK_SIZE: usize = MAX_DEPTH + 2;

/// What the traversal loop does with each triangle hit.
trait Visitor {
    /// Called with each hit in range; returns true to stop the traversal.
    fn visit(&mut self, hit: Hit) -> bool;
    /// The current upper end of the ray's range.
    fn tmax(&self) -> f32;
}

/// Runs `visitor` over the tree, with kernel `K`.
#[inline(always)]
fn traverse<B, K, V>(tree: &B, ray: &PreparedRay, visitor: &mut V)
where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: Visitor,
{
    if tree.node_count() == 0 {
        return;
    }
    let mut stack = [0u32; STACK_SIZE];
    let mut len = 1;
    while len > 0 {
        len -= 1;
        let node: NodeView = tree.node(stack[len]);
        if !node.bounds.hit_by(ray, visitor.tmax()) {
            continue;
        }
        for slot in node.first..node.first + node.count {
            let (id, tri) = tree.triangle(slot);
            if let Some(h) = K::intersect(ray, &tri, visitor.tmax()) {
                let hit = Hit {
                    t: h.t,
                    triangle: id,
                    u: h.u,
                    v: h.v,
                };
                if visitor.visit(hit) {
                    return;
                }
            }
        }
        if node.first_child != 0 {
            let second_first = second_child_first(node.order, ray.octant_mask);
            let (near, far) = if second_first {
                (node.first_child + 1, node.first_child)
            } else {
                (node.first_child, node.first_child + 1)
            };
            stack[len] = far;
            stack[len + 1] = near;
            len += 2;
        }
    }
}

struct Closest {
    best: Hit,
}

impl Visitor for Closest {
    #[inline(always)]
    fn visit(&mut self, hit: Hit) -> bool {
        if hit.is_before(&self.best) {
            self.best = hit;
        }
        false
    }
    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.best.t
    }
}

struct Any {
    tmax: f32,
    found: bool,
}

impl Visitor for Any {
    #[inline(always)]
    fn visit(&mut self, _: Hit) -> bool {
        self.found = true;
        true
    }
    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.tmax
    }
}

struct Every<F> {
    tmax: f32,
    f: F,
}

impl<F: FnMut(Hit)> Visitor for Every<F> {
    #[inline(always)]
    fn visit(&mut self, hit: Hit) -> bool {
        (self.f)(hit);
        false
    }
    #[inline(always)]
    fn tmax(&self) -> f32 {
        self.tmax
    }
}

/// Closest hit with kernel `K`; see [`crate::query`] for the tie rule.
pub fn closest_with<B: Bvh + ?Sized, K: TriangleTest>(tree: &B, ray: &Ray) -> Option<Hit> {
    let prepared = PreparedRay::new(ray)?;
    let mut v = Closest {
        best: Hit {
            t: prepared.tmax,
            triangle: u32::MAX,
            u: 0.0,
            v: 0.0,
        },
    };
    traverse::<B, K, _>(tree, &prepared, &mut v);
    (v.best.triangle != u32::MAX).then_some(v.best)
}

/// True if some triangle is hit within the ray's range, with kernel `K`.
pub fn any_with<B: Bvh + ?Sized, K: TriangleTest>(tree: &B, ray: &Ray) -> bool {
    let Some(prepared) = PreparedRay::new(ray) else {
        return false;
    };
    let mut v = Any {
        tmax: prepared.tmax,
        found: false,
    };
    traverse::<B, K, _>(tree, &prepared, &mut v);
    v.found
}

/// Calls `f` for every hit within the ray's range (in traversal order), with kernel `K`.
pub fn each_with<B: Bvh + ?Sized, K: TriangleTest>(tree: &B, ray: &Ray, f: impl FnMut(Hit)) {
    let Some(prepared) = PreparedRay::new(ray) else {
        return;
    };
    let mut v = Every {
        tmax: prepared.tmax,
        f,
    };
    traverse::<B, K, _>(tree, &prepared, &mut v);
}

/// The single-ray queries, for every [`Bvh`].
pub trait RayQueries: Bvh {
    /// The closest hit (watertight kernel), or `None`. Invalid rays miss (see
    /// [`Ray::validate`]). On equal `t` the lowest triangle id wins.
    fn cast_ray(&self, ray: &Ray) -> Option<Hit> {
        self.cast_ray_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::cast_ray`] with a chosen kernel.
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        match kernel {
            Kernel::Watertight => closest_with::<Self, Watertight>(self, ray),
            Kernel::MollerTrumbore => closest_with::<Self, MollerTrumbore>(self, ray),
        }
    }

    /// True if the ray hits anything in `[tmin, tmax]` (line of sight is `!occluded` of a
    /// [`Ray::segment`]). Stops at the first hit found.
    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::occluded`] with a chosen kernel.
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        match kernel {
            Kernel::Watertight => any_with::<Self, Watertight>(self, ray),
            Kernel::MollerTrumbore => any_with::<Self, MollerTrumbore>(self, ray),
        }
    }

    /// Calls `f` once per triangle hit in `[tmin, tmax]`, in no particular order.
    fn for_each_hit(&self, ray: &Ray, f: impl FnMut(Hit)) {
        each_with::<Self, Watertight>(self, ray, f)
    }

    /// Every hit, sorted by `t` then triangle id.
    fn all_hits(&self, ray: &Ray) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.for_each_hit(ray, |h| hits.push(h));
        Hit::sort(&mut hits);
        hits
    }
}

impl<B: Bvh + ?Sized> RayQueries for B {}
