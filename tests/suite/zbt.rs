//! The zero-byte and hybrid trees through their own types (the zoo reaches them through the
//! catalog, which maps ids back): answers bit-identical to brute force over the tree's own
//! reordered mesh, per ray and batched; the permutation and the unpacked mesh; the limits, at
//! and past them, with the mesh handed back; the box cache shared by several trees.

use crate::common::meshes::{bunny, icosphere_all_duplicated, icosphere_with_duplicates, tri_mesh};
use crate::common::oracles::{HitBits, all_bits, opt_bits};
use crate::common::rays::hard_rays;
use crate::common::tier::Tier;
use glam::Vec3;
use raybatch::brute_force;
use raybatch::zbt::{HybridOptions, MAX_TRIANGLES, MAX_VERTICES, ZbtError, ZbtOptions};
use raybatch::{
    BatchOptions, BatchQueries, Footprint, HybridTree, Kernel, Mesh, Ray, RayQueries, ZeroByteTree,
};

/// At most about 1,500 of the mesh's hard rays, spread over all of them (brute force is slow).
fn some_hard_rays(mesh: &Mesh, seed: u64) -> Vec<Ray> {
    if mesh.vertices().is_empty() {
        return vec![
            Ray::new(Vec3::ZERO, Vec3::X),
            Ray::new(Vec3::ONE, -Vec3::ONE),
        ];
    }
    let rays = hard_rays(mesh, seed);
    let step = rays.len().div_ceil(1500);
    rays.into_iter().step_by(step).collect()
}

/// Every option combination worth telling apart.
fn zbt_options() -> Vec<ZbtOptions> {
    let mut all = Vec::new();
    for leaf_size in [1, 4, 8] {
        for inherit_slack in [0.0, 0.1, 1.0, f32::INFINITY] {
            for box_cache in [true, false] {
                all.push(ZbtOptions {
                    leaf_size,
                    inherit_slack,
                    box_cache,
                    ..ZbtOptions::default()
                });
            }
        }
    }
    all
}

/// Closest, any and all hits of `tree`, per ray and batched, equal bit for bit to brute force
/// over `mesh` (the tree's own triangle order). The batch shapes: the defaults (a batch this
/// small takes the single-ray path); the stream all the way down; the stream with the packet
/// walk finishing lists of 2-7 rays (the default engine); and lists below 1,000 rays finished
/// as packets from 5 rays up to 8 and one ray at a time otherwise.
fn check_against_brute_force<A: RayQueries + BatchQueries>(
    name: &str,
    tree: &A,
    mesh: &Mesh,
    rays: &[Ray],
) {
    let mut closest = Vec::with_capacity(rays.len());
    let mut occluded = Vec::with_capacity(rays.len());
    let mut all = Vec::with_capacity(rays.len());
    for ray in rays {
        closest.push(opt_bits(brute_force::cast_ray(
            mesh,
            ray,
            Kernel::Watertight,
        )));
        occluded.push(brute_force::occluded(mesh, ray, Kernel::Watertight));
        all.push(sorted(all_bits(&brute_force::all_hits(
            mesh,
            ray,
            Kernel::Watertight,
        ))));
    }
    for (i, ray) in rays.iter().enumerate() {
        assert_eq!(opt_bits(tree.cast_ray(ray)), closest[i], "{name} {ray:?}");
        assert_eq!(tree.occluded(ray), occluded[i], "{name} {ray:?}");
        assert_eq!(
            sorted(all_bits(&tree.all_hits(ray))),
            all[i],
            "{name} {ray:?}"
        );
    }
    let small_batches = BatchOptions::default().with_min_batch(1);
    for options in [
        BatchOptions::default(),
        small_batches.with_parallel(false).with_single_ray_below(1),
        small_batches,
        small_batches
            .with_single_ray_below(1000)
            .with_packet_from(5),
    ] {
        let mut batch_closest = vec![None; rays.len()];
        let mut batch_occluded = vec![false; rays.len()];
        tree.cast_ray_batch_with(rays, &mut batch_closest, &options)
            .unwrap();
        tree.occluded_batch_with(rays, &mut batch_occluded, &options)
            .unwrap();
        let batch_all = std::sync::Mutex::new(vec![Vec::new(); rays.len()]);
        tree.for_each_hit_batch_with(rays, &options, &|i, hit| {
            batch_all.lock().unwrap()[i].push(hit)
        });
        let batch_all = batch_all.into_inner().unwrap();
        for (i, ray) in rays.iter().enumerate() {
            let what = format!("{name} batched {options:?} {ray:?}");
            assert_eq!(opt_bits(batch_closest[i]), closest[i], "{what}");
            assert_eq!(batch_occluded[i], occluded[i], "{what}");
            assert_eq!(sorted(all_bits(&batch_all[i])), all[i], "{what}");
        }
    }
}

