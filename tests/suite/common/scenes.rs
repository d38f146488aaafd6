//! Scenes for the tests: random instance layouts, and the scene oracle, brute force over every
//! instance's mesh with the ray carried into mesh space by the same documented transform the
//! scene uses (`Rigid::ray_to_mesh`), so that answers compare bit for bit.

use std::sync::Arc;

use glam::{Quat, Vec3};
use proptest::prelude::*;
use raybatch::brute_force;
use raybatch::scene::{InstanceDesc, RayFilter, Rigid, Scene};
use raybatch::{AccelKind, BuildOptions, Hit, Kernel, Mesh, Ray};

/// The brute-force answers of a scene for one ray and kernel, in global ids.
pub struct SceneReference {
    pub closest: Option<Hit>,
    pub occluded: bool,
    /// Sorted by `t`, then global id.
    pub all: Vec<Hit>,
}

/// Brute force over every instance (seen by `mask`) of `meshes` placed by `instances`.
pub fn scene_brute_force(
    meshes: &[Mesh],
    instances: &[InstanceDesc],
    ray: &Ray,
    kernel: Kernel,
    mask: u32,
) -> SceneReference {
    let filter = RayFilter::on_layers(mask);
    scene_brute_force_filtered(meshes, instances, ray, kernel, &filter)
}

/// Brute force over every instance of `meshes` placed by `instances`, through `filter` as its
/// docs define it: the instances on its layers but the ignored one, the range open without
/// the ends, no hit whose mesh-space ray runs along its triangle's winding normal when
/// culling back faces.
pub fn scene_brute_force_filtered(
    meshes: &[Mesh],
    instances: &[InstanceDesc],
    ray: &Ray,
    kernel: Kernel,
    filter: &RayFilter,
) -> SceneReference {
    let mut all = Vec::new();
    let range = if filter.include_ends {
        Some((ray.tmin, ray.tmax))
    } else {
        let (lo, hi) = (ray.tmin.next_up(), ray.tmax.next_down());
        (lo <= hi).then_some((lo, hi))
    };
    if let (true, Some((tmin, tmax))) = (ray.is_valid(), range) {
        let ray = Ray::with_range(ray.origin, ray.dir, tmin, tmax);
        let mut first = 0u32;
        for (index, d) in instances.iter().enumerate() {
            let mesh = &meshes[d.mesh];
            let ignored = filter.ignore == Some(index as u32);
            if d.mask & filter.layers != 0 && !ignored {
                let local = d.transform.ray_to_mesh(&ray);
                // The direction as queries prepare it: subnormal components flushed to zero.
                let dir = local
                    .dir
                    .to_array()
                    .map(|x| if x.abs() < f32::MIN_POSITIVE { 0.0 } else { x });
                let dir = Vec3::from(dir).as_dvec3();
                brute_force::for_each_hit(mesh, &local, kernel, |h| {
                    let [a, b, c] = mesh.triangle(h.triangle).map(|v| v.as_dvec3());
                    let along = (b - a).cross(c - a).dot(dir) > 0.0;
                    if !(filter.cull_back_faces && along) {
                        all.push(Hit {
                            triangle: first + h.triangle,
                            ..h
                        })
                    }
                });
            }
            first += mesh.triangle_count() as u32;
        }
    }
    Hit::sort(&mut all);
    SceneReference {
        closest: all.first().copied(),
        occluded: !all.is_empty() || !ray.is_valid(),
        all,
    }
}

/// A scene of `meshes` (mesh `i` built as `kinds[i % kinds.len()]`) placed by `instances`.
pub fn build_scene(meshes: &[Mesh], kinds: &[AccelKind], instances: &[InstanceDesc]) -> Scene {
    let trees = meshes
        .iter()
        .enumerate()
        .map(|(i, m)| {
            kinds[i % kinds.len()]
                .build(Arc::new(m.clone()), &BuildOptions::default())
                .unwrap()
        })
        .collect();
    Scene::new(trees, instances).unwrap()
}

/// Rotations that matter: the identity, exact quarter turns, and arbitrary ones.
pub fn rotation() -> impl Strategy<Value = Quat> {
    prop_oneof![
        2 => Just(Quat::IDENTITY),
        1 => (0usize..3).prop_map(|axis| {
            let a = [Vec3::X, Vec3::Y, Vec3::Z][axis];
            Quat::from_axis_angle(a, std::f32::consts::FRAC_PI_2)
        }),
        3 => (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
            .prop_filter("non-zero", |(x, y, z, w)| x * x + y * y + z * z + w * w > 0.01)
            .prop_map(|(x, y, z, w)| Quat::from_xyzw(x, y, z, w).normalize()),
    ]
}

/// Translations on a coarse grid (so instances overlap and touch) or anywhere nearby.
pub fn translation() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        1 => Just(Vec3::ZERO),
        2 => (-2i32..3, -2i32..3, -2i32..3).prop_map(|(x, y, z)| Vec3::new(x as f32, y as f32, z as f32)),
        2 => (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
    ]
}

/// Uniform scales: mostly 1, else from a quarter to four times.
pub fn scale() -> impl Strategy<Value = f32> {
    prop_oneof![2 => Just(1.0f32), 1 => 0.25f32..4.0]
}

/// Up to `count` instances of meshes `0..meshes`, on layers 1, 2 or both.
pub fn instances(meshes: usize, count: usize) -> impl Strategy<Value = Vec<InstanceDesc>> {
    prop::collection::vec(
        (0..meshes, rotation(), scale(), translation(), 1u32..4).prop_map(
            |(mesh, r, s, t, mask)| {
                let transform = Rigid::new(r, t).unwrap().with_scale(s).unwrap();
                InstanceDesc::new(mesh, transform).with_mask(mask)
            },
        ),
        1..=count,
    )
}

/// The mesh of instance `index` in world space (rounded; only for aiming rays at it).
pub fn world_mesh(meshes: &[Mesh], d: &InstanceDesc) -> Mesh {
    let mesh = &meshes[d.mesh];
    let vertices = mesh
        .vertices()
        .iter()
        .map(|&v| d.transform.point_to_world(v))
        .collect();
    Mesh::new(vertices, mesh.triangles().to_vec()).unwrap()
}
