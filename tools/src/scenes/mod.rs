//! The built-in benchmark scenes and ray sets of `raybatch bench`.
//!
//! Four scenes with different shapes of difficulty: a scanned object (the Stanford bunny:
//! small, dense, closed), a 1M-triangle terrain (huge, flat, thin boxes), a procedural city
//! (many separate boxes, lots of empty space) and a game level (large ground triangles under
//! thousands of boxes, short sightlines that are mostly blocked). [`rays`] generates the ray
//! sets to shoot at them.
//! Everything is deterministic: the same seed gives the same scene and rays on every machine
//! (see [`rng`] for why that needs our own generator).

mod city;
pub mod closed;
pub mod instanced;
mod level;
pub mod rays;
pub mod rng;
mod sparse;
mod terrain;

pub use rays::{RaySet, generate};
pub use rng::SplitMix64;

use raybatch::glam::Vec3;
use raybatch::{Aabb, Mesh};

/// A named mesh and what kind of scene it is.
#[derive(Clone, Debug)]
pub struct Scene {
    /// `bunny`, `terrain`, `city`, `level`: what `raybatch bench --scenes` calls it.
    pub name: &'static str,
    /// The triangles.
    pub mesh: Mesh,
    /// Where the ray sets put cameras and sightlines.
    pub kind: SceneKind,
}

/// The broad shape of a scene, which decides where cameras and line-of-sight endpoints go.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SceneKind {
    /// A single object seen from around it.
    Object,
    /// A heightfield seen from above; sightlines just above its surface.
    Terrain,
    /// Buildings on a ground plane; sightlines between pedestrians in the streets.
    City,
    /// A game level: buildings and clutter on a ground grid; short sightlines between agents
    /// standing anywhere in the open.
    Level,
}

/// Cells per side of the built-in terrain: `2 * 708^2 = 1,002,528` triangles, about a million.
pub const BUILTIN_TERRAIN_CELLS: u32 = 708;
/// Blocks per side of the built-in city: about 100k triangles.
pub const BUILTIN_CITY_BLOCKS: u32 = 48;

/// Clusters of the built-in sparse world: 200 clusters of 40 rocks, 96,000 triangles.
pub const BUILTIN_SPARSE_CLUSTERS: u32 = 200;

/// Fixed seeds: the scenes are part of the benchmark's definition, not a parameter of it.
const TERRAIN_SEED: u64 = 0x7e44_a1b0;
const CITY_SEED: u64 = 0xc1_7e5;
const SPARSE_SEED: u64 = 0x5ba_55e;
const LEVEL_SEED: u64 = 0x1e_7e1;

/// The Stanford bunny (69,451 triangles), embedded in the binary.
pub fn bunny() -> Scene {
    let text = include_str!("../../../data/stanford-bunny.obj");
    Scene {
        name: "bunny",
        // The file ships with the crate and a unit test parses it, so this cannot fail.
        mesh: Mesh::from_obj_str(text).expect("the embedded bunny is a valid OBJ file"),
        kind: SceneKind::Object,
    }
}

/// A rolling heightfield over `[0, 1000]^2` in `x`, `z` with hills up to 100 units high:
/// `2 * n^2` triangles for `n = cells_per_side` (at least 1).
///
/// Panics above 65,534 cells per side (the vertices would not fit 32-bit indices).
pub fn terrain(cells_per_side: u32) -> Scene {
    Scene {
        name: "terrain",
        mesh: terrain::mesh(cells_per_side, TERRAIN_SEED),
        kind: SceneKind::Terrain,
    }
}

/// A city of `blocks_per_side^2` blocks of box buildings separated by 20-unit streets, on a
/// ground quad; 100 units per block, about 43 triangles per block on average.
pub fn city(blocks_per_side: u32) -> Scene {
    Scene {
        name: "city",
        mesh: city::mesh(blocks_per_side, CITY_SEED),
        kind: SceneKind::City,
    }
}

/// A sparse open world: `clusters` clusters of 40 small rocks (12 triangles each) scattered
/// over a 10,000 x 2,000 x 10,000 volume, nothing in between (no ground): the spatial hash's
/// home ground. Seen from around, like an object.
pub fn sparse(clusters: u32) -> Scene {
    Scene {
        name: "sparse",
        mesh: sparse::mesh(clusters, SPARSE_SEED),
        kind: SceneKind::Object,
    }
}

/// A game level: a 640 m square of flat ground made of 10 m cells (8,192 large triangles), a
/// lattice of 20 m lots with one axis-aligned box building each (11-18 m wide, 4-20 m high; one
/// lot in ten is an empty square) and `clutter` boxes of 0.6-6 m turned about the vertical,
/// anywhere; 12 triangles per box.
pub fn level(clutter: u32) -> Scene {
    Scene {
        name: "level",
        mesh: level::mesh(clutter, LEVEL_SEED),
        kind: SceneKind::Level,
    }
}

