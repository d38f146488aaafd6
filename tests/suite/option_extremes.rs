//! Every public option struct with NaN, infinities, zeros and extremes in its fields: a build
//! either fails with a typed error or gives a structure that answers exactly (brute force, per
//! ray and batched); batch options never change an answer. Never a panic.

use crate::common::meshes::icosphere_with_duplicates;
use crate::common::oracles::opt_bits;
use crate::common::rays::hard_rays;
use proptest::prelude::*;
use raybatch::{
    AccelKind, BatchOptions, BatchOrdering, BatchQueries, BuildOptions, ChildOrdering, GridOptions,
    HybridOptions, HybridTree, Interleave, Kernel, LeafCopy, Mesh, PartitionKernel, Ray,
    RayQueries, SpatialHash, UniformGrid, ZbtOptions, ZeroByteTree, brute_force,
};

fn extreme_u32() -> impl Strategy<Value = u32> {
    prop::sample::select(vec![0, 1, 2, 3, 8, 16, 17, 1 << 20, u32::MAX])
}

fn extreme_usize() -> impl Strategy<Value = usize> {
    prop::sample::select(vec![0, 1, 2, 7, 8, 4096, 1 << 20, usize::MAX])
}

fn extreme_f32() -> impl Strategy<Value = f32> {
    prop::sample::select(vec![
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.0,
        -0.0,
        -1.0,
        f32::MIN_POSITIVE,
        1e-30,
        0.1,
        2.0,
        1e30,
        f32::MAX,
    ])
}

fn mesh() -> Mesh {
    icosphere_with_duplicates(1)
}

/// Closest hits of `rays`: brute force's, per ray and batched (with `batch`).
fn exact<A: RayQueries + BatchQueries>(
    name: &str,
    tree: &A,
    mesh: &Mesh,
    rays: &[Ray],
    batch: &BatchOptions,
) -> Result<(), TestCaseError> {
    let mut batched = vec![None; rays.len()];
    tree.cast_ray_batch_with(rays, &mut batched, batch)
        .map_err(|e| TestCaseError::fail(e.to_string()))?;
    for (ray, b) in rays.iter().zip(&batched) {
        let expected = opt_bits(brute_force::cast_ray(mesh, ray, Kernel::Watertight));
        prop_assert_eq!(opt_bits(tree.cast_ray(ray)), expected, "{} per ray", name);
        prop_assert_eq!(opt_bits(*b), expected, "{} batched", name);
    }
    Ok(())
}

fn some_rays(mesh: &Mesh) -> Vec<Ray> {
    hard_rays(mesh, 5).into_iter().step_by(7).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn build_options(
        max_leaf_size in extreme_u32(),
        wide_leaf_size in extreme_u32(),
        ordering in prop::sample::select(ChildOrdering::ALL.to_vec()),
        leaf_copy in prop::sample::select(LeafCopy::ALL.to_vec()),
        parallel in any::<bool>(),
    ) {
        let options = BuildOptions { max_leaf_size, ordering, parallel, leaf_copy, wide_leaf_size };
        let mesh = mesh();
        let rays = some_rays(&mesh);
        for kind in AccelKind::ALL {
            match kind.build(mesh.clone(), &options) {
                Ok(tree) => exact(kind.name(), &tree, &mesh, &rays, &BatchOptions::default())?,
                Err(e) => prop_assert!(options.validate().is_err(), "{}: {e}", kind.name()),
            }
        }
    }

    #[test]
    fn grid_options(
        cells_per_triangle in extreme_f32(),
        max_cells in extreme_u32().prop_map(|n| n.min(1 << 24)),
        resolution in prop::option::of(prop::array::uniform3(extreme_u32())),
        shaped_cells in any::<bool>(),
    ) {
        let options = GridOptions { cells_per_triangle, max_cells, resolution, shaped_cells };
        let mesh = mesh();
        let rays = some_rays(&mesh);
        let valid = options.validate().is_ok();
        match UniformGrid::build(mesh.clone(), &options) {
            Ok(grid) => exact("grid", &grid, &mesh, &rays, &BatchOptions::default())?,
            Err(e) => prop_assert!(!valid, "grid: {e}"),
        }
        match SpatialHash::build(mesh.clone(), &options) {
            Ok(hash) => exact("hash", &hash, &mesh, &rays, &BatchOptions::default())?,
            Err(e) => prop_assert!(!valid, "hash: {e}"),
        }
    }

    #[test]
    fn zero_byte_options(
        leaf_size in extreme_u32(),
        inherit_slack in extreme_f32(),
        box_cache in any::<bool>(),
        ordering in prop::sample::select(ChildOrdering::ALL.to_vec()),
        parallel in any::<bool>(),
        chunk_size in extreme_u32(),
    ) {
        let zbt = ZbtOptions { leaf_size, inherit_slack, box_cache, ordering, parallel };
        let mesh = mesh();
        let rays = some_rays(&mesh);
        if let Ok((tree, _)) = ZeroByteTree::build(mesh.clone(), &zbt) {
            exact("zbt", &tree, &tree.to_mesh(), &rays, &BatchOptions::default())?;
        }
        if let Ok((tree, _)) = HybridTree::build(mesh.clone(), &HybridOptions { zbt, chunk_size }) {
            exact("hybrid", &tree, &tree.to_mesh(), &rays, &BatchOptions::default())?;
        }
    }

    #[test]
    fn batch_options(
        ordering in prop::sample::select(BatchOrdering::ALL.to_vec()),
        parallel in any::<bool>(),
        min_batch in extreme_usize(),
        min_chunk in extreme_usize(),
        max_chunk in prop::option::of(extreme_usize()),
        single_ray_below in extreme_usize(),
        packet_from in extreme_usize(),
        partition in prop::sample::select(PartitionKernel::ALL.to_vec()),
        interleave in prop::sample::select(Interleave::ALL.to_vec()),
    ) {
        let batch = BatchOptions {
            kernel: Kernel::Watertight,
            ordering,
            parallel,
            min_batch,
            min_chunk,
            max_chunk,
            single_ray_below,
            packet_from,
            partition,
            interleave,
        };
        let mesh = mesh();
        let rays = some_rays(&mesh);
        for kind in AccelKind::ALL {
            let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
            exact(kind.name(), &tree, &mesh, &rays, &batch)?;
        }
    }
}
