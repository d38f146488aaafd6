use std::sync::Arc;

use glam::Vec3;

use super::*;
use crate::bvh::{BuildOptions, LeafCopy};
use crate::geom::Kernel;
use crate::query::{BatchQueries, RayQueries};
use crate::test_support::{TestRng, bunny, random_rays};

/// The kinds that cook.
const COOKED: [AccelKind; 6] = [
    AccelKind::Aabb,
    AccelKind::Quantized,
    AccelKind::Bvh4,
    AccelKind::Bvh8,
    AccelKind::Bvh4q,
    AccelKind::Bvh8q,
];

/// A soup of `n` random triangles, every seventh degenerate (a repeated index or collinear
/// corners), which the trees leave out.
fn soup(n: usize, seed: u64) -> Mesh {
    let mut rng = TestRng::new(seed);
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for t in 0..n as u32 {
        let base = rng.vec3(10.0);
        let corners = [base, base + rng.vec3(1.0), base + rng.vec3(1.0)];
        let corners = if t % 14 == 0 {
            [base, base + Vec3::X, base + 2.0 * Vec3::X]
        } else {
            corners
        };
        let first = vertices.len() as u32;
        vertices.extend(corners);
        triangles.push(if t % 14 == 7 {
            [first, first, first + 1]
        } else {
            [first, first + 1, first + 2]
        });
    }
    Mesh::new(vertices, triangles).unwrap()
}

fn round_trip(tree: &AnyAccel) -> AnyAccel {
    AnyAccel::from_cooked(&tree.to_cooked().unwrap()).unwrap()
}

/// The loaded tree is the saved one, node for node and copy for copy (its `Debug` text shows
/// every field, zero signs included), and answers alike.
#[test]
fn every_cooked_kind_loads_as_it_was_saved() {
    let meshes = [
        soup(0, 1),
        soup(1, 2),
        soup(3, 3),
        soup(200, 4),
        soup(3000, 5),
    ];
    for mesh in meshes {
        let mesh = Arc::new(mesh);
        for kind in COOKED {
            for copy in LeafCopy::ALL {
                for leaf in [1, 4] {
                    let options = BuildOptions::default()
                        .with_leaf_copy(copy)
                        .with_leaf_size(leaf)
                        .with_wide_leaf_size(leaf.max(4));
                    let tree = kind.build(mesh.clone(), &options).unwrap();
                    let loaded = round_trip(&tree);
                    let what = (kind, copy, leaf, mesh.triangle_count());
                    assert_eq!(format!("{tree:?}"), format!("{loaded:?}"), "{what:?}");
                }
            }
        }
    }
}

#[test]
fn the_bunny_answers_alike_after_loading() {
    let mesh = Arc::new(bunny());
    let rays = random_rays(&mesh, 2000, 9);
    for kind in COOKED {
        let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        let loaded = round_trip(&tree);
        let mut hits = (vec![None; rays.len()], vec![None; rays.len()]);
        tree.cast_ray_batch(&rays, &mut hits.0).unwrap();
        loaded.cast_ray_batch(&rays, &mut hits.1).unwrap();
        assert_eq!(hits.0, hits.1, "{kind:?}");
        for ray in &rays[..200] {
            assert_eq!(tree.cast_ray(ray), loaded.cast_ray(ray), "{kind:?}");
            assert_eq!(tree.occluded(ray), loaded.occluded(ray), "{kind:?}");
        }
    }
}

/// A tree over leaf blocks (the quantized 8-wide tree on large meshes) reads its slot ranges
/// back from its blocks.
#[test]
fn leaf_blocks_round_trip() {
    let mesh = Arc::new(bunny());
    let options = BuildOptions::default().with_leaf_copy(LeafCopy::Blocks);
    for kind in [AccelKind::Bvh8q, AccelKind::Bvh8, AccelKind::Bvh4] {
        let tree = kind.build(mesh.clone(), &options).unwrap();
        assert_eq!(format!("{tree:?}"), format!("{:?}", round_trip(&tree)));
    }
}

#[test]
fn cooks_names_the_kinds_that_cook() {
    let cooking: Vec<AccelKind> = AccelKind::ALL.into_iter().filter(|k| k.cooks()).collect();
    assert_eq!(cooking, COOKED);
}

#[test]
fn kinds_that_do_not_cook_say_so() {
    let mesh = Arc::new(soup(50, 6));
    for kind in AccelKind::ALL {
        let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        match tree.to_cooked() {
            Ok(_) => assert!(COOKED.contains(&kind), "{kind:?}"),
            Err(CookError::Unsupported(k)) => assert!(k == kind && !COOKED.contains(&kind)),
            Err(e) => panic!("{kind:?}: {e}"),
        }
    }
}

fn cooked_soup() -> Vec<u8> {
    let tree = AccelKind::Bvh8
        .build(soup(40, 7), &BuildOptions::default())
        .unwrap();
    tree.to_cooked().unwrap()
}

/// The file `bytes` with its payload changed by `edit` and its checksum made right again.
fn edited(bytes: &[u8], edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut payload = bytes[HEADER_BYTES..].to_vec();
    edit(&mut payload);
    let mut out = bytes[..HEADER_BYTES].to_vec();
    out[16..24].copy_from_slice(&(payload.len() as u64).to_le_bytes());
    out[24..28].copy_from_slice(&crc32fast::hash(&payload).to_le_bytes());
    out.extend(payload);
    out
}

