//! Single-ray traversal, the reference every other engine must match bit for bit.
//!
//! A depth-first loop with a fixed-size stack (trees are at most
//! [`crate::tree::build::MAX_DEPTH`] deep, so it cannot overflow). At an internal node both
//! children's boxes are tested; if both are touched, the one the precomputed ordering byte
//! names as nearer is visited now and the other is pushed with its entry distance, so that a
//! later pop can drop it without refetching it if the best hit has moved in front of it.
//! Entry distances are compared with `<=`: a box entered exactly at the best `t` may still hold
//! an equal-`t` triangle with a lower id (the tie rule of [`crate::query`]).

use glam::Vec3;

use crate::geom::{Kernel, KernelTask, PreparedRay, Ray, TriangleTest};
use crate::query::Hit;
use crate::tree::build::MAX_DEPTH;
use crate::tree::ordering::second_child_first;
use crate::tree::{Bvh, NodeView};

/// Stack entries needed: at most one pending sibling per level.
const STACK_SIZE: usize = MAX_DEPTH + 2;

/// What the traversal does with each triangle hit.
pub(crate) trait Visitor {
    /// Called with each hit in range; returns true to stop the traversal.
    fn visit(&mut self, hit: Hit) -> bool;
    /// The current upper end of the ray's range.
    fn tmax(&self) -> f32;
}

/// Tests a node's triangles; true if the visitor asked to stop.
#[inline(always)]
fn visit_triangles<B, K, V>(tree: &B, node: &NodeView, ray: &PreparedRay, visitor: &mut V) -> bool
where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: Visitor,
{
    let triangles = (node.first..node.first + node.count).map(|slot| tree.triangle(slot));
    test_triangles::<K, V>(ray, triangles, visitor)
}

/// Tests one ray against `(id, corners)` triangles, reporting hits to `visitor`; true if the
/// visitor asked to stop. Shared by the single-ray loop and the batched leaves.
#[inline(always)]
pub(crate) fn test_triangles<K, V>(
    ray: &PreparedRay,
    triangles: impl IntoIterator<Item = (u32, [Vec3; 3])>,
    visitor: &mut V,
) -> bool
where
    K: TriangleTest,
    V: Visitor,
{
    for (id, tri) in triangles {
        if let Some(h) = K::intersect(ray, &tri, visitor.tmax()) {
            let hit = Hit {
                t: h.t,
                triangle: id,
                u: h.u,
                v: h.v,
            };
            if visitor.visit(hit) {
                return true;
            }
        }
    }
    false
}

/// Runs `visitor` over every triangle the ray may hit, with kernel `K`.
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
    let root = tree.node(0);
    if root.bounds.entry(ray, visitor.tmax()) == f32::INFINITY {
        return;
    }
    traverse_below::<B, K, V>(tree, ray, root, visitor)
}

/// The traversal loop, starting at `node`, whose box the ray is known to touch. The batched
/// engine calls it to finish a subtree for the few rays that reach it.
#[inline(always)]
pub(crate) fn traverse_below<B, K, V>(tree: &B, ray: &PreparedRay, start: NodeView, visitor: &mut V)
where
    B: Bvh + ?Sized,
    K: TriangleTest,
    V: Visitor,
{
    let mut node = start;
    let mut stack = [(0u32, 0.0f32); STACK_SIZE];
    let mut len = 0;
    loop {
        if visit_triangles::<B, K, V>(tree, &node, ray, visitor) {
            return;
        }
        if node.first_child != 0 {
            let c = node.first_child;
            let (near, far) = if second_child_first(node.order, ray.octant_mask) {
                (c + 1, c)
            } else {
                (c, c + 1)
            };
            let (near_node, far_node) = (tree.node(near), tree.node(far));
            let tmax = visitor.tmax();
            let near_entry = near_node.bounds.entry(ray, tmax);
            let far_entry = far_node.bounds.entry(ray, tmax);
            match (near_entry < f32::INFINITY, far_entry < f32::INFINITY) {
                (true, true) => {
                    stack[len] = (far, far_entry);
                    len += 1;
                    node = near_node;
                    continue;
                }
                (true, false) => {
                    node = near_node;
                    continue;
                }
                (false, true) => {
                    node = far_node;
                    continue;
                }
                (false, false) => {}
            }
        }
        // Pop the next pending node that is still in front of the best hit.
        loop {
            if len == 0 {
                return;
            }
            len -= 1;
            let (index, entry) = stack[len];
            if entry <= visitor.tmax() {
                node = tree.node(index);
                break;
            }
        }
    }
}

/// [`traverse`] packaged for [`Kernel::dispatch`].
struct Traversal<'a, B: ?Sized, V> {
    tree: &'a B,
    ray: &'a PreparedRay,
    visitor: &'a mut V,
}

impl<B: Bvh + ?Sized, V: Visitor> KernelTask for Traversal<'_, B, V> {
    type Output = ();
    #[inline(always)]
    fn run<K: TriangleTest>(self) {
        traverse::<B, K, V>(self.tree, self.ray, self.visitor)
    }
}