/// The names [`named`] knows, as `raybatch bench --scenes` names them.
pub const NAMES: [&str; 5] = ["bunny", "terrain", "city", "level", "sparse"];

/// The built-in scene called `name` (one of [`NAMES`]); `None` for another name.
pub fn named(name: &str) -> Option<Scene> {
    Some(match name {
        "bunny" => bunny(),
        "terrain" => terrain(BUILTIN_TERRAIN_CELLS),
        "city" => city(BUILTIN_CITY_BLOCKS),
        "sparse" => sparse(BUILTIN_SPARSE_CLUSTERS),
        "level" => level(level::BUILTIN_CLUTTER),
        _ => return None,
    })
}

/// The scene a command-line argument names: the bunny if there is none, an OBJ file if it
/// ends in `.obj`, else a built-in scene ([`named`]). Panics with the choices otherwise (for
/// arguments a person types).
pub fn from_arg(arg: Option<&str>) -> Scene {
    match arg {
        None => bunny(),
        Some(path) if path.ends_with(".obj") => Scene {
            name: "mesh",
            mesh: raybatch::Mesh::load_obj(path).expect("a readable OBJ file"),
            kind: SceneKind::Object,
        },
        Some(name) => named(name)
            .unwrap_or_else(|| panic!("unknown scene {name}: {} or a .obj file", NAMES.join(", "))),
    }
}

/// The scenes `raybatch bench` runs: the bunny, the 1M-triangle terrain, the city and the
/// game level.
pub fn builtin() -> Vec<Scene> {
    vec![
        bunny(),
        terrain(BUILTIN_TERRAIN_CELLS),
        city(BUILTIN_CITY_BLOCKS),
        level(level::BUILTIN_CLUTTER),
    ]
}

/// Appends the 12 triangles of the closed box `bounds` (its corners in [`Aabb::corners`]
/// order), outward-facing: the crates of the instanced worlds and the rocks of the sparse one.
pub(crate) fn push_box(vertices: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>, bounds: Aabb) {
    const FACES: [[u32; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let base = vertices.len() as u32;
    vertices.extend(bounds.corners());
    for [a, b, c, d] in FACES {
        triangles.push([base + a, base + b, base + c]);
        triangles.push([base + a, base + c, base + d]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bunny_parses_with_every_triangle() {
        let b = bunny();
        assert_eq!(b.mesh.triangle_count(), 69_451);
        assert_eq!(b.kind, SceneKind::Object);
        let bounds = b.mesh.bounds();
        assert!(!bounds.is_empty() && bounds.extent().min_element() > 0.0);
    }

    #[test]
    fn named_knows_exactly_its_names() {
        for name in NAMES {
            assert_eq!(named(name).map(|s| s.name), Some(name));
        }
        assert!(named("nope").is_none());
    }

    #[test]
    fn scenes_are_deterministic() {
        assert_eq!(terrain(20).mesh, terrain(20).mesh);
        assert_eq!(sparse(3).mesh, sparse(3).mesh);
        assert_eq!(sparse(3).mesh.triangle_count(), 3 * 40 * 12);
        assert_eq!(city(5).mesh, city(5).mesh);
    }

    #[test]
    fn small_scenes_have_the_documented_sizes() {
        assert_eq!(terrain(10).mesh.triangle_count(), 200);
        let c = city(3).mesh;
        assert_eq!((c.triangle_count() - 2) % 12, 0);
    }

    // About a second in a debug build: run with `cargo test --release` (or `--ignored`).
    #[test]
    #[cfg_attr(
        debug_assertions,
        ignore = "builds a million triangles; run in release"
    )]
    fn builtin_scenes_have_their_sizes() {
        let scenes = builtin();
        let names: Vec<_> = scenes.iter().map(|s| s.name).collect();
        assert_eq!(names, ["bunny", "terrain", "city", "level"]);
        assert_eq!(scenes[3].mesh.triangle_count(), 45_812);
        assert_eq!(scenes[1].mesh.triangle_count(), 1_002_528);
        let city_triangles = scenes[2].mesh.triangle_count();
        assert!(
            (50_000..=200_000).contains(&city_triangles),
            "{city_triangles}"
        );
        let t = scenes[1].mesh.bounds();
        assert_eq!(
            (t.min.x, t.min.z, t.max.x, t.max.z),
            (0.0, 0.0, 1000.0, 1000.0)
        );
        assert!(t.min.y >= 0.0 && t.max.y <= 100.0);
    }
}