/// `hits` in one order (a batch reports a ray's hits in its visiting order).
fn sorted(mut hits: Vec<HitBits>) -> Vec<HitBits> {
    hits.sort_unstable();
    hits
}

/// The permutation is one, the vertices are untouched, each triangle keeps its corner order,
/// and the three ways to get the plain mesh back agree.
fn check_permutation(original: &Mesh, reordered: &Mesh, plain: &[[u32; 3]], perm: &[u32]) {
    assert_eq!(reordered.vertices(), original.vertices());
    assert_eq!(reordered.triangles(), plain);
    let mut seen = vec![false; original.triangle_count()];
    for (new, &old) in perm.iter().enumerate() {
        assert!(
            !std::mem::replace(&mut seen[old as usize], true),
            "{old} twice"
        );
        assert_eq!(
            reordered.triangles()[new],
            original.triangles()[old as usize]
        );
    }
    assert!(seen.iter().all(|&s| s));
}

fn meshes() -> Vec<(&'static str, Mesh)> {
    let bunny = bunny();
    let (v, t) = (
        bunny.vertices().to_vec(),
        bunny.triangles()[..6000].to_vec(),
    );
    vec![
        ("duplicates", icosphere_with_duplicates(2)),
        ("all-duplicated", icosphere_all_duplicated(1)),
        ("bunny-part", Mesh::new(v, t).unwrap()),
        (
            "degenerate",
            tri_mesh(
                &[
                    [0.0, 0.0, 1.0],
                    [1.0, 0.0, 1.0],
                    [0.0, 1.0, 1.0],
                    [2.0, 2.0, 1.0],
                ],
                &[[0, 0, 1], [0, 1, 2], [0, 1, 1], [1, 3, 2], [0, 1, 3]],
            ),
        ),
        ("empty", Mesh::new(vec![], vec![]).unwrap()),
    ]
}

/// Every mesh with every option combination in the full tier; in the sample, six per mesh,
/// different ones for each mesh, so that every combination runs on some mesh.
fn zero_byte_trees(tier: Tier) {
    let all = zbt_options();
    for (m, (mesh_name, mesh)) in meshes().into_iter().enumerate() {
        let rays = some_hard_rays(&mesh, 3);
        let options: Vec<ZbtOptions> = match tier {
            Tier::Sample => (0..6).map(|j| all[(m * 6 + j) % all.len()]).collect(),
            Tier::Full => all.clone(),
        };
        for options in options {
            let name = format!("zbt {mesh_name} {options:?}");
            let (tree, perm) = ZeroByteTree::build(mesh.clone(), &options).unwrap();
            assert_eq!(tree.heap_bytes(), 0);
            let reordered = tree.to_mesh();
            check_permutation(&mesh, &reordered, &tree.plain_triangles(), &perm);
            check_against_brute_force(&name, &tree, &reordered, &rays);
            assert_eq!(tree.into_mesh(), reordered);
        }
    }
}

#[test]
fn zero_byte_tree_answers_like_brute_force_sample() {
    assert!(meshes().len() * 6 >= zbt_options().len());
    zero_byte_trees(Tier::Sample);
}

#[test]
#[ignore = "heavy: every mesh with every option combination (the full tier)"]
fn zero_byte_tree_answers_like_brute_force_over_its_mesh() {
    zero_byte_trees(Tier::Full);
}

