//! Per-ray filters (layers, an ignored instance, back faces, end points): every ray through
//! its own filter answers as brute force under the documented filter, per ray, batched with a
//! filter per ray, batched through one filter and queued; and the semantics a game relies on,
//! one case each.

use crate::common::oracles::opt_bits;
use crate::common::rays::invalid_rays;
use crate::common::scenes::{build_scene, instances, scene_brute_force_filtered, world_mesh};
use crate::common::strategies::{RaySpec, mesh_strategy, ray_spec};
use glam::{Quat, Vec3};
use proptest::prelude::*;
use raybatch::scene::{InstanceDesc, RayFilter, Rigid, Scene};
use raybatch::users::{LosQueue, QueueError};
use raybatch::{
    AccelKind, BatchError, BatchOptions, BatchQueries, Kernel, Mesh, Ray, RayQueries, brute_force,
};

fn filter_strategy(instances: usize) -> impl Strategy<Value = RayFilter> {
    let ignore = prop::option::of(0..instances as u32 + 1);
    (
        prop_oneof![Just(u32::MAX), 1u32..4],
        ignore,
        any::<bool>(),
        any::<bool>(),
    )
        .prop_map(
            |(layers, ignore, cull_back_faces, include_ends)| RayFilter {
                layers,
                ignore,
                cull_back_faces,
                include_ends,
            },
        )
}

/// Rays aimed at the instances' world copies, the invalid rays, and rays whose range ends
/// exactly on a surface (a hit's `t` as range end or start).
fn rays_for(meshes: &[Mesh], descs: &[InstanceDesc], specs: &[RaySpec]) -> Vec<Ray> {
    let worlds: Vec<Mesh> = descs.iter().map(|d| world_mesh(meshes, d)).collect();
    let mut rays: Vec<Ray> = Vec::new();
    for (k, spec) in specs.iter().enumerate() {
        let world = &worlds[k % worlds.len()];
        let ray = spec.resolve(world);
        rays.push(ray);
        if let Some(hit) = brute_force::cast_ray(world, &ray, Kernel::Watertight) {
            rays.push(Ray::with_range(ray.origin, ray.dir, ray.tmin, hit.t));
            rays.push(Ray::with_range(ray.origin, ray.dir, hit.t, ray.tmax));
            rays.push(Ray::with_range(ray.origin, ray.dir, hit.t, hit.t));
        }
    }
    rays.extend(invalid_rays());
    rays
}

