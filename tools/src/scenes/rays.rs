//! The ray sets of `raybatch bench`: five workloads with very different coherence and lengths.
//!
//! Each set answers a different question: how fast are random rays from anywhere (incoherent,
//! the worst case for caches), rays entering from outside (traversal from the root), primary
//! camera rays (coherent, what packets and sorting help most), short rays (ambient occlusion:
//! early exits), and line-of-sight segments (any-hit queries, mixed clear and blocked).
//! Everything derives from the seed through [`SplitMix64`], so runs are comparable everywhere.

use raybatch::glam::{Vec2, Vec3};
use raybatch::{Aabb, AccelKind, AnyAccel, BuildOptions, Mesh, Ray, RayQueries};
use rayon::prelude::*;

use super::SceneKind;
use super::city::{self, Street};
use super::level;
use super::rng::SplitMix64;
use super::terrain::TerrainGrid;

/// Which rays to generate; see [`generate`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RaySet {
    /// Origins uniform in the bounds, directions uniform on the sphere, unbounded.
    Incoherent,
    /// From a sphere around the bounds towards random points inside, unbounded.
    OutsideIn,
    /// Primary rays of a pinhole camera, row-major pixels, unbounded.
    Camera,
    /// Like `Incoherent` but only 2% of the bounds diagonal long (unit directions).
    Short,
    /// Segments between random pairs of points (`t` in `[0, 1]`), meant for any-hit queries.
    LineOfSight,
}

impl RaySet {
    /// Every set, in the order the benchmark reports them.
    pub const ALL: [RaySet; 5] = [
        RaySet::Incoherent,
        RaySet::OutsideIn,
        RaySet::Camera,
        RaySet::Short,
        RaySet::LineOfSight,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            RaySet::Incoherent => "incoherent",
            RaySet::OutsideIn => "outside-in",
            RaySet::Camera => "camera",
            RaySet::Short => "short",
            RaySet::LineOfSight => "line-of-sight",
        }
    }

    /// The set called `name` (as given by [`RaySet::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }
}

impl std::fmt::Display for RaySet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Length of `Short` rays as a fraction of the bounds diagonal.
const SHORT_FRACTION: f32 = 0.02;
/// `OutsideIn` origins lie on a sphere this many half-diagonals from the centre (outside the box).
const OUTSIDE_RADIUS: f32 = 1.5;
/// `LineOfSight` endpoints for objects lie on a sphere this many half-diagonals from the centre.
const OBJECT_SIGHT_RADIUS: f32 = 1.2;
/// Eye height of a pedestrian above the city ground.
const AGENT_HEIGHT: f32 = 1.8;
/// Height of terrain line-of-sight endpoints above the surface.
const TERRAIN_SIGHT_HEIGHT: f32 = 2.0;
/// Chance that the second end of a city sightline is on the same street as the first, which
/// keeps a good share of the segments clear.
const SAME_STREET: f32 = 0.3;
/// Heights of a level's agents' eyes above its ground (crouching to standing).
const LEVEL_EYE: (f32, f32) = (1.0, 2.0);
/// Lengths of a level's sightlines (horizontal distance between the agents).
const LEVEL_SIGHT: (f32, f32) = (20.0, 80.0);
/// Draws of an agent's place before giving up on finding open ground.
const LEVEL_TRIES: usize = 64;
/// `tan(22.5 deg)`, half the 45 degree vertical field of view, as a constant (no `tan` call: see
/// the [`super::rng`] docs on reproducibility).
const TAN_HALF_FOV: f32 = 0.414_213_57;

/// `count` rays of `set` for `mesh` (a scene of `kind`), reproducible from `seed` (the camera
/// needs no randomness and ignores it). Every ray passes [`Ray::validate`]; the result does not
/// depend on the number of threads.
///
/// The set only reads `mesh`'s bounds, except `LineOfSight` on a terrain built by
/// [`super::terrain()`], whose endpoints follow the triangulated surface, and `LineOfSight` in a
/// `Level`, whose endpoints are kept out of the mesh's boxes. A mesh of another shape with `kind`
/// `Terrain` falls back to the `Object` sightlines; with `kind` `City` it gets points at agent
/// height on the street grid a city of its size would have. An empty mesh gets the
/// rays of the box `[-1, 1]^3`.
pub fn generate(set: RaySet, mesh: &Mesh, kind: SceneKind, count: usize, seed: u64) -> Vec<Ray> {
    // One stream per set, so the sets generated with one seed are unrelated.
    let stream = SplitMix64::for_item(seed, set as u64).next_u64();
    let bounds = ray_bounds(mesh);
    match set {
        RaySet::Incoherent => per_ray(count, stream, |r| incoherent(r, &bounds, f32::INFINITY)),
        RaySet::Short => {
            let tmax = SHORT_FRACTION * bounds.extent().length();
            per_ray(count, stream, |r| incoherent(r, &bounds, tmax))
        }
        RaySet::OutsideIn => per_ray(count, stream, |r| outside_in(r, &bounds)),
        RaySet::Camera => Camera::for_scene(&bounds, kind).rays(count),
        RaySet::LineOfSight => line_of_sight(stream, mesh, &bounds, kind, count),
    }
}