#[test]
fn hybrid_tree_answers_like_brute_force_over_its_mesh() {
    for (mesh_name, mesh) in meshes() {
        let rays = some_hard_rays(&mesh, 4);
        for chunk_size in [1, 7, 64, 512] {
            let options = HybridOptions {
                chunk_size,
                ..HybridOptions::default()
            };
            let name = format!("hybrid {mesh_name} chunk {chunk_size}");
            let (tree, perm) = HybridTree::build(mesh.clone(), &options).unwrap();
            let reordered = tree.to_mesh();
            check_permutation(&mesh, &reordered, &tree.plain_triangles(), &perm);
            check_against_brute_force(&name, &tree, &reordered, &rays);
        }
    }
}

/// The zero-byte tree reports the same hit distances as brute force over the original mesh,
/// and the same triangle through the permutation wherever no other triangle ties.
#[test]
fn same_hits_as_the_original_mesh_through_the_permutation() {
    let mesh = bunny();
    let rays: Vec<Ray> = some_hard_rays(&mesh, 5).into_iter().take(500).collect();
    let (tree, perm) = ZeroByteTree::build(mesh.clone(), &ZbtOptions::default()).unwrap();
    for ray in &rays {
        let expected = brute_force::cast_ray(&mesh, ray, Kernel::Watertight);
        let got = tree.cast_ray(ray);
        assert_eq!(got.map(|h| h.t.to_bits()), expected.map(|h| h.t.to_bits()));
        if let (Some(got), Some(expected)) = (got, expected) {
            let ties = brute_force::all_hits(&mesh, ray, Kernel::Watertight)
                .iter()
                .filter(|h| h.t == expected.t)
                .count();
            if ties == 1 {
                assert_eq!(perm[got.triangle as usize], expected.triangle);
                assert_eq!((got.u, got.v), (expected.u, expected.v));
            }
        }
    }
}

/// A mesh of `n` small disjoint triangles on a line (`n` distinct boxes), with `extra`
/// unused vertices appended.
fn strip(n: usize, extra: usize) -> Mesh {
    let mut vertices = Vec::with_capacity(3 * n + extra);
    for i in 0..n {
        let x = i as f32 * 2.0;
        vertices.extend([
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x + 1.0, 0.0, 0.0),
            Vec3::new(x, 1.0, 0.0),
        ]);
    }
    vertices.resize(3 * n + extra, Vec3::ZERO);
    let triangles = (0..n as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    Mesh::new(vertices, triangles).unwrap()
}

/// Rays straight down onto triangles `ids` of a [`strip`].
fn rays_onto(ids: &[usize]) -> Vec<Ray> {
    ids.iter()
        .map(|&i| Ray::new(Vec3::new(i as f32 * 2.0 + 0.25, 0.25, 1.0), -Vec3::Z))
        .collect()
}

#[test]
fn triangle_limit_exactly_and_one_past() {
    let at = strip(MAX_TRIANGLES, 0);
    let ids = [0, 1, MAX_TRIANGLES / 2, MAX_TRIANGLES - 1];
    let options = ZbtOptions::default();
    let (tree, perm) = ZeroByteTree::build(at, &options).unwrap();
    for (ray, &id) in rays_onto(&ids).iter().zip(&ids) {
        let hit = tree.cast_ray(ray).expect("a hit");
        assert_eq!(perm[hit.triangle as usize] as usize, id);
    }
    drop(tree);
    let past = strip(MAX_TRIANGLES + 1, 0);
    let rejected = ZeroByteTree::build(past.clone(), &options).unwrap_err();
    assert_eq!(
        rejected.error,
        ZbtError::TooManyTriangles {
            count: MAX_TRIANGLES + 1,
            max: MAX_TRIANGLES
        }
    );
    assert!(rejected.to_string().contains(&MAX_TRIANGLES.to_string()));
    assert_eq!(rejected.mesh, past, "the mesh is handed back unchanged");
    // The hybrid tree has no triangle limit.
    let (hybrid, perm) = HybridTree::build(past, &HybridOptions::default()).unwrap();
    let ids = [0, MAX_TRIANGLES];
    for (ray, &id) in rays_onto(&ids).iter().zip(&ids) {
        let hit = hybrid.cast_ray(ray).expect("a hit");
        assert_eq!(perm[hit.triangle as usize] as usize, id);
    }
}

