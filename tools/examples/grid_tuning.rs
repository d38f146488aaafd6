//! The spatial structures' knobs, measured against the AABB tree: the kd-tree's leaf size, the
//! grid's density (cells per triangle) and resolution, the spatial hash against the dense grid
//! with the same cells, on the ray sets of `raybatch bench` plus vertical rays (straight down from above
//! the bounds, the height field's typical query). One thread, per ray, Mrays/s; every
//! variant's closest hits are checked against the AABB tree's (same triangle, same `t` bits).
//!
//! `cargo run --release -p raybatch-tools --example grid_tuning [-- bunny|terrain|city|sparse [RAYS]]`
//!
//! `... grid_tuning -- race SCENE RAYS [NXxNYxNZ]` times the AABB tree and the grid (at its
//! defaults, or at the given resolution) on the short and vertical rays (the terrain targets of
//! issue 11), per ray and batched, in alternation within one process (best of 7 rounds each):
//! on a noisy machine the ratio of two runs made side by side holds where separate runs drift.
//!
//! `... grid_tuning -- profile SCENE SET aabb|grid|grid-cube|grid:NXxNYxNZ|kd RAYS`
//! (`grid-cube`: the grid with cube cells, `GridOptions::shaped_cells` off) builds one structure and traces one
//! ray set (`incoherent`, `camera`, `short`, `vertical`) through `trace_set`, a function of its
//! own, so that `valgrind --tool=callgrind --collect-atstart=no
//! --toggle-collect='*trace_set*'` counts the instructions of the queries alone (not the
//! scene, the rays or the build): divide by RAYS for instructions per ray.

use std::time::Instant;

use raybatch::glam::Vec3;
use raybatch::grid::HASH_CELLS_PER_TRIANGLE;
use raybatch::{
    AabbTree, Accel, BatchQueries, BuildOptions, Footprint, GridOptions, Hit, KdTree, Mesh, Ray,
    RayQueries, SpatialHash, UniformGrid,
};
use raybatch_tools::scenes::{self, RaySet, SplitMix64};

fn main() {
    let mut args = std::env::args().skip(1);
    let first = args.next();
    if first.as_deref() == Some("profile") {
        let rest: Vec<String> = args.collect();
        let [scene, set, structure, count] = rest.as_slice() else {
            panic!("profile SCENE SET aabb|grid|grid-cube|grid:NXxNYxNZ|kd RAYS");
        };
        return profile(scene, set, structure, count.parse().expect("a ray count"));
    }
    if first.as_deref() == Some("race") {
        let scene = args.next().unwrap_or_else(|| "terrain".into());
        let count = args
            .next()
            .map_or(200_000, |n| n.parse().expect("a ray count"));
        let resolution = args.next().map(|r| parse_resolution(&r));
        return race(&scene, count, resolution);
    }
    let scene = scene(first.as_deref().unwrap_or("terrain"));
    let count: usize = args
        .next()
        .map_or(100_000, |n| n.parse().expect("a ray count"));
    let sets: Vec<(&str, Vec<Ray>)> = ["incoherent", "camera", "short", "vertical"]
        .into_iter()
        .map(|s| (s, ray_set(&scene, s, count)))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    println!(
        "{} ({} triangles), {count} rays per set, closest hit, one thread, Mrays/s (ratio to aabb)\n",
        scene.name,
        scene.mesh.triangle_count()
    );
    let names: Vec<&str> = sets.iter().map(|(n, _)| *n).collect();
    println!(
        "| variant | build ms | B/tri | cells | {} |",
        names.join(" | ")
    );
    println!("|---|---|---|---|{}", "---|".repeat(names.len()));
    pool.install(|| {
        let start = Instant::now();
        let aabb: AabbTree = AabbTree::build(scene.mesh.clone(), &BuildOptions::default()).unwrap();
        let ms = ms_since(start);
        let reference: Vec<(Vec<Option<Hit>>, f64)> =
            sets.iter().map(|(_, rays)| measure(&aabb, rays)).collect();
        row("aabb", ms, &aabb, &reference, &reference);
        for leaf in [1, 4] {
            let start = Instant::now();
            let kd = KdTree::build(scene.mesh.clone(), leaf).unwrap();
            let ms = ms_since(start);
            let m: Vec<_> = sets.iter().map(|(_, rays)| measure(&kd, rays)).collect();
            check(&reference, &m);
            row(
                &format!("kd leaf {leaf}, depth {}", kd.depth()),
                ms,
                &kd,
                &m,
                &reference,
            );
        }
        for (density, shaped_cells) in [(2.0, true), (2.0, false), (1.0, true), (4.0, true)] {
            let options = GridOptions {
                cells_per_triangle: density,
                shaped_cells,
                ..GridOptions::default()
            };
            let start = Instant::now();
            let grid = UniformGrid::build(scene.mesh.clone(), &options).unwrap();
            let ms = ms_since(start);
            let m: Vec<_> = sets.iter().map(|(_, rays)| measure(&grid, rays)).collect();
            check(&reference, &m);
            let cells = if shaped_cells { "shaped" } else { "cube" };
            let name = format!("grid {density} cells/tri, {cells} {:?}", grid.resolution());
            row(&name, ms, &grid, &m, &reference);
        }
        // On the sparse world, also cells near the size of its rocks (512 and 1,024 per
        // triangle), where the dense grid's bits for empty cells outweigh the references.
        let fine: &[f32] = if scene.name == "sparse" {
            &[512.0, 1024.0]
        } else {
            &[]
        };
        for &density in [2.0, HASH_CELLS_PER_TRIANGLE, 64.0].iter().chain(fine) {
            // The hash, and the dense grid with the same cells.
            let options = GridOptions {
                cells_per_triangle: density,
                ..SpatialHash::default_options()
            };
            let start = Instant::now();
            let hash = SpatialHash::build(scene.mesh.clone(), &options).unwrap();
            let ms = ms_since(start);
            let m: Vec<_> = sets.iter().map(|(_, rays)| measure(&hash, rays)).collect();
            check(&reference, &m);
            let resolution = hash.resolution();
            row(
                &format!("hash {density} cells/tri {resolution:?}"),
                ms,
                &hash,
                &m,
                &reference,
            );
            let options = GridOptions {
                resolution: Some(resolution),
                max_cells: 1 << 28,
                ..GridOptions::default()
            };
            let start = Instant::now();
            let grid = UniformGrid::build(scene.mesh.clone(), &options).unwrap();
            let ms = ms_since(start);
            let m: Vec<_> = sets.iter().map(|(_, rays)| measure(&grid, rays)).collect();
            check(&reference, &m);
            row(
                &format!("grid {:?}", grid.resolution()),
                ms,
                &grid,
                &m,
                &reference,
            );
        }
        if scene.name != "terrain" {
            return;
        }
        let extent = scene.mesh.bounds().extent();
        for (across, up) in [(708, 8), (500, 8)] {
            // Fine cells across the scene's two largest axes, `up` along the smallest.
            let small = (0..3)
                .min_by(|&a, &b| extent[a].total_cmp(&extent[b]))
                .unwrap();
            let mut resolution = [across; 3];
            resolution[small] = up;
            let options = GridOptions {
                resolution: Some(resolution),
                ..GridOptions::default()
            };
            let start = Instant::now();
            let grid = UniformGrid::build(scene.mesh.clone(), &options).unwrap();
            let ms = ms_since(start);
            let m: Vec<_> = sets.iter().map(|(_, rays)| measure(&grid, rays)).collect();
            check(&reference, &m);
            let name = format!("grid {resolution:?}");
            row(&name, ms, &grid, &m, &reference);
        }
    });
}

