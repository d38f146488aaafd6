//! The README's quickstart, compiled: `cargo run --release --example quickstart`.

use raybatch::glam::Vec3;
use raybatch::{AccelKind, BatchQueries, BuildOptions, Hit, Mesh, Ray, RayQueries};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mesh = Mesh::load_obj("data/stanford-bunny.obj")?; // or Mesh::new(vertices, triangles)?
    // The library's pick for this mesh (`AccelKind::for_mesh`); every kind answers the same.
    let tree = AccelKind::for_mesh(&mesh).build(mesh, &BuildOptions::default())?;

    // One ray at a time.
    let ray = Ray::new(Vec3::new(0.0, 0.1, 1.0), Vec3::new(0.0, 0.0, -1.0));
    if let Some(Hit { t, triangle, u, v }) = tree.cast_ray(&ray) {
        println!("hit triangle {triangle} at t = {t} (u = {u}, v = {v})");
    }
    let blocked = tree.occluded(&Ray::segment(Vec3::ZERO, Vec3::new(0.0, 0.2, 0.0)));
    println!("segment blocked: {blocked}");

    // A whole batch: one pass down the tree, split over rayon's threads; the same answers.
    let rays = vec![ray; 100_000];
    let mut hits = vec![None; rays.len()];
    tree.cast_ray_batch(&rays, &mut hits)?;
    let mut occluded = vec![false; rays.len()];
    tree.occluded_batch(&rays, &mut occluded)?;
    tree.for_each_hit_batch(&rays, |_ray, _hit| { /* e.g. sum losses per ray */ });
    Ok(())
}