#[test]
fn vertex_limit_exactly_and_one_past() {
    // The last triangle uses vertex MAX_VERTICES - 1: every bit of its indices is address.
    let mut at = strip(4, MAX_VERTICES - 12);
    let (mut vertices, mut triangles) = at.into_parts();
    let last = (MAX_VERTICES - 1) as u32;
    vertices[last as usize] = Vec3::new(4.0, 1.0, 0.0);
    triangles[2] = [6, 7, last];
    at = Mesh::new(vertices, triangles).unwrap();
    let (tree, perm) = ZeroByteTree::build(at.clone(), &ZbtOptions::default()).unwrap();
    let hit = tree.cast_ray(&rays_onto(&[2])[0]).expect("a hit");
    assert_eq!(perm[hit.triangle as usize], 2);
    assert!(tree.plain_triangles().contains(&[6, 7, last]));
    drop(tree);
    let (mut vertices, triangles) = at.into_parts();
    vertices.push(Vec3::ZERO);
    let past = Mesh::new(vertices, triangles).unwrap();
    for rejected in [
        ZeroByteTree::build(past.clone(), &ZbtOptions::default()).unwrap_err(),
        HybridTree::build(past.clone(), &HybridOptions::default()).unwrap_err(),
    ] {
        assert_eq!(
            rejected.error,
            ZbtError::TooManyVertices {
                count: MAX_VERTICES + 1,
                max: MAX_VERTICES
            }
        );
        assert_eq!(rejected.mesh, past);
    }
}

#[test]
fn bad_options_are_typed_errors() {
    let mesh = icosphere_with_duplicates(1);
    for leaf_size in [0, 9, u32::MAX] {
        let options = ZbtOptions {
            leaf_size,
            ..ZbtOptions::default()
        };
        let rejected = ZeroByteTree::build(mesh.clone(), &options).unwrap_err();
        assert_eq!(rejected.error, ZbtError::BadLeafSize(leaf_size));
        assert_eq!(rejected.mesh, mesh);
    }
    for chunk_size in [0, MAX_TRIANGLES as u32 + 1] {
        let options = HybridOptions {
            chunk_size,
            ..HybridOptions::default()
        };
        let rejected = HybridTree::build(mesh.clone(), &options).unwrap_err();
        assert_eq!(rejected.error, ZbtError::BadChunkSize(chunk_size));
    }
}

/// Trees queried in turn on one thread share its box cache; entries are tagged by tree, so a
/// tree never sees another's boxes, even one built over a moved copy of the same mesh (same
/// node indices, other boxes) after the first was dropped.
#[test]
fn box_cache_is_shared_but_never_mixes_trees() {
    let mesh = icosphere_with_duplicates(2);
    let moved = Mesh::new(
        mesh.vertices().iter().map(|&v| v * 0.5 + 0.3).collect(),
        mesh.triangles().to_vec(),
    )
    .unwrap();
    let rays = some_hard_rays(&mesh, 6);
    let options = ZbtOptions::default();
    let (a, _) = ZeroByteTree::build(mesh.clone(), &options).unwrap();
    let (b, _) = ZeroByteTree::build(moved.clone(), &options).unwrap();
    let (a_mesh, b_mesh) = (a.to_mesh(), b.to_mesh());
    for ray in &rays {
        for (tree, tree_mesh) in [(&a, &a_mesh), (&b, &b_mesh)] {
            let expected = brute_force::cast_ray(tree_mesh, ray, Kernel::Watertight);
            assert_eq!(opt_bits(tree.cast_ray(ray)), opt_bits(expected));
        }
    }
    drop(a);
    let (c, _) = ZeroByteTree::build(moved, &options).unwrap();
    let c_mesh = c.to_mesh();
    for ray in &rays {
        let expected = brute_force::cast_ray(&c_mesh, ray, Kernel::Watertight);
        assert_eq!(opt_bits(c.cast_ray(ray)), opt_bits(expected));
    }
}