/// Runs `visitor` with `kernel`, monomorphized for the ray's dominant axis.
///
/// On x86-64 CPUs with AVX2 the whole loop is compiled a second time with AVX2 enabled (wider
/// blends and three-operand instructions make the box test shorter) and picked at run time,
/// for the trees whose [`Bvh::AVX2_TRAVERSAL`] says it pays.
/// Both versions perform the same IEEE operations in the same order (Rust never fuses a
/// multiply and an add on its own), so they return identical bits.
#[inline]
pub(crate) fn run<B: Bvh + ?Sized, V: Visitor>(
    tree: &B,
    ray: &PreparedRay,
    kernel: Kernel,
    visitor: &mut V,
) {
    #[cfg(target_arch = "x86_64")]
    if B::AVX2_TRAVERSAL && std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, the only requirement of `run_avx2`.
        unsafe { run_avx2(tree, ray, kernel, visitor) };
        return;
    }
    run_portable(tree, ray, kernel, visitor)
}

/// [`run`] compiled for the baseline instruction set.
pub(crate) fn run_portable<B: Bvh + ?Sized, V: Visitor>(
    tree: &B,
    ray: &PreparedRay,
    kernel: Kernel,
    visitor: &mut V,
) {
    kernel.dispatch(ray.kz as usize, Traversal { tree, ray, visitor })
}

/// [`run`] compiled with AVX2 enabled.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_avx2<B: Bvh + ?Sized, V: Visitor>(
    tree: &B,
    ray: &PreparedRay,
    kernel: Kernel,
    visitor: &mut V,
) {
    kernel.dispatch(ray.kz as usize, Traversal { tree, ray, visitor })
}

/// Keeps the best hit by the tie rule.
pub(crate) struct Closest {
    pub best: Hit,
}

impl Closest {
    pub fn new(tmax: f32) -> Self {
        Self {
            best: Hit {
                t: tmax,
                triangle: u32::MAX,
                u: 0.0,
                v: 0.0,
            },
        }
    }

    pub fn result(&self) -> Option<Hit> {
        (self.best.triangle != u32::MAX).then_some(self.best)
    }
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

/// Stops at the first hit.
pub(crate) struct Any {
    pub tmax: f32,
    pub found: bool,
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

/// Reports every hit.
pub(crate) struct Every<F> {
    pub tmax: f32,
    pub f: F,
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

/// The single-ray queries, for every [`Bvh`].
pub trait RayQueries: Bvh {
    /// The closest hit (watertight kernel), or `None`. Invalid rays miss (see
    /// [`Ray::validate`]). On equal `t` the lowest triangle id wins.
    fn cast_ray(&self, ray: &Ray) -> Option<Hit> {
        self.cast_ray_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::cast_ray`] with a chosen kernel.
    fn cast_ray_with(&self, ray: &Ray, kernel: Kernel) -> Option<Hit> {
        let prepared = PreparedRay::new(ray)?;
        let mut closest = Closest::new(prepared.tmax);
        run(self, &prepared, kernel, &mut closest);
        closest.result()
    }

    /// True if the ray hits anything in `[tmin, tmax]` (line of sight is `!occluded` of a
    /// [`Ray::segment`]). Stops at the first hit found.
    fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, Kernel::Watertight)
    }

    /// [`RayQueries::occluded`] with a chosen kernel.
    fn occluded_with(&self, ray: &Ray, kernel: Kernel) -> bool {
        let Some(prepared) = PreparedRay::new(ray) else {
            return false;
        };
        let mut any = Any {
            tmax: prepared.tmax,
            found: false,
        };
        run(self, &prepared, kernel, &mut any);
        any.found
    }

    /// Calls `f` once per triangle hit in `[tmin, tmax]`, in no particular order (watertight).
    fn for_each_hit(&self, ray: &Ray, f: impl FnMut(Hit)) {
        self.for_each_hit_with(ray, Kernel::Watertight, f)
    }

    /// [`RayQueries::for_each_hit`] with a chosen kernel.
    fn for_each_hit_with(&self, ray: &Ray, kernel: Kernel, f: impl FnMut(Hit)) {
        let Some(prepared) = PreparedRay::new(ray) else {
            return;
        };
        let mut every = Every {
            tmax: prepared.tmax,
            f,
        };
        run(self, &prepared, kernel, &mut every);
    }

    /// Every hit, sorted by `t` then triangle id (watertight).
    fn all_hits(&self, ray: &Ray) -> Vec<Hit> {
        let mut hits = Vec::new();
        self.for_each_hit(ray, |h| hits.push(h));
        Hit::sort(&mut hits);
        hits
    }
}

impl<B: Bvh + ?Sized> RayQueries for B {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::{self, SceneKind, rays::RaySet};
    use crate::tree::{AabbTree, BuildOptions};

    /// The run-time dispatched loop (AVX2 where available) and the baseline one agree bit for
    /// bit.
    #[test]
    fn dispatched_and_portable_traversals_agree() {
        let scene = scenes::bunny();
        let tree: AabbTree = AabbTree::build(scene.mesh.clone(), &BuildOptions::default()).unwrap();
        let rays = scenes::rays::generate(
            RaySet::Incoherent,
            &scene.mesh,
            SceneKind::Object,
            20_000,
            3,
        );
        for kernel in Kernel::ALL {
            for ray in &rays {
                let prepared = PreparedRay::new(ray).unwrap();
                let mut a = Closest::new(prepared.tmax);
                let mut b = Closest::new(prepared.tmax);
                run(&tree, &prepared, kernel, &mut a);
                run_portable(&tree, &prepared, kernel, &mut b);
                let bits = |h: Option<Hit>| {
                    h.map(|h| (h.t.to_bits(), h.triangle, h.u.to_bits(), h.v.to_bits()))
                };
                assert_eq!(bits(a.result()), bits(b.result()), "{ray:?}");
            }
        }
    }
}
