//! The typed API against the dynamic one. The zoo reaches every structure through `AnyAccel`;
//! this checks that each kind's concrete tree (reached with `AnyAccel::run`), queried through
//! its own impls of the query traits (`RayQueries`, `BatchQueries`, `Footprint`,
//! default-kernel entry points included), answers bit for bit like the `AnyAccel`. Together with the zoo's
//! comparisons with brute force, the typed methods are held to the same reference.

use std::sync::{Arc, Mutex};

use crate::common::meshes::icosphere_with_duplicates;
use crate::common::oracles::{HitBits, all_bits, bits, opt_bits};
use crate::common::rays::hard_rays;
use crate::common::zoo::LEAF_SIZES;
use raybatch::{
    AccelKind, AnyAccel, BatchOptions, BatchOrdering, BatchQueries, BuildOptions, ChildOrdering,
    Footprint, Hit, Kernel, KindTask, Ray, RayQueries, Structure,
};

/// Every hit of a batch as sorted `(ray index, hit bits)`.
fn sorted_batch_hits(each: impl FnOnce(&(dyn Fn(usize, Hit) + Sync))) -> Vec<(usize, HitBits)> {
    let sink = Mutex::new(Vec::new());
    each(&|i, h| sink.lock().unwrap().push((i, bits(&h))));
    let mut hits = sink.into_inner().unwrap();
    hits.sort_unstable();
    hits
}

/// Compares every query of `typed` (through the generic traits) with `any`, bit for bit.
fn compare_typed<T: RayQueries + BatchQueries + Footprint>(
    name: &str,
    typed: &T,
    any: &AnyAccel,
    rays: &[Ray],
) -> Result<(), String> {
    let footprint = |f: &dyn Footprint| {
        (
            f.name(),
            f.triangle_count(),
            f.node_count(),
            f.heap_bytes(),
            f.id_map_bytes(),
            f.bytes_per_triangle().to_bits(),
        )
    };
    if footprint(typed) != footprint(any) {
        return Err(format!(
            "{name}: footprint {:?}, AnyAccel {:?}",
            footprint(typed),
            footprint(any)
        ));
    }
    for ray in rays {
        let sorted = |mut v: Vec<HitBits>| {
            v.sort_unstable();
            v
        };
        let mut typed_each = Vec::new();
        RayQueries::for_each_hit(typed, ray, |h| typed_each.push(bits(&h)));
        let mut any_each = Vec::new();
        any.for_each_hit(ray, |h| any_each.push(bits(&h)));
        let default_kernel = (
            opt_bits(RayQueries::cast_ray(typed, ray)),
            RayQueries::occluded(typed, ray),
            all_bits(&RayQueries::all_hits(typed, ray)),
            sorted(typed_each),
        );
        let expected = (
            opt_bits(any.cast_ray(ray)),
            any.occluded(ray),
            all_bits(&any.all_hits(ray)),
            sorted(any_each),
        );
        if default_kernel != expected {
            return Err(format!(
                "{name}: typed default-kernel queries {default_kernel:?}, AnyAccel {expected:?} \
                 for {ray:?}"
            ));
        }
        for kernel in Kernel::ALL {
            let mut typed_each = Vec::new();
            RayQueries::for_each_hit_with(typed, ray, kernel, &mut |h| typed_each.push(bits(&h)));
            let mut any_each = Vec::new();
            any.for_each_hit_with(ray, kernel, &mut |h| any_each.push(bits(&h)));
            let got = (
                opt_bits(RayQueries::cast_ray_with(typed, ray, kernel)),
                RayQueries::occluded_with(typed, ray, kernel),
                sorted(typed_each),
            );
            let expected = (
                opt_bits(any.cast_ray_with(ray, kernel)),
                any.occluded_with(ray, kernel),
                sorted(any_each),
            );
            if got != expected {
                return Err(format!(
                    "{name} {kernel:?}: typed {got:?}, AnyAccel {expected:?} for {ray:?}"
                ));
            }
        }
    }

    // Batched: the default entry points, then explicit options.
    let n = rays.len();
    let (mut typed_hits, mut any_hits) = (vec![None; n], vec![None; n]);
    let (mut typed_occ, mut any_occ) = (vec![false; n], vec![true; n]);
    BatchQueries::cast_ray_batch(typed, rays, &mut typed_hits).map_err(|e| e.to_string())?;
    any.cast_ray_batch(rays, &mut any_hits)
        .map_err(|e| e.to_string())?;
    BatchQueries::occluded_batch(typed, rays, &mut typed_occ).map_err(|e| e.to_string())?;
    any.occluded_batch(rays, &mut any_occ)
        .map_err(|e| e.to_string())?;
    let typed_all = sorted_batch_hits(|f| BatchQueries::for_each_hit_batch(typed, rays, f));
    let any_all = sorted_batch_hits(|f| any.for_each_hit_batch(rays, f));
    let as_bits = |v: &[Option<Hit>]| v.iter().map(|h| opt_bits(*h)).collect::<Vec<_>>();
    if as_bits(&typed_hits) != as_bits(&any_hits) || typed_occ != any_occ || typed_all != any_all {
        return Err(format!(
            "{name}: typed default batched queries differ from AnyAccel"
        ));
    }
    for kernel in Kernel::ALL {
        let options = BatchOptions::default()
            .with_kernel(kernel)
            .with_ordering(BatchOrdering::Unordered)
            .with_parallel(false)
            .with_min_batch(0)
            .with_max_chunk(64);
        BatchQueries::cast_ray_batch_with(typed, rays, &mut typed_hits, &options)
            .map_err(|e| e.to_string())?;
        any.cast_ray_batch_with(rays, &mut any_hits, &options)
            .map_err(|e| e.to_string())?;
        BatchQueries::occluded_batch_with(typed, rays, &mut typed_occ, &options)
            .map_err(|e| e.to_string())?;
        any.occluded_batch_with(rays, &mut any_occ, &options)
            .map_err(|e| e.to_string())?;
        let typed_all =
            sorted_batch_hits(|f| BatchQueries::for_each_hit_batch_with(typed, rays, &options, f));
        let any_all = sorted_batch_hits(|f| any.for_each_hit_batch_with(rays, &options, f));
        if as_bits(&typed_hits) != as_bits(&any_hits)
            || typed_occ != any_occ
            || typed_all != any_all
        {
            return Err(format!(
                "{name} {options:?}: typed batched queries differ from AnyAccel"
            ));
        }
    }
    Ok(())
}

