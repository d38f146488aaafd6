//! Quantized vertices: a tree over a quantized mesh answers exactly like brute force over the
//! dequantized mesh (every query, both kernels, both node formats, batched == per ray), every
//! decoded vertex is within half a grid step of the original, and the visit counter changes
//! no answer.

use std::sync::Arc;

use crate::common::meshes::bunny;
use crate::common::oracles::{compare_all, describe, opt_bits};
use crate::common::rays::incoherent;
use crate::common::rng::seeded;
use crate::common::strategies::{RaySpec, mesh_strategy, ray_spec};
use crate::common::zoo::Built;
use proptest::prelude::*;
use raybatch::QuantizedVertexTree;
use raybatch::mesh::quantized::QuantizedMesh;
use raybatch::{AabbTree, BuildOptions, Hit, Kernel, Mesh, QuantizedAabbTree, RayQueries, Visitor};

/// Trees over `q` with leaf sizes 1, 4 and 16.
fn trees(q: &QuantizedMesh) -> Vec<Built> {
    [1, 4, 16]
        .into_iter()
        .map(|leaf| {
            let options = BuildOptions::default().with_leaf_size(leaf);
            Built {
                name: format!("qv{}/leaf{leaf}", q.grid().bits),
                accel: Box::new(QuantizedVertexTree::build(q.clone(), &options).unwrap()),
            }
        })
        .collect()
}

fn check(mesh: &Mesh, bits: u32, specs: &[RaySpec]) -> Result<(), TestCaseError> {
    let q = QuantizedMesh::new(mesh, bits).unwrap();
    let decoded = q.dequantize();
    let half = q.grid().max_error().as_dvec3();
    for (i, v) in mesh.vertices().iter().enumerate() {
        let err = (q.vertex(i as u32).as_dvec3() - v.as_dvec3()).abs();
        prop_assert!(err.cmple(half).all(), "vertex {i}: error {err} > {half}");
    }
    let zoo = trees(&q);
    let rays: Vec<_> = specs.iter().map(|s| s.resolve(&decoded)).collect();
    for ray in &rays {
        compare_all(&decoded, &zoo, ray).map_err(|e| {
            TestCaseError::fail(format!("{bits} bits: {e}\nmesh: {}", describe(&decoded)))
        })?;
    }
    for t in &zoo {
        let mut batched = vec![None; rays.len()];
        t.accel.cast_ray_batch(&rays, &mut batched).unwrap();
        for (ray, b) in rays.iter().zip(batched) {
            prop_assert_eq!(opt_bits(b), opt_bits(t.accel.cast_ray(ray)), "{}", t.name);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Random soups (shared, degenerate, duplicated, coplanar triangles, sometimes over a
    /// closed icosphere) at 16, 10, 8 bits and coarser, random rays.
    #[test]
    fn quantized_trees_match_brute_force_over_the_dequantized_mesh(
        mesh in mesh_strategy(),
        bits in prop_oneof![Just(16u32), Just(10), Just(8), 1u32..=16],
        specs in prop::collection::vec(ray_spec(), 24),
    ) {
        check(&mesh, bits, &specs)?;
    }
}

#[test]
fn bunny_at_16_bits_half_the_vertex_bytes_and_exact_for_its_mesh() {
    let mesh = bunny();
    let q = QuantizedMesh::new(&mesh, 16).unwrap();
    assert!(2 * q.vertex_bytes() <= size_of_val(mesh.vertices()));
    let tree = QuantizedVertexTree::build(q.clone(), &BuildOptions::default()).unwrap();
    let exact: AabbTree = AabbTree::build(q.dequantize(), &BuildOptions::default()).unwrap();
    let rays = incoherent(&mesh, 2_000, &mut seeded(16));
    for ray in &rays {
        assert_eq!(
            opt_bits(tree.cast_ray(ray)),
            opt_bits(exact.cast_ray(ray)),
            "{ray:?}"
        );
    }
}

/// Counts the nodes an all-hits walk enters (a visitor of the caller's that keeps no hit).
#[derive(Default)]
struct NodesEntered(u32);

impl Visitor for NodesEntered {
    const COUNTS_NODES: bool = true;
    fn visit(&mut self, _: u32, _: Hit, _: &mut f32) {}
    fn enter_node(&mut self, _: u32) {
        self.0 += 1;
    }
}

/// Quantized node boxes contain the full ones over the same topology, so an all-hits walk
/// enters at least as many of them; counting changes no answer.
#[test]
fn quantized_boxes_are_entered_at_least_as_often() {
    let mesh = Arc::new(bunny());
    let options = BuildOptions::default();
    let full: AabbTree = AabbTree::build(mesh.clone(), &options).unwrap();
    let quantized = QuantizedAabbTree::build(mesh.clone(), &options).unwrap();
    let rays = incoherent(&mesh, 2_000, &mut seeded(17));
    let mut entered = 0;
    for ray in &rays {
        let expected = opt_bits(full.cast_ray(ray));
        let (visited, _) = full.cast_ray_visits(ray, Kernel::Watertight);
        assert_eq!(opt_bits(visited), expected);
        let (a, b) = (&mut NodesEntered::default(), &mut NodesEntered::default());
        full.visit(ray, Kernel::Watertight, a);
        quantized.visit(ray, Kernel::Watertight, b);
        assert!(b.0 >= a.0, "{ray:?}");
        entered += a.0;
    }
    assert!(entered > 0);
}