/// `count` rays, ray `i` drawn by `ray` from its own generator [`SplitMix64::for_item`]`(stream,
/// i)`: generated in parallel, yet the same for any thread count.
fn per_ray(count: usize, stream: u64, ray: impl Fn(&mut SplitMix64) -> Ray + Sync) -> Vec<Ray> {
    (0..count)
        .into_par_iter()
        .map(|i| ray(&mut SplitMix64::for_item(stream, i as u64)))
        .collect()
}

/// The mesh bounds, made usable as a ray target: the unit box for an empty mesh, and padded by 1
/// if the mesh is a single point (so the half-diagonal is never zero).
fn ray_bounds(mesh: &Mesh) -> Aabb {
    let b = mesh.bounds();
    if b.is_empty() {
        Aabb::new(Vec3::splat(-1.0), Vec3::ONE)
    } else if b.extent().max_element() == 0.0 {
        Aabb::new(b.min - Vec3::ONE, b.max + Vec3::ONE)
    } else {
        b
    }
}

fn half_diagonal(bounds: &Aabb) -> f32 {
    0.5 * bounds.extent().length()
}

/// A ray from a uniform point in the bounds in a uniform direction (unit length).
fn incoherent(rng: &mut SplitMix64, bounds: &Aabb, tmax: f32) -> Ray {
    let origin = rng.point_in(bounds.min, bounds.max);
    Ray::with_range(origin, rng.unit_vector(), 0.0, tmax)
}

/// A ray from a uniform point on the enclosing sphere towards a uniform point in the bounds.
fn outside_in(rng: &mut SplitMix64, bounds: &Aabb) -> Ray {
    let out = rng.unit_vector();
    let origin = bounds.center() + out * (OUTSIDE_RADIUS * half_diagonal(bounds));
    let target = rng.point_in(bounds.min, bounds.max);
    // The sphere lies outside the box, so the direction is never zero; the fallback is a guard
    // against rounding on absurdly flat boxes only.
    let dir = (target - origin).normalize_or(-out);
    Ray::new(origin, dir)
}

/// A pinhole camera: rays through a grid of pixels on the image plane at distance 1.
struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
}

impl Camera {
    fn look_at(eye: Vec3, target: Vec3) -> Self {
        let forward = (target - eye).normalize_or(Vec3::Z);
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(forward);
        Self {
            eye,
            forward,
            right,
            up,
        }
    }

    /// Where each kind of scene is best looked at from, always outside the bounds.
    fn for_scene(bounds: &Aabb, kind: SceneKind) -> Self {
        let (min, max, e, c) = (bounds.min, bounds.max, bounds.extent(), bounds.center());
        match kind {
            // From the front, a little from the side and above, filling the frame.
            SceneKind::Object => {
                let offset = Vec3::new(0.45, 0.35, 1.0).normalize() * (1.8 * half_diagonal(bounds));
                Self::look_at(c + offset, c)
            }
            // From beyond a corner, high above the hills, looking down at about 25 degrees: the
            // near rows see the ground, the top rows reach the far side and the sky.
            SceneKind::Terrain => {
                let lift = 0.35 * e.x.max(e.z);
                let eye = Vec3::new(min.x - 0.1 * e.x, max.y + lift, min.z - 0.1 * e.z);
                Self::look_at(eye, c)
            }
            // From just outside a corner, between the street and the roofs, looking across the
            // city (or level) and slightly down.
            SceneKind::City | SceneKind::Level => {
                let eye_height = min.y + 0.12 * e.y;
                let eye = Vec3::new(min.x - 0.02 * e.x, eye_height, min.z - 0.02 * e.z);
                Self::look_at(eye, Vec3::new(c.x, min.y + 0.05 * e.y, c.z))
            }
        }
    }

