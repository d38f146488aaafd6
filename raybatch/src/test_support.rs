//! Helpers shared by the unit tests: one seeded random generator, the bunny, random rays.

use glam::Vec3;

use crate::geom::Ray;
use crate::mesh::Mesh;

/// SplitMix64: a small seeded generator, so unit tests need no dependency and every run draws
/// the same numbers.
pub(crate) struct TestRng(u64);

impl TestRng {
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub(crate) fn range(&mut self, lo: f32, hi: f32) -> f32 {
        let unit = (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32;
        lo + (hi - lo) * unit
    }

    /// Uniform in the cube `[-r, r)^3`.
    pub(crate) fn vec3(&mut self, r: f32) -> Vec3 {
        Vec3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
    }
}

/// The Stanford bunny from the workspace's `data/` folder.
pub(crate) fn bunny() -> Mesh {
    Mesh::from_obj_str(include_str!("../../data/stanford-bunny.obj")).expect("valid OBJ")
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
