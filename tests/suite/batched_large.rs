//! The batched queries against the single-ray reference, bit for bit, on large batches:
//! 100,000 hard and random rays over several structures and option combinations, and a million
//! incoherent rays on the Stanford bunny with the default options.

use std::sync::Arc;

use crate::common::batch::{
    Combo, GARBAGE, Threads, all_combos, batched_closest, batched_hits, batched_occluded,
    compare_closest, compare_hits, compare_occluded, ok, single_ray_answers, spread_combos,
};
use crate::common::meshes::{bunny, icosphere, icosphere_with_duplicates};
use crate::common::oracles::{HitBits, opt_bits};
use crate::common::rays::{hard_rays, incoherent, with_range_variant};
use crate::common::rng::{in_cube, seeded};
use crate::common::tier::Tier;
use crate::common::zoo::{LEAF_SIZES, all_structures, build};
use raybatch::{
    AabbTree, AccelKind, BatchQueries, BuildOptions, ChildOrdering, Kernel, RayQueries,
};
use rayon::prelude::*;

/// 100,000 rays (20,000 in the sample: the hard rays of an icosphere with duplicates, then
/// random rays through its bounds, some with `tmin = 0.3 tmax`) on three structures of each
/// kind (each leaf size and each ordering once per kind): every query with one combination,
/// closest and any hit with another.
fn large_batches(tier: Tier) {
    let count = tier.pick(20_000, 100_000);
    let mesh = icosphere_with_duplicates(3);
    let mut rays = hard_rays(&mesh, 9);
    let mut rng = seeded(10);
    while rays.len() < count {
        let (origin, target) = (in_cube(&mut rng, 2.0), in_cube(&mut rng, 1.0));
        rays.push(with_range_variant(rays.len(), origin, target));
    }
    rays.truncate(count);
    let zoo = all_structures(&mesh);
    let all = all_combos(1, 0);
    // Per kind: leaf 1 fixed, leaf 4 split-axis, leaf 16 PNS (the zoo is kind-major, then leaf
    // size, then ordering).
    let per_kind = LEAF_SIZES.len() * ChildOrdering::ALL.len();
    let picks: Vec<usize> = (0..AccelKind::ALL.len())
        .flat_map(|k| [0, 4, 8].map(|i| k * per_kind + i))
        .collect();
    assert_eq!(picks[..6], [0, 4, 8, 9, 13, 17]);
    for (n, t) in picks.into_iter().enumerate() {
        let tree = &zoo[t];
        let kernel = Kernel::ALL[n % 2];
        let exp = single_ray_answers(&*tree.accel, &rays, kernel);
        let mut combos: Vec<Combo> = spread_combos(&all, t, 32)
            .into_iter()
            .filter(|c| c.kernel == kernel && c.max_chunk != 1)
            .take(2)
            .collect();
        assert_eq!(combos.len(), 2);
        combos[0].min_chunk = 4096;
        for (j, combo) in combos.iter().enumerate() {
            let what = format!("{} {combo:?} ({count} rays)", tree.name);
            let closest = batched_closest(tree, &rays, combo).unwrap();
            ok(compare_closest(&what, &rays, &closest, &exp.closest));
            let occluded = batched_occluded(tree, &rays, combo).unwrap();
            ok(compare_occluded(&what, &rays, &occluded, &exp.occluded));
            if j == 0 {
                let hits = batched_hits(tree, &rays, combo);
                ok(compare_hits(&what, &rays, &hits, &exp.hits));
            }
        }
    }
}

#[test]
fn large_batches_sample() {
    large_batches(Tier::Sample);
}

#[test]
#[ignore = "heavy: 100,000 rays on three structures of each kind (the full tier)"]
fn hundred_thousand_rays() {
    large_batches(Tier::Full);
}

/// Closest hit of `count` incoherent rays on the Stanford bunny, batched with the default
/// options (parallel, global pool) against the single-ray path, on the typed `AabbTree`.
fn bunny_closest(count: usize) {
    let mesh = bunny();
    let rays = incoherent(&mesh, count, &mut seeded(42));
    assert_eq!(rays.len(), count);
    let tree: AabbTree = AabbTree::build(mesh, &BuildOptions::default()).unwrap();
    let expected: Vec<Option<HitBits>> = rays
        .par_iter()
        .map(|r| opt_bits(RayQueries::cast_ray(&tree, r)))
        .collect();
    let mut hits = vec![Some(GARBAGE); count];
    BatchQueries::cast_ray_batch(&tree, &rays, &mut hits).unwrap();
    ok(compare_closest(
        &format!("bunny, {count} incoherent rays, default options"),
        &rays,
        &hits,
        &expected,
    ));
    assert!(expected.iter().filter(|h| h.is_some()).count() > count / 10);
}

#[test]
fn bunny_incoherent_closest_sample() {
    bunny_closest(100_000);
}

#[test]
#[ignore = "heavy: a million rays (the full tier)"]
fn bunny_1m_incoherent_closest() {
    bunny_closest(1_000_000);
}

/// The grids and the kd-tree walk a batch in Morton order of the rays' origins once structure
/// and mesh pass 16 MiB (`traverse::origin_order`; below it, in the stream's order): over an
/// icosphere of 1.3M triangles (24 MB of mesh), closest, any and every hit of 20,000 rays
/// (origins inside and around the sphere), batched with two option combinations (one
/// sequential with small chunks, one on a pool) against the single-ray path, bit for bit.
#[test]
fn origin_order_on_a_large_mesh() {
    let mesh = Arc::new(icosphere(8));
    assert!(mesh.heap_bytes() > 16 << 20);
    let rays = incoherent(&mesh, 20_000, &mut seeded(77));
    let all = all_combos(1, 0);
    for kind in [AccelKind::Grid, AccelKind::Hash, AccelKind::Kd] {
        let name = format!("{} over a 1.3M-triangle icosphere", kind.name());
        let tree = build(&mesh, kind, &BuildOptions::default(), name);
        let exp = single_ray_answers(&*tree.accel, &rays, Kernel::Watertight);
        let combos = all.iter().filter(|c| c.kernel == Kernel::Watertight);
        let sequential = combos
            .clone()
            .find(|c| c.threads == Threads::Sequential && c.max_chunk > 1 && c.max_chunk < 20_000)
            .expect("a sequential combination with small chunks");
        let pooled = combos
            .clone()
            .find(|c| c.threads != Threads::Sequential && c.max_chunk >= 20_000)
            .expect("a combination on a pool");
        for combo in [sequential, pooled] {
            let what = format!("{} {combo:?}", tree.name);
            let closest = batched_closest(&tree, &rays, combo).unwrap();
            ok(compare_closest(&what, &rays, &closest, &exp.closest));
            let occluded = batched_occluded(&tree, &rays, combo).unwrap();
            ok(compare_occluded(&what, &rays, &occluded, &exp.occluded));
            let hits = batched_hits(&tree, &rays, combo);
            ok(compare_hits(&what, &rays, &hits, &exp.hits));
        }
    }
}
