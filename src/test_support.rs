//! Helpers shared by the unit tests: the seeded random generator, the bunny, random rays.

use glam::Vec3;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

use crate::geom::Ray;
use crate::mesh::Mesh;

/// The unit tests' seeded generator: rand's `StdRng`, the generator the integration tests use
/// too (`tests/suite/common/rng.rs`), so every run draws the same numbers.
pub(crate) struct TestRng(StdRng);

impl TestRng {
    pub(crate) fn new(seed: u64) -> Self {
        Self(StdRng::seed_from_u64(seed))
    }

    /// Uniform in `[lo, hi)`.
    pub(crate) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        self.0.random_range(lo..hi)
    }

    /// Uniform in the cube `[-r, r)^3`.
    pub(crate) fn vec3(&mut self, r: f32) -> Vec3 {
        Vec3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
    }
}

/// The Stanford bunny from the workspace's `data/` folder.
pub(crate) fn bunny() -> Mesh {
    Mesh::from_obj_str(include_str!("../data/stanford-bunny.obj")).expect("valid OBJ")
}

/// `n` incoherent rays: origins in the mesh's bounds (grown by a quarter), random directions.
pub(crate) fn random_rays(mesh: &Mesh, n: usize, seed: u64) -> Vec<Ray> {
    let bounds = mesh.bounds();
    let (center, half) = (bounds.center(), bounds.extent() * 0.625);
    let mut rng = TestRng::new(seed);
    (0..n)
        .map(|_| {
            let origin = center + half * rng.vec3(1.0);
            Ray::new(origin, rng.vec3(1.0))
        })
        .collect()
}