#[test]
fn damaged_files_are_refused() {
    let bytes = cooked_soup();
    for len in 0..bytes.len() {
        assert!(
            AnyAccel::from_cooked(&bytes[..len]).is_err(),
            "cut at {len}"
        );
    }
    for bit in (0..8 * bytes.len()).step_by(7) {
        let mut damaged = bytes.clone();
        damaged[bit / 8] ^= 1 << (bit % 8);
        assert!(AnyAccel::from_cooked(&damaged).is_err(), "bit {bit}");
    }
    let cut = &bytes[..bytes.len() - 1];
    assert!(matches!(
        AnyAccel::from_cooked(cut),
        Err(CookError::Truncated { .. })
    ));
    let mut flipped = bytes.clone();
    *flipped.last_mut().unwrap() ^= 1;
    assert!(matches!(
        AnyAccel::from_cooked(&flipped),
        Err(CookError::Checksum { .. })
    ));
}

#[test]
fn foreign_and_newer_files_are_refused() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n# a mesh, not a cooked tree\n";
    assert!(matches!(
        AnyAccel::from_cooked(obj),
        Err(CookError::NotCooked)
    ));
    assert!(matches!(
        AnyAccel::from_cooked(&[]),
        Err(CookError::NotCooked)
    ));
    let mut newer = cooked_soup();
    newer[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
    assert!(matches!(
        AnyAccel::from_cooked(&newer),
        Err(CookError::NewerVersion { found, .. }) if found == FORMAT_VERSION + 1
    ));
    let mut unknown = cooked_soup();
    unknown[12..16].copy_from_slice(&99u32.to_le_bytes());
    assert!(matches!(
        AnyAccel::from_cooked(&unknown),
        Err(CookError::UnknownKind(99))
    ));
    let scene = crate::Scene::new(Vec::new(), &[])
        .unwrap()
        .to_cooked()
        .unwrap();
    assert!(matches!(
        AnyAccel::from_cooked(&scene),
        Err(CookError::WrongContent { .. })
    ));
    assert!(matches!(
        crate::Scene::from_cooked(&cooked_soup()),
        Err(CookError::WrongContent { .. })
    ));
}

/// Payloads changed behind a right checksum (as by hand) load as an error or as a tree that
/// answers as brute force does over the file's mesh: the shape is checked and the boxes
/// recomputed.
#[test]
fn edited_payloads_never_answer_wrongly() {
    let mesh = soup(60, 8);
    let rays = random_rays(&mesh, 300, 10);
    let mut rng = TestRng::new(11);
    let mut loaded = 0;
    for kind in COOKED {
        let bytes = kind
            .build(mesh.clone(), &BuildOptions::default())
            .unwrap()
            .to_cooked()
            .unwrap();
        let words = (bytes.len() - HEADER_BYTES) / 4;
        for _ in 0..400 {
            let at = 4 * (rng.range(0.0, words as f32) as usize).min(words - 1);
            let value = match rng.range(0.0, 4.0) as u32 {
                0 => 0,
                1 => rng.range(0.0, 64.0) as u32,
                2 => 0x8000_0000 | rng.range(0.0, 64.0) as u32,
                _ => rng.range(0.0, 4e9) as u32,
            };
            let file = edited(&bytes, |p| {
                p[at..at + 4].copy_from_slice(&value.to_le_bytes())
            });
            let Ok(tree) = AnyAccel::from_cooked(&file) else {
                continue;
            };
            loaded += 1;
            let file_mesh = read_mesh(&mut Reader::new(&file[HEADER_BYTES..])).unwrap();
            for ray in &rays {
                let expected = crate::brute_force::cast_ray(&file_mesh, ray, Kernel::Watertight);
                assert_eq!(
                    tree.cast_ray(ray),
                    expected,
                    "{kind:?}, word {at} = {value}"
                );
            }
        }
    }
    // Some edits load (a changed vertex, an order byte), so the check above ran.
    assert!(loaded > 0);
}

#[test]
fn scenes_load_as_they_were_saved() {
    use crate::scene::{InstanceDesc, Rigid, Scene};
    use glam::Quat;
    let meshes = vec![
        AccelKind::Bvh4
            .build(soup(30, 12), &BuildOptions::default())
            .unwrap(),
        AccelKind::Aabb
            .build(bunny(), &BuildOptions::default())
            .unwrap(),
    ];
    let turn = Rigid::new(Quat::from_rotation_y(0.7), Vec3::new(0.1, 0.0, 0.3)).unwrap();
    let instances = [
        InstanceDesc::new(0, Rigid::IDENTITY),
        InstanceDesc::new(1, turn.with_scale(3.0).unwrap()).with_mask(2),
        InstanceDesc::new(0, turn).with_user(77),
        InstanceDesc::new(1, Rigid::from_translation(Vec3::X).unwrap()),
    ];
    let mut scene = Scene::new(meshes, &instances).unwrap();
    scene.remove_instance(3).unwrap();
    let loaded = Scene::from_cooked(&scene.to_cooked().unwrap()).unwrap();
    assert_eq!(loaded.instances().len(), 4);
    for (a, b) in scene.instances().iter().zip(loaded.instances()) {
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
    }
    for (a, b) in scene.meshes().iter().zip(loaded.meshes()) {
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
    }
    let rays = random_rays(&bunny(), 500, 13);
    for ray in &rays {
        assert_eq!(scene.cast_ray_resolved(ray), loaded.cast_ray_resolved(ray));
    }
    let unsupported = Scene::new(
        vec![
            AccelKind::Kd
                .build(soup(30, 12), &BuildOptions::default())
                .unwrap(),
        ],
        &[InstanceDesc::new(0, Rigid::IDENTITY)],
    )
    .unwrap();
    assert!(matches!(
        unsupported.to_cooked(),
        Err(CookError::Unsupported(AccelKind::Kd))
    ));
}
