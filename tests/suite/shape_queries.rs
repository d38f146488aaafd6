//! Shape queries: every tree that answers them equals the brute-force reference bit for bit
//! (overlapping ids, first contacts, the tie rule), a sphere of radius 0 sweeps as a ray, and
//! the hard cases: a sphere sliding on a floor of many triangles, grazing and zero-length
//! sweeps, shapes starting in contact, kinds that do not answer and bad input.

use std::sync::Arc;

use crate::common::strategies::{mesh_strategy, vertex};
use proptest::prelude::*;
use raybatch::glam::Vec3;
use raybatch::shape::{Shape, ShapeError, ShapeQueries, brute_force};
use raybatch::{Aabb, AccelKind, AnyAccel, BuildOptions, Kernel, Mesh, Ray, RayQueries};

/// The kinds that answer shape queries.
fn answering() -> impl Iterator<Item = AccelKind> {
    AccelKind::ALL.into_iter().filter(|k| k.answers_shapes())
}

/// Every answering kind with leaves of 1, 4 and 16 triangles.
fn trees(mesh: &Arc<Mesh>) -> Vec<AnyAccel> {
    let mut trees = Vec::new();
    for kind in answering() {
        for leaf in [1, 4, 16] {
            let options = BuildOptions::default().with_leaf_size(leaf);
            trees.push(kind.build(mesh.clone(), &options).expect("the mesh builds"));
        }
    }
    trees
}

fn shape_strategy() -> impl Strategy<Value = Shape> {
    let radius = prop_oneof![1 => Just(0.0f32), 4 => 0.0f32..1.5];
    prop_oneof![
        (vertex(), radius.clone()).prop_map(|(centre, radius)| Shape::Sphere { centre, radius }),
        (vertex(), vertex()).prop_map(|(a, b)| Shape::Box(Aabb::new(a.min(b), a.max(b)))),
        (vertex(), vertex(), radius).prop_map(|(a, b, radius)| Shape::Capsule { a, b, radius }),
    ]
}

fn motion_strategy() -> impl Strategy<Value = Vec3> {
    prop_oneof![1 => Just(Vec3::ZERO), 6 => vertex().prop_map(|v| v * 2.0)]
}

/// The reference's first contact; for a sphere of radius 0, the ray reference's hit.
fn expected_sweep(mesh: &Mesh, shape: &Shape, motion: Vec3) -> Option<(f32, u32)> {
    if let Shape::Sphere { centre, radius } = *shape
        && radius == 0.0
        && motion != Vec3::ZERO
    {
        let ray = Ray::with_range(centre, motion, 0.0, 1.0);
        return raybatch::brute_force::cast_ray(mesh, &ray, Kernel::Watertight)
            .map(|h| (h.t, h.triangle));
    }
    brute_force::sweep(mesh, shape, motion).map(|c| (c.t, c.triangle))
}

