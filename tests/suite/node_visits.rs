//! `cast_ray_visits` (the `Visitor::enter_node` hook): on every structure of the catalog it
//! answers what `cast_ray` answers, bit for bit, counts at least one node for a ray that hits,
//! none for a ray that misses the structure's bounds, and more for a ray that crosses the whole
//! mesh than for the same ray stopped before it.

use std::sync::Arc;

use crate::common::meshes::icosphere;
use crate::common::oracles::opt_bits;
use raybatch::RayQueries;
use raybatch::glam::Vec3;
use raybatch::{AccelKind, BuildOptions, Kernel, Ray};

#[test]
fn visits_come_with_the_closest_hit_on_every_structure() {
    let mesh = Arc::new(icosphere(3));
    let targets: Vec<Vec3> = (0..40)
        .map(|i| {
            let a = i as f32 * 0.7;
            Vec3::new(a.cos(), a.sin(), (a * 0.3).sin()) * 0.6
        })
        .collect();
    for kind in AccelKind::ALL {
        let tree = kind.build(mesh.clone(), &BuildOptions::default()).unwrap();
        for kernel in Kernel::ALL {
            for &target in &targets {
                let origin = Vec3::new(3.0, 2.0, -2.5);
                let ray = Ray::new(origin, target - origin);
                let (hit, visits) = tree.cast_ray_visits(&ray, kernel);
                assert_eq!(opt_bits(hit), opt_bits(tree.cast_ray_with(&ray, kernel)));
                assert!(hit.is_some() && visits >= 1, "{}: {visits}", kind.name());
                let away = Ray::new(origin, origin);
                assert_eq!(
                    tree.cast_ray_visits(&away, kernel),
                    (None, 0),
                    "{}",
                    kind.name()
                );
                let short = Ray::with_range(origin, target - origin, 0.0, 0.05);
                let (none, fewer) = tree.cast_ray_visits(&short, kernel);
                assert!(none.is_none() && fewer < visits, "{}", kind.name());
            }
        }
        let invalid = Ray::new(Vec3::NAN, Vec3::X);
        assert_eq!(
            tree.cast_ray_visits(&invalid, Kernel::Watertight),
            (None, 0)
        );
    }
}
