//! The single-ray loop over a [`Bvh`] in its baseline and AVX2 copies ([`super::avx2`]).
//! Trees whose [`Bvh::AVX2_TRAVERSAL`] is false (measured slower that way) always run the
//! baseline copy.

use super::avx2::{self, Loop};
use super::single::{self, Memory, Pending};
use super::stack::PendingStack;
use crate::bvh::Bvh;
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;

/// One ray through [`single::trace`], as a [`Loop`].
struct OneRay<'a, B: Bvh, K, V, S> {
    tree: &'a B,
    ray: &'a PreparedRay,
    id: u32,
    memory: Memory<'a, B, S>,
    visitor: &'a mut V,
    kernel: std::marker::PhantomData<K>,
}

impl<B, K, V, S> Loop for OneRay<'_, B, K, V, S>
where
    B: Bvh,
    K: TriangleTest,
    V: Visitor,
    S: PendingStack<Pending<B>>,
{
    type Output = f32;
    const AVX2: bool = B::AVX2_TRAVERSAL && !V::COUNTS_NODES;
    #[inline(always)]
    fn run(self) -> f32 {
        single::trace::<B, K, V, S>(self.tree, self.ray, self.id, self.memory, self.visitor)
    }
}

/// [`single::trace`], in the AVX2 copy if `avx2` (the tree's [`Bvh::AVX2_TRAVERSAL`], or
/// false for the tests' baseline) and the CPU has it, else the baseline copy.
#[inline]
pub(crate) fn trace<B, K, V, S>(
    avx2: bool,
    tree: &B,
    ray: &PreparedRay,
    id: u32,
    memory: Memory<'_, B, S>,
    visitor: &mut V,
) -> f32
where
    B: Bvh,
    K: TriangleTest,
    V: Visitor,
    S: PendingStack<Pending<B>>,
{
    let one = OneRay::<B, K, V, S> {
        tree,
        ray,
        id,
        memory,
        visitor,
        kernel: std::marker::PhantomData,
    };
    avx2::run(one, avx2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{AabbTree, BuildOptions, BvhScratch};
    use crate::geom::{Kernel, KernelTask, Ray};
    use crate::hit::{Closest, Hit};
    use crate::test_support::{bunny, random_rays};

    /// Runs one closest-hit ray through a chosen copy of the loop.
    struct Both<'a> {
        tree: &'a AabbTree,
        ray: &'a PreparedRay,
        portable: bool,
    }

    impl KernelTask for Both<'_> {
        type Output = Option<Hit>;
        fn run<K: TriangleTest>(self) -> Option<Hit> {
            let mut best = [Hit::none_before(self.ray.tmax)];
            let BvhScratch { stack, cache, .. } = &mut BvhScratch::default();
            let mut visitor = Closest { best: &mut best };
            let (tree, ray) = (self.tree, self.ray);
            trace::<_, K, _, _>(!self.portable, tree, ray, 0, (stack, cache), &mut visitor);
            best[0].found()
        }
    }

    /// The run-time dispatched loop (AVX2 where available) and the baseline one agree bit for
    /// bit.
    #[test]
    fn dispatched_and_portable_traversals_agree() {
        #[cfg(target_arch = "x86_64")]
        crate::x86::Avx2::detect_or_note(
            "the dispatched loop is the portable one, compared with itself",
        );
        let mesh = bunny();
        let tree: AabbTree = AabbTree::build(mesh.clone(), &BuildOptions::default()).unwrap();
        let rays: Vec<Ray> = random_rays(&mesh, 20_000, 3);
        for kernel in Kernel::ALL {
            for ray in &rays {
                let prepared = PreparedRay::new(ray).unwrap();
                let run = |portable| {
                    let task = Both {
                        tree: &tree,
                        ray: &prepared,
                        portable,
                    };
                    kernel.dispatch(prepared.kz as usize, task)
                };
                let bits = |h: Option<Hit>| {
                    h.map(|h| (h.t.to_bits(), h.triangle, h.u.to_bits(), h.v.to_bits()))
                };
                assert_eq!(bits(run(false)), bits(run(true)), "{ray:?}");
            }
        }
    }
}