/// The built-in scene called `name`.
fn scene(name: &str) -> scenes::Scene {
    scenes::named(name)
        .unwrap_or_else(|| panic!("unknown scene {name}: bunny, terrain, city or sparse"))
}

/// `count` rays of the set called `name`: one of `raybatch bench`'s, or `vertical`.
fn ray_set(scene: &scenes::Scene, name: &str, count: usize) -> Vec<Ray> {
    if name == "vertical" {
        return vertical_rays(&scene.mesh, count);
    }
    let set = RaySet::from_name(name).unwrap_or_else(|| panic!("unknown ray set {name}"));
    scenes::generate(set, &scene.mesh, scene.kind, count, 7)
}

/// The `profile` mode (see the module docs): one structure at its defaults, one ray set.
fn profile(scene: &str, set: &str, structure: &str, count: usize) {
    let scene = self::scene(scene);
    let rays = ray_set(&scene, set, count);
    let mesh = scene.mesh;
    let hits = match structure {
        "aabb" => {
            let tree: AabbTree = AabbTree::build(mesh, &BuildOptions::default()).unwrap();
            trace_set(&tree, &rays)
        }
        "grid" | "grid-cube" => {
            let options = GridOptions {
                shaped_cells: structure == "grid",
                ..GridOptions::default()
            };
            let grid = UniformGrid::build(mesh, &options).unwrap();
            println!("{:?}", grid.resolution());
            trace_set(&grid, &rays)
        }
        shaped if shaped.starts_with("grid:") => {
            // `grid:NXxNYxNZ`: a grid of that resolution.
            let options = GridOptions {
                resolution: Some(parse_resolution(&shaped[5..])),
                ..GridOptions::default()
            };
            let grid = UniformGrid::build(mesh, &options).unwrap();
            println!("{:?}", grid.resolution());
            trace_set(&grid, &rays)
        }
        "kd" => trace_set(&KdTree::build(mesh, 4).unwrap(), &rays),
        other => panic!("unknown structure {other}: aabb, grid or kd"),
    };
    println!("{hits} of {count} rays hit");
}

/// `NXxNYxNZ` as cells along x, y and z.
fn parse_resolution(text: &str) -> [u32; 3] {
    let dims: Vec<u32> = text.split('x').map(|d| d.parse().unwrap()).collect();
    [dims[0], dims[1], dims[2]]
}

