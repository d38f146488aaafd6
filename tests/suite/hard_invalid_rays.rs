//! Hard cases of invalid and extreme rays: NaN or infinite origins, directions and ranges, zero
//! and subnormal directions miss everywhere without a panic (each with its `RayError`); valid
//! but extreme rays answer like the brute-force reference, in every structure of the zoo.

use crate::common::meshes::icosphere;
use crate::common::oracles::{
    assert_matches_brute_force, assert_misses_everywhere, opt_bits, unanimous_hit,
};
use crate::common::zoo::all_structures;
use glam::Vec3;
use raybatch::{Kernel, Mesh, Ray, RayError};

/// A mesh with something to hit from the origin in every direction.
fn enclosing_mesh() -> Mesh {
    icosphere(1)
}

#[test]
fn nan_and_infinite_rays_miss_without_panic() {
    let mesh = enclosing_mesh();
    let zoo = all_structures(&mesh);
    let o = Vec3::new(0.1, -0.2, 0.05);
    let d = Vec3::new(0.3, 0.4, -0.5);
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let bad = [
        (
            Ray::new(Vec3::new(nan, 0.0, 0.0), d),
            RayError::NonFiniteOrigin,
        ),
        (
            Ray::new(Vec3::new(0.0, 0.0, -nan), d),
            RayError::NonFiniteOrigin,
        ),
        (
            Ray::new(Vec3::new(0.0, inf, 0.0), d),
            RayError::NonFiniteOrigin,
        ),
        (Ray::new(Vec3::splat(-inf), d), RayError::NonFiniteOrigin),
        // The origin is checked first.
        (Ray::new(Vec3::NAN, Vec3::NAN), RayError::NonFiniteOrigin),
        (
            Ray::new(o, Vec3::new(nan, 1.0, 0.0)),
            RayError::NonFiniteDirection,
        ),
        (
            Ray::new(o, Vec3::new(0.0, 0.0, inf)),
            RayError::NonFiniteDirection,
        ),
        (
            Ray::new(o, Vec3::new(1.0, -inf, 0.0)),
            RayError::NonFiniteDirection,
        ),
        (Ray::new(o, Vec3::NAN), RayError::NonFiniteDirection),
        (Ray::with_range(o, d, nan, 1.0), RayError::InvalidRange),
        (Ray::with_range(o, d, 0.0, nan), RayError::InvalidRange),
        (Ray::with_range(o, d, nan, nan), RayError::InvalidRange),
        (Ray::with_range(o, d, -1.0, 1.0), RayError::InvalidRange),
        (
            Ray::with_range(o, d, -f32::MIN_POSITIVE, 1.0),
            RayError::InvalidRange,
        ),
        (Ray::with_range(o, d, -inf, inf), RayError::InvalidRange),
        (Ray::with_range(o, d, inf, inf), RayError::InvalidRange),
        (Ray::with_range(o, d, 2.0, 1.0), RayError::InvalidRange),
        (Ray::with_range(o, d, 0.0, -inf), RayError::InvalidRange),
        (Ray::with_range(o, d, 0.0, -1.0), RayError::InvalidRange),
    ];
    for (ray, err) in bad {
        assert_eq!(ray.validate(), Err(err), "{ray:?}");
        assert!(!ray.is_valid());
        assert!(!err.to_string().is_empty());
        assert_misses_everywhere(&mesh, &zoo, &ray);
    }
    // The same rays with their problem removed do hit: the misses above are not accidents.
    for ray in [
        Ray::new(o, d),
        Ray::with_range(o, d, 0.0, inf),
        Ray::with_range(o, d, -0.0, inf),
    ] {
        assert_eq!(ray.validate(), Ok(()));
        assert_matches_brute_force(&mesh, &zoo, &ray);
        assert!(unanimous_hit(&zoo, &ray).is_some());
    }
    // Valid but extreme rays: no panic, same answer as brute force.
    let extreme = [
        Ray::new(Vec3::splat(1e38), Vec3::splat(-3e38)),
        Ray::new(Vec3::splat(-3.4e38), Vec3::new(f32::MAX, 1.0, 1.0)),
        Ray::new(Vec3::new(1e30, 0.0, 0.0), -Vec3::X),
        Ray::new(o, Vec3::new(f32::MAX, f32::MAX, -f32::MAX)),
        Ray::new(o, Vec3::new(f32::MIN_POSITIVE, 0.0, 0.0)),
        Ray::with_range(o, d, f32::MAX, f32::MAX),
        Ray::with_range(o, d, 0.0, 0.0),
    ];
    for ray in extreme {
        assert_eq!(ray.validate(), Ok(()), "{ray:?}");
        assert_matches_brute_force(&mesh, &zoo, &ray);
    }
}

#[test]
fn zero_direction_misses() {
    let mesh = enclosing_mesh();
    let zoo = all_structures(&mesh);
    let sub = f32::MIN_POSITIVE / 2.0; // subnormal
    let zero_dirs = [
        Vec3::ZERO,
        Vec3::new(-0.0, 0.0, -0.0),
        Vec3::splat(-0.0),
        Vec3::new(sub, 0.0, 0.0),
        Vec3::new(-sub, sub, -1e-45),
        Vec3::splat(1e-40),
    ];
    // From inside, and from a vertex (on the surface, where t = 0 would otherwise hit).
    for origin in [Vec3::new(0.1, 0.0, 0.0), mesh.vertices()[0]] {
        for dir in zero_dirs {
            let ray = Ray::new(origin, dir);
            assert_eq!(ray.validate(), Err(RayError::ZeroDirection), "{dir:?}");
            assert_misses_everywhere(&mesh, &zoo, &ray);
            let seg = Ray::segment(origin, origin + dir);
            assert_misses_everywhere(&mesh, &zoo, &seg);
        }
        assert_misses_everywhere(&mesh, &zoo, &Ray::segment(origin, origin));
    }
    // Subnormal components next to a normal one count as zero: same answers, bit for bit,
    // as the direction with exact zeros.
    let origin = Vec3::new(0.1, 0.2, 0.0);
    for (with_sub, flushed) in [
        (Vec3::new(1.0, sub, -sub), Vec3::new(1.0, 0.0, -0.0)),
        (Vec3::new(1e-40, -2.0, 0.0), Vec3::new(0.0, -2.0, 0.0)),
        (Vec3::new(-1e-45, 1e-45, 0.5), Vec3::new(-0.0, 0.0, 0.5)),
    ] {
        let a = Ray::new(origin, with_sub);
        let b = Ray::new(origin, flushed);
        assert_eq!(a.validate(), Ok(()));
        assert_matches_brute_force(&mesh, &zoo, &a);
        for t in &zoo {
            for kernel in Kernel::ALL {
                let (ha, hb) = (
                    t.accel.cast_ray_with(&a, kernel),
                    t.accel.cast_ray_with(&b, kernel),
                );
                assert!(ha.is_some());
                assert_eq!(opt_bits(ha), opt_bits(hb), "{} {kernel:?}", t.name);
            }
        }
    }
}
