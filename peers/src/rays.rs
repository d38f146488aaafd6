//! The ray sets every library is run on: raybatch's own benchmark sets
//! ([`raybatch_tools::scenes::rays::generate`]), so peers and `raybatch bench` shoot the same rays.
//!
//! [`ray_sets`] is the one entry point: it returns named sets of `raybatch::Ray`s, which each
//! library then converts to its own ray type outside the timed loop.

use raybatch::Mesh;
use raybatch::Ray;
use raybatch_tools::scenes::{self, SceneKind};

pub use raybatch_tools::scenes::RaySet as SetKind;

/// The sets compared by default.
pub const DEFAULT_SETS: [SetKind; 3] = [
    SetKind::Incoherent,
    SetKind::OutsideIn,
    SetKind::LineOfSight,
];

/// One named batch of rays.
pub struct RaySet {
    pub kind: SetKind,
    /// What the rays are, for the report.
    pub description: &'static str,
    pub rays: Vec<Ray>,
    /// Also time any-hit (occlusion) queries on this set.
    pub any_hit: bool,
}

impl RaySet {
    pub fn name(&self) -> &'static str {
        self.kind.name()
    }
}

/// What each set is on a scene of kind `scene`: for a mesh treated as a single object
/// (`SceneKind::Object`), in full; on a terrain or a city, `raybatch bench`'s sets for it (its
/// line-of-sight set, for instance, is sightlines between walkers in a city's streets).
pub fn describe(kind: SetKind, scene: SceneKind) -> &'static str {
    if scene != SceneKind::Object {
        return "the `raybatch bench` set of this name for the scene";
    }
    match kind {
        SetKind::Incoherent => {
            "origins uniform in the mesh bounds, directions uniform on the unit sphere, \
             t in [0, inf)"
        }
        SetKind::OutsideIn => {
            "from a sphere of 1.5 half-diagonals around the bounds towards uniform points \
             inside them, unit directions, t in [0, inf)"
        }
        SetKind::Camera => "primary rays of a pinhole camera looking at the mesh, t in [0, inf)",
        SetKind::Short => "like incoherent, but only 2% of the bounds diagonal long",
        SetKind::LineOfSight => {
            "segments between uniform points on a sphere of 1.2 half-diagonals around the \
             bounds (t in [0, 1], direction = end - start)"
        }
    }
}

/// `count` rays of each of `sets` for `mesh`, a scene of kind `scene` (an OBJ file is treated
/// as a single object), reproducible from `seed`. Line-of-sight sets are also used for any-hit
/// queries.
pub fn ray_sets(
    (mesh, scene): (&Mesh, SceneKind),
    sets: &[SetKind],
    count: usize,
    seed: u64,
) -> Vec<RaySet> {
    sets.iter()
        .map(|&kind| RaySet {
            kind,
            description: describe(kind, scene),
            rays: scenes::generate(kind, mesh, scene, count, seed),
            any_hit: kind == SetKind::LineOfSight,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use raybatch::glam::Vec3;

    #[test]
    fn sets_are_deterministic_and_valid() {
        let mesh = Mesh::new(
            vec![
                Vec3::new(-1.0, 0.0, 2.0),
                Vec3::new(3.0, 0.0, 2.0),
                Vec3::new(0.0, 5.0, 4.0),
            ],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let object = (&mesh, SceneKind::Object);
        let a = ray_sets(object, &DEFAULT_SETS, 500, 7);
        let b = ray_sets(object, &DEFAULT_SETS, 500, 7);
        assert_eq!(a.len(), 3);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.rays, y.rays);
            assert_eq!(x.rays.len(), 500);
            assert!(x.rays.iter().all(Ray::is_valid));
        }
        assert!(a[2].any_hit && !a[0].any_hit);
        assert!(a[2].rays.iter().all(|r| r.tmin == 0.0 && r.tmax == 1.0));
    }
}
