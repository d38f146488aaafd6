//! The single-ray loop compiled twice: for the baseline instruction set and with AVX2, picked
//! at run time.
//!
//! With AVX2 the box test gets wider blends and three-operand instructions. Both copies perform
//! the same IEEE operations in the same order (Rust never fuses a multiply and an add on its
//! own), so they return identical bits; a test compares them. Trees whose
//! [`Bvh::AVX2_TRAVERSAL`] is false (measured slower that way) always run the baseline copy.

use super::single;
use crate::bvh::{Bvh, BvhScratch};
use crate::geom::{PreparedRay, TriangleTest};
use crate::hit::Visitor;

/// [`single::trace`], in the AVX2 copy where the CPU has AVX2 and the tree wants it.
#[inline]
pub(crate) fn trace<B: Bvh, K: TriangleTest, V: Visitor>(
    tree: &B,
    ray: &PreparedRay,
    id: u32,
    scratch: &mut BvhScratch<B::Cache>,
    visitor: &mut V,
) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if B::AVX2_TRAVERSAL && std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, the only requirement of `trace_avx2`.
        return unsafe { trace_avx2::<B, K, V>(tree, ray, id, scratch, visitor) };
    }
    trace_portable::<B, K, V>(tree, ray, id, scratch, visitor)
}

/// [`single::trace`] compiled for the baseline instruction set.
pub(crate) fn trace_portable<B: Bvh, K: TriangleTest, V: Visitor>(
    tree: &B,
    ray: &PreparedRay,
    id: u32,
    scratch: &mut BvhScratch<B::Cache>,
    visitor: &mut V,
) -> f32 {
    single::trace::<B, K, V>(tree, ray, id, scratch, visitor)
}

/// [`single::trace`] compiled with AVX2 enabled.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn trace_avx2<B: Bvh, K: TriangleTest, V: Visitor>(
    tree: &B,
    ray: &PreparedRay,
    id: u32,
    scratch: &mut BvhScratch<B::Cache>,
    visitor: &mut V,
) -> f32 {
    single::trace::<B, K, V>(tree, ray, id, scratch, visitor)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{AabbTree, BuildOptions};
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
            let mut scratch = BvhScratch::default();
            let mut visitor = Closest { best: &mut best };
            let (tree, ray) = (self.tree, self.ray);
            if self.portable {
                trace_portable::<_, K, _>(tree, ray, 0, &mut scratch, &mut visitor);
            } else {
                trace::<_, K, _>(tree, ray, 0, &mut scratch, &mut visitor);
            }
            best[0].found()
        }
    }

    /// The run-time dispatched loop (AVX2 where available) and the baseline one agree bit for
    /// bit.
    #[test]
    fn dispatched_and_portable_traversals_agree() {
        #[cfg(target_arch = "x86_64")]
        if !std::arch::is_x86_feature_detected!("avx2") {
            // Written to stderr directly so the test harness shows it even on success.
            let _ = std::io::Write::write_all(
                &mut std::io::stderr(),
                b"note: this CPU lacks AVX2: the dispatched loop is the portable one, compared with itself\n",
            );
        }
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
