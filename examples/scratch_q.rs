use raybatch::scenes::{self, SceneKind, rays::RaySet};
use raybatch::*;
use std::time::Instant;
fn main() {
    let s = scenes::bunny();
    let rays = scenes::rays::generate(RaySet::Incoherent, &s.mesh, SceneKind::Object, 1_000_000, 1);
    let o = BuildOptions::default();
    let full: AabbTree = AabbTree::build(s.mesh.clone(), &o).unwrap();
    let q = QuantizedAabbTree::build(s.mesh.clone(), &o).unwrap();
    let fc: AabbTree = AabbTree::build(s.mesh.clone(), &o.with_leaf_corners(true)).unwrap();
    for _ in 0..6 {
        let t0 = Instant::now();
        let a = rays.iter().filter(|r| full.cast_ray(r).is_some()).count();
        let t1 = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let b = rays.iter().filter(|r| q.cast_ray(r).is_some()).count();
        let t2 = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let c = rays.iter().filter(|r| fc.cast_ray(r).is_some()).count();
        let t3 = t0.elapsed().as_secs_f64();
        println!(
            "full {:.2} quant {:.2} corners {:.2} Mr/s {a} {b} {c}",
            1.0 / t1,
            1.0 / t2,
            1.0 / t3
        );
    }
}