/// The `race` mode (see the module docs), with the grid at its defaults or at `resolution`.
fn race(scene: &str, count: usize, resolution: Option<[u32; 3]>) {
    let scene = self::scene(scene);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let aabb: AabbTree = AabbTree::build(scene.mesh.clone(), &BuildOptions::default()).unwrap();
    let options = GridOptions {
        resolution,
        ..GridOptions::default()
    };
    let grid = UniformGrid::build(scene.mesh.clone(), &options).unwrap();
    println!(
        "{} ({} triangles), grid {:?} at {:.1} B/tri, aabb {:.1} B/tri; {count} rays, closest \
         hit, one thread, ms (best of {ROUNDS} alternated rounds)\n",
        scene.name,
        scene.mesh.triangle_count(),
        grid.resolution(),
        grid.bytes_per_triangle(),
        aabb.bytes_per_triangle()
    );
    println!(
        "| rays | aabb per ray | grid per ray | ratio | aabb batched | grid batched | ratio |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for set in ["short", "vertical"] {
        let rays = ray_set(&scene, set, count);
        let mut best = [f64::INFINITY; 4];
        let mut answers: Vec<Vec<Option<Hit>>> = vec![vec![None; rays.len()]; 4];
        pool.install(|| {
            for _ in 0..ROUNDS {
                for (k, out) in answers.iter_mut().enumerate() {
                    let start = Instant::now();
                    match k {
                        0 => per_ray(&aabb, &rays, out),
                        1 => per_ray(&grid, &rays, out),
                        2 => aabb.cast_rays(&rays, out).unwrap(),
                        _ => grid.cast_rays(&rays, out).unwrap(),
                    }
                    best[k] = best[k].min(ms_since(start));
                }
            }
        });
        for other in &answers[1..] {
            assert_same_hits(&answers[0], other);
        }
        println!(
            "| {set} | {:.1} | {:.1} | {:.2} | {:.1} | {:.1} | {:.2} |",
            best[0],
            best[1],
            best[0] / best[1],
            best[2],
            best[3],
            best[2] / best[3]
        );
    }
    println!("\n(ratio: the grid's speed over the tree's; above 1 the grid is faster)");
}

/// Rounds of the `race` mode.
const ROUNDS: usize = 7;

/// Closest hits of `rays` one at a time into `out`.
fn per_ray<A: Accel>(accel: &A, rays: &[Ray], out: &mut [Option<Hit>]) {
    for (ray, hit) in rays.iter().zip(out) {
        *hit = accel.cast_ray(ray);
    }
}

/// Closest hits of `rays`, counted: the only code a profile of the `profile` mode collects.
#[inline(never)]
fn trace_set<A: Accel>(accel: &A, rays: &[Ray]) -> usize {
    rays.iter().filter(|r| accel.cast_ray(r).is_some()).count()
}

/// Rays straight down from above the bounds at uniform random `x`, `z`.
fn vertical_rays(mesh: &Mesh, count: usize) -> Vec<Ray> {
    let b = mesh.bounds();
    let mut rng = SplitMix64::new(99);
    (0..count)
        .map(|_| {
            let x = b.min.x + rng.next_f32() * (b.max.x - b.min.x);
            let z = b.min.z + rng.next_f32() * (b.max.z - b.min.z);
            Ray::new(Vec3::new(x, b.max.y + 1.0, z), -Vec3::Y)
        })
        .collect()
}

/// Closest hits of every ray and Mrays/s (best of two passes).
fn measure<A: Accel>(accel: &A, rays: &[Ray]) -> (Vec<Option<Hit>>, f64) {
    let mut best = 0.0f64;
    let mut hits = Vec::new();
    for _ in 0..2 {
        let start = Instant::now();
        hits = rays.iter().map(|r| accel.cast_ray(r)).collect();
        best = best.max(rays.len() as f64 / start.elapsed().as_secs_f64() / 1e6);
    }
    (hits, best)
}

/// Panics unless every closest hit equals the reference's, bit for bit.
fn check(reference: &[(Vec<Option<Hit>>, f64)], m: &[(Vec<Option<Hit>>, f64)]) {
    for ((a, _), (b, _)) in reference.iter().zip(m) {
        assert_same_hits(a, b);
    }
}

/// Panics unless the two lists of closest hits are the same, bit for bit.
fn assert_same_hits(a: &[Option<Hit>], b: &[Option<Hit>]) {
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let bits = |h: &Option<Hit>| h.map(|h| (h.triangle, h.t.to_bits(), h.u.to_bits()));
        assert_eq!(bits(x), bits(y), "ray {i}");
    }
}

fn row<A: Footprint>(
    name: &str,
    ms: f64,
    accel: &A,
    m: &[(Vec<Option<Hit>>, f64)],
    reference: &[(Vec<Option<Hit>>, f64)],
) {
    let speeds: Vec<String> = m
        .iter()
        .zip(reference)
        .map(|((_, s), (_, r))| format!("{s:.2} ({:.2}x)", s / r))
        .collect();
    println!(
        "| {name} | {ms:.0} | {:.1} | {} | {} |",
        accel.bytes_per_triangle(),
        accel.node_count(),
        speeds.join(" | ")
    );
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}