    /// `count` rays through the first `count` pixels of a `w x h` image, `w = ceil(sqrt(count))`,
    /// in row-major order from the top-left corner.
    fn rays(&self, count: usize) -> Vec<Ray> {
        if count == 0 {
            return Vec::new();
        }
        let w = ceil_sqrt(count);
        let h = count.div_ceil(w);
        let aspect = w as f32 / h as f32;
        let mut rays = vec![Ray::new(self.eye, self.forward); count];
        // One task per image row (the last may be partial): no per-pixel division.
        rays.par_chunks_mut(w)
            .enumerate()
            .for_each(|(row, pixels)| {
                let sy = (1.0 - (row as f32 + 0.5) / h as f32 * 2.0) * TAN_HALF_FOV;
                for (col, ray) in pixels.iter_mut().enumerate() {
                    let sx = ((col as f32 + 0.5) / w as f32 * 2.0 - 1.0) * TAN_HALF_FOV * aspect;
                    ray.dir = (self.forward + self.right * sx + self.up * sy).normalize();
                }
            });
        rays
    }
}

/// The smallest `w` with `w * w >= n`.
fn ceil_sqrt(n: usize) -> usize {
    let w = n.isqrt();
    if w * w < n { w + 1 } else { w }
}

fn line_of_sight(
    stream: u64,
    mesh: &Mesh,
    bounds: &Aabb,
    kind: SceneKind,
    count: usize,
) -> Vec<Ray> {
    match (kind, TerrainGrid::from_mesh(mesh)) {
        (SceneKind::Terrain, Some(grid)) => per_ray(count, stream, |r| {
            segment(r, |r| terrain_sight_point(r, &grid, bounds))
        }),
        (SceneKind::City, _) => {
            let blocks = city::blocks_from_extent(bounds.extent().x);
            per_ray(count, stream, |r| city_sightline(r, blocks))
        }
        (SceneKind::Level, _) => {
            let open = OpenGround::new(mesh, bounds);
            per_ray(count, stream, |r| open.sightline(r))
        }
        _ => per_ray(count, stream, |r| {
            segment(r, |r| object_sight_point(r, bounds))
        }),
    }
}

/// The segment between two independent points from `point`, redrawn in the (practically
/// impossible) case that they coincide and the segment would be invalid.
fn segment(rng: &mut SplitMix64, mut point: impl FnMut(&mut SplitMix64) -> Vec3) -> Ray {
    loop {
        let ray = Ray::segment(point(rng), point(rng));
        if ray.is_valid() {
            return ray;
        }
    }
}

/// A uniform point on the sphere of `OBJECT_SIGHT_RADIUS` half-diagonals: segments between two
/// of them may pass through the object or beside it.
fn object_sight_point(rng: &mut SplitMix64, bounds: &Aabb) -> Vec3 {
    bounds.center() + rng.unit_vector() * (OBJECT_SIGHT_RADIUS * half_diagonal(bounds))
}

/// A uniform point over the terrain, `TERRAIN_SIGHT_HEIGHT` above its surface: hills in between
/// block the view.
fn terrain_sight_point(rng: &mut SplitMix64, grid: &TerrainGrid, bounds: &Aabb) -> Vec3 {
    let x = rng.range_f32(bounds.min.x, bounds.max.x);
    let z = rng.range_f32(bounds.min.z, bounds.max.z);
    Vec3::new(x, grid.surface_height(x, z) + TERRAIN_SIGHT_HEIGHT, z)
}

/// A segment between two pedestrians in the streets; often on the same street (usually clear),
/// otherwise on any street (usually blocked by buildings, clear across parks and crossings).
fn city_sightline(rng: &mut SplitMix64, blocks: u32) -> Ray {
    let at_agent_height = |(x, z): (f32, f32)| Vec3::new(x, city::GROUND + AGENT_HEIGHT, z);
    loop {
        let first = Street::random(rng, blocks);
        let second = if rng.chance(SAME_STREET) {
            first
        } else {
            Street::random(rng, blocks)
        };
        let a = at_agent_height(first.random_point(rng));
        let b = at_agent_height(second.random_point(rng));
        let ray = Ray::segment(a, b);
        if ray.is_valid() {
            return ray;
        }
    }
}

/// Where agents can stand in a level: points `LEVEL_EYE` above its ground with nothing above
/// them (not inside a building or a crate), found with a tree over the level.
struct OpenGround {
    tree: AnyAccel,
    bounds: Aabb,
}

