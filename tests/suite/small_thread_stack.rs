//! Queries on a thread with a small stack (64 KiB, as some game engines give their workers)
//! answer as on the main thread: the one-ray walks that keep their stack on the call stack
//! (the wide trees, the binary trees traced alone) and the workspace a thread makes on its
//! first query must fit in it.

use crate::common::meshes::bunny;
use crate::common::oracles::{HitBits, opt_bits};
use crate::common::rays::incoherent;
use crate::common::rng::seeded;
use raybatch::{AccelKind, AnyAccel, BatchOptions, BuildOptions, Ray};
use raybatch::{BatchQueries, RayQueries};

/// The stack of the small thread.
const SMALL_STACK: usize = 64 * 1024;

/// Per-ray closest hits and occlusion, and batched closest hits (on the calling thread).
type Answers = (Vec<Option<HitBits>>, Vec<bool>, Vec<Option<HitBits>>);

fn answers(tree: &AnyAccel, rays: &[Ray]) -> Answers {
    let closest = rays
        .iter()
        .map(|ray| opt_bits(tree.cast_ray(ray)))
        .collect();
    let occluded = rays.iter().map(|ray| tree.occluded(ray)).collect();
    let mut batched = vec![None; rays.len()];
    let options = BatchOptions::default().with_parallel(false);
    tree.cast_ray_batch_with(rays, &mut batched, &options)
        .expect("lengths match");
    let batched = batched.into_iter().map(opt_bits).collect();
    (closest, occluded, batched)
}

#[test]
fn queries_on_a_64_kib_thread_match_the_main_thread() {
    let mesh = bunny();
    let rays = incoherent(&mesh, 3_000, &mut seeded(64));
    for kind in [
        AccelKind::Bvh4,
        AccelKind::Bvh8,
        AccelKind::Aabb,
        AccelKind::Zbt,
    ] {
        let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        let expected = answers(&tree, &rays);
        let small = std::thread::scope(|scope| {
            std::thread::Builder::new()
                .stack_size(SMALL_STACK)
                .spawn_scoped(scope, || answers(&tree, &rays))
                .expect("a thread starts")
                .join()
                .expect("the small thread's queries do not overflow its stack")
        });
        assert!(small == expected, "{}: answers differ", kind.name());
    }
}