fn check(mesh: Mesh, shapes: &[(Shape, Vec3)]) -> Result<(), TestCaseError> {
    let mesh = Arc::new(mesh);
    for tree in trees(&mesh) {
        let name = tree.kind().name();
        for (shape, motion) in shapes {
            let ids = brute_force::overlapping(&mesh, shape);
            prop_assert_eq!(
                &tree.overlapping(shape).unwrap(),
                &ids,
                "{} {:?}",
                name,
                shape
            );
            prop_assert_eq!(tree.overlaps(shape).unwrap(), !ids.is_empty());
            if let Shape::Box(_) = shape {
                prop_assert!(matches!(
                    tree.sweep(shape, *motion),
                    Err(ShapeError::Invalid(_))
                ));
                continue;
            }
            let swept = tree.sweep(shape, *motion).unwrap();
            let expected = expected_sweep(&mesh, shape, *motion);
            prop_assert_eq!(
                swept.map(|c| (c.t, c.triangle)),
                expected,
                "{} {:?} {}",
                name,
                shape,
                motion
            );
            if let Some(c) = swept {
                prop_assert!((0.0..=1.0).contains(&c.t));
                prop_assert!((c.normal.length() - 1.0).abs() < 1e-4, "{:?}", c);
            }
            prop_assert_eq!(
                tree.sweep_blocked(shape, *motion).unwrap(),
                expected.is_some()
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Every answering tree against brute force on random soups (shared vertices, degenerate,
    /// duplicated and coplanar triangles, a closed sphere under some) and random shapes.
    #[test]
    fn trees_answer_shape_queries_as_brute_force(
        mesh in mesh_strategy(),
        shapes in prop::collection::vec((shape_strategy(), motion_strategy()), 12),
    ) {
        check(mesh, &shapes)?;
    }
}

/// A floor of 2 x 20 x 20 triangles at y = 0.
fn floor() -> Arc<Mesh> {
    let n = 20;
    let vertices: Vec<Vec3> = (0..=n)
        .flat_map(|z| (0..=n).map(move |x| Vec3::new(x as f32, 0.0, z as f32)))
        .collect();
    let at = |x: u32, z: u32| z * (n + 1) + x;
    let triangles = (0..n)
        .flat_map(|z| (0..n).map(move |x| (x, z)))
        .flat_map(|(x, z)| {
            [
                [at(x, z), at(x, z + 1), at(x + 1, z)],
                [at(x + 1, z), at(x, z + 1), at(x + 1, z + 1)],
            ]
        })
        .collect();
    Arc::new(Mesh::new(vertices, triangles).unwrap())
}

#[test]
fn a_sphere_sliding_on_a_floor_of_many_triangles_touches_only_where_it_rests() {
    let floor = floor();
    for tree in trees(&floor) {
        let above = Shape::Sphere {
            centre: Vec3::new(0.5, 0.5 + 1e-4, 0.7),
            radius: 0.5,
        };
        let motion = Vec3::new(18.3, 0.0, 17.9);
        assert_eq!(
            tree.sweep(&above, motion).unwrap(),
            None,
            "{}",
            tree.kind().name()
        );
        let capsule = Shape::Capsule {
            a: Vec3::new(0.5, 0.25 + 1e-4, 0.7),
            b: Vec3::new(0.5, 1.5, 0.7),
            radius: 0.25,
        };
        assert!(!tree.sweep_blocked(&capsule, motion).unwrap());
        // Resting on it: a contact at the start, with the floor's normal.
        let resting = Shape::Sphere {
            centre: Vec3::new(3.5, 0.5, 4.25),
            radius: 0.5,
        };
        let contact = tree.sweep(&resting, motion).unwrap().expect("touching");
        assert_eq!(contact.t, 0.0);
        assert_eq!(contact.normal, Vec3::Y);
        assert_eq!(contact.point, Vec3::new(3.5, 0.0, 4.25));
        // Falling onto it at a shared vertex: the lowest id of the triangles there.
        let falling = Shape::Sphere {
            centre: Vec3::new(5.0, 2.0, 5.0),
            radius: 0.5,
        };
        let contact = tree
            .sweep(&falling, Vec3::new(0.0, -4.0, 0.0))
            .unwrap()
            .unwrap();
        assert_eq!(
            (contact.t, contact.point),
            (0.375, Vec3::new(5.0, 0.0, 5.0))
        );
        let touching = brute_force::overlapping(
            &floor,
            &Shape::Sphere {
                centre: Vec3::new(5.0, 0.5, 5.0),
                radius: 0.5,
            },
        );
        assert_eq!(contact.triangle, touching[0]);
        assert_eq!(touching.len(), 6, "the six triangles around the vertex");
    }
}

#[test]
fn zero_length_sweeps_touch_exactly_what_overlaps() {
    let floor = floor();
    let tree = AccelKind::DEFAULT
        .build(floor.clone(), &BuildOptions::default())
        .unwrap();
    for (y, touching) in [(0.5, true), (0.500_001, false), (-0.2, true)] {
        let shape = Shape::Sphere {
            centre: Vec3::new(7.3, y, 2.2),
            radius: 0.5,
        };
        let swept = tree.sweep(&shape, Vec3::ZERO).unwrap();
        assert_eq!(swept.is_some(), touching, "{y}");
        assert_eq!(tree.overlaps(&shape).unwrap(), touching);
        assert_eq!(swept.map(|c| c.t), touching.then_some(0.0));
    }
}

#[test]
fn a_point_sweeps_as_the_ray_query() {
    let mesh = Arc::new(
        Mesh::load_obj(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/stanford-bunny.obj"
        ))
        .unwrap(),
    );
    let tree = AccelKind::DEFAULT
        .build(mesh.clone(), &BuildOptions::default())
        .unwrap();
    let bounds = mesh.bounds();
    let mut hits = 0;
    for k in 0..2000u32 {
        let f = |i: u32| ((k * 7919 + i * 104_729) % 1000) as f32 / 1000.0;
        let from = bounds.min + (bounds.max - bounds.min) * Vec3::new(f(1), f(2), f(3));
        let to = bounds.min + (bounds.max - bounds.min) * Vec3::new(f(4), f(5), f(6));
        let point = Shape::Sphere {
            centre: from,
            radius: 0.0,
        };
        let ray = Ray::with_range(from, to - from, 0.0, 1.0);
        let swept = tree.sweep(&point, to - from).unwrap();
        assert_eq!(
            swept.map(|c| (c.t, c.triangle)),
            tree.cast_ray(&ray).map(|h| (h.t, h.triangle))
        );
        assert_eq!(
            tree.sweep_blocked(&point, to - from).unwrap(),
            tree.occluded(&ray)
        );
        hits += usize::from(swept.is_some());
    }
    assert!(hits > 200, "{hits}");
}

#[test]
fn kinds_without_a_walk_and_bad_shapes_are_typed_errors() {
    let names: Vec<&str> = answering().map(|k| k.name()).collect();
    assert_eq!(
        names,
        ["aabb", "quantized", "bvh4", "bvh8", "bvh4q", "bvh8q"]
    );
    let floor = floor();
    let sphere = Shape::Sphere {
        centre: Vec3::ONE,
        radius: 1.0,
    };
    for kind in AccelKind::ALL {
        let tree = kind.build(floor.clone(), &BuildOptions::default()).unwrap();
        let answer = tree.overlaps(&sphere);
        if kind.answers_shapes() {
            assert_eq!(answer, Ok(true));
        } else {
            assert_eq!(answer, Err(ShapeError::Unsupported { kind }));
            assert!(answer.unwrap_err().to_string().contains(kind.name()));
        }
    }
    let tree = AccelKind::DEFAULT
        .build(floor, &BuildOptions::default())
        .unwrap();
    let bad = [
        Shape::Sphere {
            centre: Vec3::NAN,
            radius: 1.0,
        },
        Shape::Sphere {
            centre: Vec3::ONE,
            radius: -1.0,
        },
        Shape::Sphere {
            centre: Vec3::ONE,
            radius: f32::INFINITY,
        },
        Shape::Capsule {
            a: Vec3::ONE,
            b: Vec3::INFINITY,
            radius: 1.0,
        },
        Shape::Box(Aabb::new(Vec3::ONE, Vec3::ZERO)),
        Shape::Box(Aabb::new(Vec3::ZERO, Vec3::NAN)),
    ];
    for shape in bad {
        assert!(
            matches!(tree.overlaps(&shape), Err(ShapeError::Invalid(_))),
            "{shape:?}"
        );
        assert!(matches!(
            tree.overlapping(&shape),
            Err(ShapeError::Invalid(_))
        ));
        assert!(matches!(
            tree.sweep(&shape, Vec3::X),
            Err(ShapeError::Invalid(_))
        ));
    }
    assert!(matches!(
        tree.sweep(&sphere, Vec3::NAN),
        Err(ShapeError::Invalid(_))
    ));
    assert!(matches!(
        tree.sweep_blocked(&sphere, Vec3::INFINITY),
        Err(ShapeError::Invalid(_))
    ));
}