/// Compares the concrete tree inside an [`AnyAccel`] with the `AnyAccel` itself.
struct CompareTyped<'a> {
    name: &'a str,
    any: &'a AnyAccel,
    rays: &'a [Ray],
}

impl KindTask for CompareTyped<'_> {
    type Output = Result<(), String>;
    fn run<A: Structure>(self, kind: AccelKind, typed: &A) -> Self::Output {
        assert_eq!(kind, self.any.kind(), "{}", self.name);
        compare_typed(self.name, typed, self.any, self.rays)
    }
}

/// Every kind, leaf size and ordering: the concrete tree answers as its `AnyAccel` does.
#[test]
fn typed_queries_match_any_accel() {
    let mesh = Arc::new(icosphere_with_duplicates(1));
    let rays = hard_rays(&mesh, 12);
    for kind in AccelKind::ALL {
        assert_eq!(AccelKind::from_name(kind.name()), Some(kind));
        for leaf in LEAF_SIZES {
            for ordering in ChildOrdering::ALL {
                let options = BuildOptions::default()
                    .with_leaf_size(leaf)
                    .with_ordering(ordering);
                let name = format!("{}/leaf{leaf}/{}", kind.name(), ordering.name());
                let any = kind.build(mesh.clone(), &options).unwrap();
                let task = CompareTyped {
                    name: &name,
                    any: &any,
                    rays: &rays,
                };
                if let Err(e) = any.run(task) {
                    panic!("{e}");
                }
            }
        }
    }
}

/// `AnyAccel::triangle` gives the corners of the triangle a hit names, in the mesh's own ids
/// for every kind (the zero-byte trees, which reorder their mesh, included), and `None` past
/// the last triangle.
#[test]
fn triangle_gives_the_corners_of_the_mesh_triangle_of_each_id() {
    let mesh = Arc::new(icosphere_with_duplicates(2));
    let count = mesh.triangle_count() as u32;
    for kind in AccelKind::ALL {
        let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        for id in 0..count {
            assert_eq!(tree.triangle(id), Some(mesh.triangle(id)), "{kind:?} {id}");
        }
        assert_eq!(tree.triangle(count), None, "{kind:?}");
        assert_eq!(tree.triangle(u32::MAX), None, "{kind:?}");
    }
}
