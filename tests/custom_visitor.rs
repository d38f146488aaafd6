//! A visitor written by a user ("the first N hits", as an audio engine counting surfaces
//! would), run through every structure's one-ray traversal: it sees exactly the hits the
//! built-in queries see, and ending the ray (`tmax = RAY_DONE`) stops the walk at once.

mod common;

use common::meshes::{icosphere, transformed};
use common::oracles::bits;
use common::rays::hard_rays;
use glam::DVec3;
use raybatch::geom::PreparedRay;
use raybatch::hit::RAY_DONE;
use raybatch::query::single::trace_one;
use raybatch::zbt::ZbtOptions;
use raybatch::{
    AabbTree, Accel, AccelKind, BuildOptions, Hit, HybridTree, Kernel, Mesh, QuantizedAabbTree,
    QuantizedWideTree, QuantizedWideTree8, Ray, RayQueries, Visitor, WideTree, WideTree8,
    ZeroByteTree,
};
use raybatch::{GridOptions, KdTree, SpatialHash, UniformGrid};

/// Keeps the first `n` hits it is shown, then ends the ray.
struct FirstHits {
    n: usize,
    seen: Vec<Hit>,
    calls_after_done: usize,
}

impl Visitor for FirstHits {
    fn visit(&mut self, _: u32, hit: Hit, tmax: &mut f32) {
        if self.seen.len() == self.n {
            self.calls_after_done += 1;
            return;
        }
        self.seen.push(hit);
        if self.seen.len() == self.n {
            *tmax = RAY_DONE;
        }
    }
}

/// Five nested spheres: a ray from the centre crosses each once, from outside twice.
fn nested_spheres() -> Mesh {
    let sphere = icosphere(2);
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for k in 1..=5 {
        let layer = transformed(&sphere, k as f64, DVec3::ZERO);
        let base = vertices.len() as u32;
        vertices.extend_from_slice(layer.vertices());
        triangles.extend(layer.triangles().iter().map(|t| t.map(|i| i + base)));
    }
    Mesh::new(vertices, triangles).expect("valid mesh")
}

fn check<A: Accel + RayQueries>(name: &str, tree: &A, rays: &[Ray]) {
    for ray in rays {
        let all: Vec<_> = tree.all_hits(ray).iter().map(bits).collect();
        let Some(prepared) = PreparedRay::new(ray) else {
            continue;
        };
        for n in [1, 2, 3, 7] {
            let mut first = FirstHits {
                n,
                seen: Vec::new(),
                calls_after_done: 0,
            };
            trace_one(tree, &prepared, Kernel::Watertight, &mut first);
            assert_eq!(first.seen.len(), n.min(all.len()), "{name} n={n} {ray:?}");
            assert_eq!(
                first.calls_after_done, 0,
                "{name}: hits after the ray ended"
            );
            for hit in &first.seen {
                assert!(
                    all.contains(&bits(hit)),
                    "{name}: {hit:?} not a hit of {ray:?}"
                );
            }
        }
    }
}

#[test]
fn first_n_hits_visitor_on_every_structure() {
    let mesh = nested_spheres();
    let mut rays = hard_rays(&mesh, 5);
    rays.extend((0..200).map(|i| {
        let a = i as f32 * 0.37;
        Ray::new(glam::Vec3::ZERO, glam::Vec3::new(a.cos(), a.sin(), 0.3))
    }));
    for kind in AccelKind::ALL {
        let options = BuildOptions::default();
        let name = kind.name();
        // Exhaustive: a new kind must be added here with its concrete type.
        match kind {
            AccelKind::Aabb => check(
                name,
                &<AabbTree>::build(mesh.clone(), &options).unwrap(),
                &rays,
            ),
            AccelKind::Quantized => check(
                name,
                &QuantizedAabbTree::build(mesh.clone(), &options).unwrap(),
                &rays,
            ),
            AccelKind::Bvh4 => check(
                name,
                &WideTree::build(mesh.clone(), &options).unwrap(),
                &rays,
            ),
            AccelKind::Bvh8 => check(
                name,
                &WideTree8::build(mesh.clone(), &options).unwrap(),
                &rays,
            ),
            AccelKind::Bvh4q => check(
                name,
                &QuantizedWideTree::build(mesh.clone(), &options).unwrap(),
                &rays,
            ),
            AccelKind::Bvh8q => check(
                name,
                &QuantizedWideTree8::build(mesh.clone(), &options).unwrap(),
                &rays,
            ),
            AccelKind::Bvh8qb => check(
                name,
                &QuantizedWideTree8::build_with_blocks(mesh.clone(), &options).unwrap(),
                &rays,
            ),
            AccelKind::Zbt | AccelKind::ZbtNoCache => {
                let zbt = ZbtOptions {
                    box_cache: kind == AccelKind::Zbt,
                    ..ZbtOptions::default()
                };
                check(
                    name,
                    &ZeroByteTree::build(mesh.clone(), &zbt).unwrap().0,
                    &rays,
                )
            }
            AccelKind::Hybrid => {
                let (tree, _) = HybridTree::build(mesh.clone(), &Default::default()).unwrap();
                check(name, &tree, &rays)
            }
            AccelKind::Grid => check(
                name,
                &UniformGrid::build(mesh.clone(), &GridOptions::default()).unwrap(),
                &rays,
            ),
            AccelKind::Kd => check(
                name,
                &KdTree::build(mesh.clone(), options.max_leaf_size).unwrap(),
                &rays,
            ),
            AccelKind::Hash => check(
                name,
                &SpatialHash::build(mesh.clone(), &SpatialHash::default_options()).unwrap(),
                &rays,
            ),
        }
    }
}
