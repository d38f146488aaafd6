//! A visitor written by a user ("the first N hits", as an audio engine counting surfaces
//! would), run through every structure's one-ray traversal: it sees exactly the hits the
//! built-in queries see, and ending the ray (`tmax = RAY_DONE`) stops the walk at once; the
//! same through `AnyAccel`.

use crate::common::meshes::{icosphere, transformed};
use crate::common::oracles::bits;
use crate::common::rays::hard_rays;
use glam::DVec3;
use raybatch::RAY_DONE;
use raybatch::zbt::ZbtOptions;
use raybatch::{
    AccelKind, BuildOptions, Hit, Kernel, KindTask, Mesh, Ray, RayQueries, Structure, Visitor,
    ZeroByteTree,
};

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

fn check<A: RayQueries>(name: &str, tree: &A, rays: &[Ray]) {
    for ray in rays {
        let all: Vec<_> = tree.all_hits(ray).iter().map(bits).collect();
        for n in [1, 2, 3, 7] {
            let mut first = FirstHits {
                n,
                seen: Vec::new(),
                calls_after_done: 0,
            };
            tree.visit(ray, Kernel::Watertight, &mut first);
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

/// [`check`] on the concrete tree inside an `AnyAccel`.
struct Check<'a> {
    rays: &'a [Ray],
}

impl KindTask for Check<'_> {
    type Output = ();
    fn run<A: Structure>(self, kind: AccelKind, tree: &A) {
        check(kind.name(), tree, self.rays);
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
        let any = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        any.run(Check { rays: &rays });
        check(&format!("{} (AnyAccel)", kind.name()), &any, &rays);
    }
    let no_cache = ZbtOptions {
        box_cache: false,
        ..ZbtOptions::default()
    };
    let (tree, _) = ZeroByteTree::build(mesh.clone(), &no_cache).unwrap();
    check("zbt without its box cache", &tree, &rays);
}