impl OpenGround {
    fn new(mesh: &Mesh, bounds: &Aabb) -> Self {
        let tree = AccelKind::DEFAULT
            .build(mesh.clone(), &BuildOptions::default())
            .expect("a mesh with valid bounds builds with the default options");
        Self {
            tree,
            bounds: *bounds,
        }
    }

    /// A segment from an agent to another `LEVEL_SIGHT` away in a random direction; both ends
    /// in the open and inside the level.
    fn sightline(&self, rng: &mut SplitMix64) -> Ray {
        loop {
            let a = self.open_point(rng, |r| {
                Vec2::new(
                    r.range_f32(self.bounds.min.x, self.bounds.max.x),
                    r.range_f32(self.bounds.min.z, self.bounds.max.z),
                )
            });
            let b = self.open_point(rng, |r| {
                let step = r.unit_vector_2d() * r.range_f32(LEVEL_SIGHT.0, LEVEL_SIGHT.1);
                Vec2::new(a.x, a.z) + step
            });
            let ray = Ray::segment(a, b);
            if ray.is_valid() {
                return ray;
            }
        }
    }

    /// A point `LEVEL_EYE` above the ground at a place from `place`, redrawn until it is in
    /// the open and inside the level (after `LEVEL_TRIES` draws, the last one is kept: a mesh
    /// that is roofed everywhere still gets its rays).
    fn open_point(&self, rng: &mut SplitMix64, place: impl Fn(&mut SplitMix64) -> Vec2) -> Vec3 {
        let (min, max) = (self.bounds.min, self.bounds.max);
        let mut point = Vec3::ZERO;
        for _ in 0..LEVEL_TRIES {
            let at = place(rng);
            let height = rng.range_f32(LEVEL_EYE.0, LEVEL_EYE.1);
            point = Vec3::new(at.x, level::GROUND + height, at.y);
            let inside = point.cmpge(min).all() && point.cmple(max).all();
            if inside && !self.tree.occluded(&Ray::new(point, Vec3::Y)) {
                break;
            }
        }
        point
    }
}

#[cfg(test)]
mod tests {
    use raybatch::Kernel;
    use raybatch::brute_force;

    use super::*;
    use crate::scenes::{self, Scene};

    fn small_scenes() -> Vec<Scene> {
        vec![
            scenes::bunny(),
            scenes::terrain(24),
            scenes::city(4),
            scenes::level(80),
        ]
    }

    #[test]
    fn every_set_is_deterministic_valid_and_sized() {
        for scene in small_scenes() {
            for set in RaySet::ALL {
                for count in [0, 1, 7, 300] {
                    let rays = generate(set, &scene.mesh, scene.kind, count, 5);
                    assert_eq!(rays.len(), count, "{} {set}", scene.name);
                    assert_eq!(rays, generate(set, &scene.mesh, scene.kind, count, 5));
                    for r in &rays {
                        assert_eq!(r.validate(), Ok(()), "{} {set} {r:?}", scene.name);
                    }
                }
                // Different seeds give different rays (except for the seedless camera).
                let a = generate(set, &scene.mesh, scene.kind, 10, 1);
                let b = generate(set, &scene.mesh, scene.kind, 10, 2);
                assert_eq!(a == b, set == RaySet::Camera, "{} {set}", scene.name);
            }
        }
    }

    #[test]
    fn names_round_trip() {
        for set in RaySet::ALL {
            assert_eq!(RaySet::from_name(set.name()), Some(set));
        }
        assert_eq!(RaySet::from_name("nope"), None);
    }

    #[test]
    fn origins_and_lengths_follow_the_definitions() {
        let scene = scenes::terrain(8);
        let b = scene.mesh.bounds();
        let hd = half_diagonal(&b);
        for r in generate(RaySet::Incoherent, &scene.mesh, scene.kind, 200, 3) {
            assert!(r.origin.cmpge(b.min).all() && r.origin.cmple(b.max).all());
            assert_eq!(r.tmax, f32::INFINITY);
        }
        for r in generate(RaySet::Short, &scene.mesh, scene.kind, 200, 3) {
            assert!((r.dir.length() - 1.0).abs() < 1e-5);
            assert_eq!(r.tmax, 0.02 * 2.0 * hd);
        }
        for r in generate(RaySet::OutsideIn, &scene.mesh, scene.kind, 200, 3) {
            assert!(((r.origin - b.center()).length() / hd - 1.5).abs() < 1e-3);
            // Aimed into the box: some point of the ray lies inside it.
            let to_center = (b.center() - r.origin).length();
            assert!(r.dir.dot((b.center() - r.origin) / to_center) > 0.0);
        }
    }