fn check(
    scene: &Scene,
    (meshes, descs): (&[Mesh], &[InstanceDesc]),
    rays: &[Ray],
    filters: &[RayFilter],
    single_ray_below: usize,
) -> Result<(), String> {
    let oracle =
        |i: usize, kernel| scene_brute_force_filtered(meshes, descs, &rays[i], kernel, &filters[i]);
    for kernel in Kernel::ALL {
        let expected: Vec<_> = (0..rays.len()).map(|i| oracle(i, kernel)).collect();
        for (i, (ray, filter)) in rays.iter().zip(filters).enumerate() {
            let view = scene.filtered(*filter);
            let got = view.cast_ray_with(ray, kernel);
            if opt_bits(got) != opt_bits(expected[i].closest) {
                return Err(format!(
                    "{kernel:?} closest {got:?}, expected {:?}, {ray:?} through {filter:?}",
                    expected[i].closest
                ));
            }
            if view.occluded_with(ray, kernel) != expected[i].occluded {
                return Err(format!(
                    "{kernel:?} occluded differs, {ray:?} through {filter:?}"
                ));
            }
        }
        let options = BatchOptions::default()
            .with_kernel(kernel)
            .with_min_batch(0)
            .with_single_ray_below(single_ray_below);
        let batch = scene.filtered_batch(filters);
        let mut hits = vec![None; rays.len()];
        batch
            .cast_ray_batch_with(rays, &mut hits, &options)
            .unwrap();
        let mut occluded = vec![false; rays.len()];
        batch
            .occluded_batch_with(rays, &mut occluded, &options)
            .unwrap();
        // The same filter for the whole batch, through a view.
        let shared = filters[0];
        let view = scene.filtered(shared);
        let mut view_hits = vec![None; rays.len()];
        view.cast_ray_batch_with(rays, &mut view_hits, &options)
            .unwrap();
        for i in 0..rays.len() {
            if opt_bits(hits[i]) != opt_bits(expected[i].closest)
                || occluded[i] != expected[i].occluded
            {
                return Err(format!(
                    "{kernel:?} batched ray {i}: {:?} / {}, expected {:?} / {}, {:?} through {:?}",
                    hits[i],
                    occluded[i],
                    expected[i].closest,
                    expected[i].occluded,
                    rays[i],
                    filters[i]
                ));
            }
            let want = scene_brute_force_filtered(meshes, descs, &rays[i], kernel, &shared);
            if opt_bits(view_hits[i]) != opt_bits(want.closest) {
                return Err(format!("{kernel:?} view batch ray {i} through {shared:?}"));
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random soups under random transforms and scales, mixed tree kinds, a random filter per
    /// ray.
    #[test]
    fn filtered_rays_match_brute_force(
        meshes in prop::collection::vec(mesh_strategy(), 1..=3),
        descs in instances(3, 6),
        specs in prop::collection::vec(ray_spec(), 16),
        filter_seeds in prop::collection::vec(filter_strategy(6), 64),
        kind in 0usize..AccelKind::ALL.len(),
        single_ray_below in prop_oneof![Just(0usize), Just(4), Just(1000)],
    ) {
        let descs: Vec<InstanceDesc> = descs
            .into_iter()
            .map(|d| InstanceDesc { mesh: d.mesh % meshes.len(), ..d })
            .collect();
        let kinds = [AccelKind::ALL[kind], AccelKind::DEFAULT];
        let scene = build_scene(&meshes, &kinds, &descs);
        let rays = rays_for(&meshes, &descs, &specs);
        let filters: Vec<RayFilter> =
            (0..rays.len()).map(|i| filter_seeds[i % filter_seeds.len()]).collect();
        let result = check(&scene, (&meshes, &descs), &rays, &filters, single_ray_below);
        prop_assert!(result.is_ok(), "{}", result.unwrap_err());
    }
}

/// A unit quad in the plane z = 0, its winding normal +z.
fn quad() -> Mesh {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let vertices = corners.map(|(x, y)| Vec3::new(x, y, 0.0)).to_vec();
    Mesh::new(vertices, vec![[0, 1, 2], [0, 2, 3]]).unwrap()
}

/// A closed box of half-size `h` around the origin, faces wound outwards.
fn cube(h: f32) -> Mesh {
    let v = |x: f32, y: f32, z: f32| Vec3::new(x * h, y * h, z * h);
    let vertices = vec![
        v(-1., -1., -1.),
        v(1., -1., -1.),
        v(1., 1., -1.),
        v(-1., 1., -1.),
        v(-1., -1., 1.),
        v(1., -1., 1.),
        v(1., 1., 1.),
        v(-1., 1., 1.),
    ];
    let faces = vec![
        [0, 2, 1],
        [0, 3, 2],
        [4, 5, 6],
        [4, 6, 7],
        [0, 1, 5],
        [0, 5, 4],
        [2, 3, 7],
        [2, 7, 6],
        [1, 2, 6],
        [1, 6, 5],
        [0, 4, 7],
        [0, 7, 3],
    ];
    Mesh::new(vertices, faces).unwrap()
}

#[test]
fn an_agent_sees_past_its_own_body() {
    // Instance 0: the agent's body around its eye; instance 1: a wall far away.
    let meshes = vec![cube(0.5), quad()];
    let wall = Rigid::from_translation(Vec3::new(0.0, 0.0, -20.0)).unwrap();
    let descs = [
        InstanceDesc::new(0, Rigid::IDENTITY),
        InstanceDesc::new(1, wall),
    ];
    let scene = build_scene(&meshes, &[AccelKind::DEFAULT], &descs);
    let eye = Vec3::new(0.0, 0.1, 0.0);
    let sight = Ray::segment(eye, Vec3::new(3.0, 0.0, -10.0));
    assert!(scene.occluded(&sight), "the body blocks its own eye");
    let own = RayFilter::ALL.ignoring(0);
    assert!(!scene.filtered(own).occluded(&sight));
    let through_wall = Ray::segment(eye, Vec3::new(0.0, 0.0, -30.0));
    assert!(scene.filtered(own).occluded(&through_wall));
    let hit = scene
        .filtered(own)
        .cast_ray_resolved(&through_wall)
        .unwrap();
    assert_eq!(hit.instance, 1);
}

#[test]
fn back_faces_let_rays_through_only_when_culled() {
    let scene = Scene::from_meshes(
        vec![quad()],
        &[InstanceDesc::new(
            0,
            Rigid::new(Quat::from_rotation_x(0.3), Vec3::ZERO).unwrap(),
        )],
    )
    .unwrap();
    let cull = RayFilter::ALL.culling_back_faces();
    // From the front (against the normal): blocked either way.
    let front = Ray::segment(Vec3::new(0.1, 0.2, 5.0), Vec3::new(0.1, 0.2, -5.0));
    assert!(scene.occluded(&front) && scene.filtered(cull).occluded(&front));
    // From behind: blocked, unless back faces are culled.
    let back = Ray::segment(Vec3::new(0.1, 0.2, -5.0), Vec3::new(0.1, 0.2, 5.0));
    assert!(scene.occluded(&back));
    assert!(!scene.filtered(cull).occluded(&back));
    assert_eq!(scene.filtered(cull).cast_ray(&back), None);
}

#[test]
fn open_ends_skip_surfaces_at_the_end_points() {
    let scene = Scene::from_meshes(vec![quad()], &[InstanceDesc::new(0, Rigid::IDENTITY)]).unwrap();
    let open = RayFilter::ALL.without_ends();
    // A sightline ending on the floor, one starting on it, one crossing it.
    let ends_on = Ray::segment(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.25, 0.5, 0.0));
    let starts_on = Ray::segment(Vec3::new(0.25, 0.5, 0.0), Vec3::new(0.25, 0.5, 2.0));
    let crosses = Ray::segment(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.25, 0.5, -2.0));
    for ray in [ends_on, starts_on, crosses] {
        assert!(scene.occluded(&ray), "closed segments count their ends");
    }
    assert!(!scene.filtered(open).occluded(&ends_on));
    assert!(!scene.filtered(open).occluded(&starts_on));
    assert!(scene.filtered(open).occluded(&crosses));
    // A range of one point on the surface: hit when closed; empty (not invalid) when open.
    let point = Ray::with_range(Vec3::new(0.25, 0.5, 2.0), Vec3::NEG_Z, 2.0, 2.0);
    assert!(scene.occluded(&point));
    assert!(!scene.filtered(open).occluded(&point));
    let rays = [ends_on, starts_on, crosses, point];
    let filters = [open; 4];
    let mut occluded = [true; 4];
    let options = BatchOptions::default().with_min_batch(0);
    scene
        .filtered_batch(&filters)
        .occluded_batch_with(&rays, &mut occluded, &options)
        .unwrap();
    assert_eq!(occluded, [false, false, true, false]);
}

#[test]
fn a_filter_per_ray_needs_one_filter_per_ray() {
    let scene = Scene::from_meshes(vec![quad()], &[InstanceDesc::new(0, Rigid::IDENTITY)]).unwrap();
    let rays = [Ray::new(Vec3::Z, Vec3::NEG_Z); 3];
    let filters = [RayFilter::ALL; 2];
    let mut occluded = [false; 3];
    let error = scene
        .filtered_batch(&filters)
        .occluded_batch(&rays, &mut occluded)
        .unwrap_err();
    assert_eq!(
        error,
        BatchError::FilterCount {
            rays: 3,
            filters: 2
        }
    );
    let mut hits = [None; 3];
    assert!(
        scene
            .filtered_batch(&filters)
            .cast_ray_batch(&rays, &mut hits)
            .is_err()
    );
    let queue = LosQueue::with_capacity(8).unwrap();
    let error = queue.submit_all_filtered(&rays, &filters).unwrap_err();
    assert_eq!(
        error,
        QueueError::FilterCount {
            rays: 3,
            filters: 2
        }
    );
    assert!(queue.is_empty());
}

#[test]
fn queued_sightlines_keep_their_own_filters() {
    let meshes = vec![cube(0.5), quad()];
    let descs: Vec<InstanceDesc> = (0..16)
        .map(|i| {
            let at = Vec3::new((i % 4) as f32 * 2.0 - 3.0, (i / 4) as f32 * 2.0 - 3.0, 0.0);
            let turn = Quat::from_rotation_y(0.4 * i as f32);
            InstanceDesc::new(i % 2, Rigid::new(turn, at).unwrap()).with_mask(1 << (i % 3))
        })
        .collect();
    let scene = build_scene(&meshes, &[AccelKind::DEFAULT], &descs);
    let mut rng = crate::common::rng::seeded(7);
    let (mut rays, mut filters) = (Vec::new(), Vec::new());
    for k in 0..3000u32 {
        let from = crate::common::rng::in_cube(&mut rng, 5.0);
        let to = crate::common::rng::in_cube(&mut rng, 5.0);
        rays.push(Ray::segment(from, to));
        let mut filter = RayFilter::on_layers([u32::MAX, 1, 6][k as usize % 3]);
        if k % 4 == 0 {
            filter = filter.ignoring(k % 16);
        }
        if k % 5 == 0 {
            filter = filter.culling_back_faces();
        }
        if k % 7 == 0 {
            filter = filter.without_ends();
        }
        filters.push(filter);
    }
    let queue = LosQueue::with_capacity(rays.len()).unwrap();
    let (half_rays, rest_rays) = rays.split_at(1000);
    let (half_filters, rest_filters) = filters.split_at(1000);
    let first = queue.submit_all_filtered(half_rays, half_filters).unwrap();
    let singles: Vec<_> = rest_rays
        .iter()
        .zip(rest_filters)
        .map(|(r, f)| queue.submit_filtered(*r, *f).unwrap())
        .collect();
    assert_eq!(queue.flush(&scene), Ok(rays.len()));
    let mut blocked = 0;
    for (k, (ray, filter)) in rays.iter().zip(&filters).enumerate() {
        let ticket = if k < 1000 {
            first.offset(k)
        } else {
            singles[k - 1000]
        };
        let expected = scene.filtered(*filter).occluded(ray);
        assert_eq!(
            queue.occluded(ticket),
            Ok(expected),
            "sightline {k} through {filter:?}"
        );
        blocked += usize::from(expected);
    }
    assert!(blocked > 300 && blocked < 2700, "{blocked} blocked of 3000");
    // One filter shared by a whole frame.
    let shared = RayFilter::on_layers(2).culling_back_faces();
    let tickets: Vec<_> = rays
        .iter()
        .map(|r| queue.submit_filtered(*r, shared).unwrap())
        .collect();
    queue.flush(&scene).unwrap();
    for (ray, ticket) in rays.iter().zip(tickets) {
        assert_eq!(
            queue.occluded(ticket),
            Ok(scene.filtered(shared).occluded(ray))
        );
    }
}