    #[test]
    fn cameras_are_outside_and_coherent() {
        for scene in small_scenes() {
            let b = scene.mesh.bounds();
            let rays = generate(RaySet::Camera, &scene.mesh, scene.kind, 100, 0);
            let eye = rays[0].origin;
            let inside = eye.cmpge(b.min).all() && eye.cmple(b.max).all();
            assert!(!inside, "{}: camera inside the bounds", scene.name);
            assert!(rays.iter().all(|r| r.origin == eye));
            // Neighbouring pixels of a row differ by a small angle.
            for pair in rays[..10].windows(2) {
                assert!(pair[0].dir.dot(pair[1].dir) > 0.99, "{}", scene.name);
            }
            // Most camera rays see the scene.
            let hits = rays
                .iter()
                .filter(|r| brute_force::cast_ray(&scene.mesh, r, Kernel::Watertight).is_some())
                .count();
            assert!(
                hits > 30,
                "{}: only {hits} of 100 camera rays hit",
                scene.name
            );
        }
    }

    /// The share of blocked segments among `rays`.
    fn blocked_share(mesh: &Mesh, rays: &[Ray]) -> f32 {
        let blocked = rays
            .iter()
            .filter(|r| brute_force::occluded(mesh, r, Kernel::Watertight))
            .count();
        blocked as f32 / rays.len() as f32
    }

    #[test]
    fn city_sightlines_are_at_agent_height_and_mixed() {
        let scene = scenes::city(4);
        let rays = generate(RaySet::LineOfSight, &scene.mesh, scene.kind, 200, 8);
        for r in &rays {
            assert_eq!(
                (r.origin.y, r.dir.y, r.tmax),
                (city::GROUND + AGENT_HEIGHT, 0.0, 1.0)
            );
        }
        let share = blocked_share(&scene.mesh, &rays);
        assert!((0.2..0.9).contains(&share), "{share}");
    }

    #[test]
    fn level_sightlines_are_short_open_and_mostly_blocked() {
        let scene = scenes::level(2200);
        let tree = AccelKind::DEFAULT
            .build(scene.mesh.clone(), &BuildOptions::default())
            .unwrap();
        let rays = generate(RaySet::LineOfSight, &scene.mesh, scene.kind, 2000, 8);
        for r in &rays {
            for p in [r.origin, r.at(1.0)] {
                let eye = p.y - level::GROUND;
                assert!((LEVEL_EYE.0..=LEVEL_EYE.1).contains(&eye), "{p}");
                assert!(!tree.occluded(&Ray::new(p, Vec3::Y)), "{p} is under a roof");
            }
            let run = Vec2::new(r.dir.x, r.dir.z).length();
            assert!(
                (LEVEL_SIGHT.0..=LEVEL_SIGHT.1 + 1e-3).contains(&run),
                "{run}"
            );
        }
        let share = blocked_share(&scene.mesh, &rays);
        assert!((0.9..0.99).contains(&share), "{share}");
    }

    #[test]
    fn terrain_sightlines_start_above_the_surface_and_are_mixed() {
        let scene = scenes::terrain(24);
        let grid = TerrainGrid::from_mesh(&scene.mesh).unwrap();
        let rays = generate(RaySet::LineOfSight, &scene.mesh, scene.kind, 200, 8);
        for r in &rays {
            for p in [r.origin, r.at(1.0)] {
                let above = p.y - grid.surface_height(p.x, p.z);
                assert!((above - TERRAIN_SIGHT_HEIGHT).abs() < 1e-3, "{p}");
            }
        }
        let share = blocked_share(&scene.mesh, &rays);
        assert!((0.1..0.95).contains(&share), "{share}");
    }

    #[test]
    fn degenerate_meshes_still_get_valid_rays() {
        let empty = Mesh::default();
        let point = Mesh::new(vec![Vec3::ONE], vec![[0, 0, 0]]).unwrap();
        for mesh in [&empty, &point] {
            for kind in [
                SceneKind::Object,
                SceneKind::Terrain,
                SceneKind::City,
                SceneKind::Level,
            ] {
                for set in RaySet::ALL {
                    let rays = generate(set, mesh, kind, 50, 1);
                    assert!(rays.iter().all(Ray::is_valid), "{set} {kind:?}");
                }
            }
        }
    }
}
