//! The city scene: a ground quad and a grid of blocks of box buildings, separated by streets.
//!
//! It stresses what the terrain does not: many separate closed objects, large empty spaces, big
//! differences in triangle size, and line-of-sight queries along streets, which are clear when
//! both ends see down the same street and blocked as soon as a building is in between.

use raybatch::Mesh;
use raybatch::glam::Vec3;

use super::rng::SplitMix64;

/// Width of every street, including those around the edge of the city.
pub(crate) const STREET: f32 = 20.0;
/// Side of a square block between streets.
const BLOCK: f32 = 80.0;
/// Distance between the starts of consecutive blocks.
const PITCH: f32 = BLOCK + STREET;
/// Height of the ground plane.
pub(crate) const GROUND: f32 = 0.0;
/// Buildings start this far below the ground, so their bottom faces never coincide with it (a
/// coplanar overlap would make hits depend on tie-breaking rather than geometry).
const FOUNDATION: f32 = -1.0;
/// Chance that a lot is left empty (a park or square): some long sightlines cross blocks.
const EMPTY_LOT: f32 = 0.1;
/// Chance that a building is a tower rather than an ordinary house or office block.
const TOWER: f32 = 0.05;

/// The city mesh: ground quad first (triangles 0 and 1), then 12 triangles per building.
pub(crate) fn mesh(blocks_per_side: u32, seed: u64) -> Mesh {
    let mut rng = SplitMix64::new(seed);
    let mut b = Builder::default();
    b.ground(size(blocks_per_side));
    for bz in 0..blocks_per_side {
        for bx in 0..blocks_per_side {
            b.block(&mut rng, block_origin(bx), block_origin(bz));
        }
    }
    Mesh::new(b.vertices, b.triangles).expect("a generated city is always a valid mesh")
}

/// Side of the square ground of a city with `blocks` blocks per side.
pub(crate) fn size(blocks: u32) -> f32 {
    blocks as f32 * PITCH + STREET
}

/// The smaller coordinate of block number `k` along an axis.
fn block_origin(k: u32) -> f32 {
    STREET + k as f32 * PITCH
}

/// Recovers the blocks per side from a city's bounds (its ground spans `size(blocks)`).
pub(crate) fn blocks_from_extent(extent: f32) -> u32 {
    ((extent - STREET) / PITCH).round().max(0.0) as u32
}

/// Accumulates the vertex and triangle arrays.
#[derive(Default)]
struct Builder {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl Builder {
    fn next_index(&self) -> u32 {
        u32::try_from(self.vertices.len()).expect("city too large for 32-bit indices")
    }

    /// The ground `[0, size]^2` at `GROUND`, two triangles facing up.
    fn ground(&mut self, size: f32) {
        let base = self.next_index();
        for (x, z) in [(0.0, 0.0), (size, 0.0), (0.0, size), (size, size)] {
            self.vertices.push(Vec3::new(x, GROUND, z));
        }
        let [v00, v10, v01, v11] = [base, base + 1, base + 2, base + 3];
        self.triangles.push([v00, v01, v10]);
        self.triangles.push([v10, v01, v11]);
    }

    /// One block: split into 1 to 3 lots per axis, most lots holding one building.
    fn block(&mut self, rng: &mut SplitMix64, x0: f32, z0: f32) {
        let (lots_x, lots_z) = (1 + rng.below(3) as u32, 1 + rng.below(3) as u32);
        let (lot_w, lot_d) = (BLOCK / lots_x as f32, BLOCK / lots_z as f32);
        for lz in 0..lots_z {
            for lx in 0..lots_x {
                if rng.chance(EMPTY_LOT) {
                    continue;
                }
                let lot_min = (x0 + lx as f32 * lot_w, z0 + lz as f32 * lot_d);
                self.building(rng, lot_min, (lot_w, lot_d));
            }
        }
    }

    /// A building on a lot: a random footprint (50% to 90% of the lot per axis, placed anywhere
    /// inside it) and a random height.
    fn building(&mut self, rng: &mut SplitMix64, lot_min: (f32, f32), lot: (f32, f32)) {
        let (w, d) = (
            lot.0 * rng.range_f32(0.5, 0.9),
            lot.1 * rng.range_f32(0.5, 0.9),
        );
        let x = lot_min.0 + rng.range_f32(0.0, lot.0 - w);
        let z = lot_min.1 + rng.range_f32(0.0, lot.1 - d);
        let h = if rng.chance(TOWER) {
            rng.range_f32(80.0, 250.0)
        } else {
            rng.range_f32(6.0, 45.0)
        };
        self.closed_box(
            Vec3::new(x, FOUNDATION, z),
            Vec3::new(x + w, GROUND + h, z + d),
        );
    }

    /// A closed box: 8 shared vertices, 12 triangles wound counter-clockwise seen from outside.
    fn closed_box(&mut self, min: Vec3, max: Vec3) {
        let base = self.next_index();
        // Corner `c` takes max.x if bit 0 is set, max.y for bit 1, max.z for bit 2.
        for c in 0..8u32 {
            let pick = |bit: u32, lo: f32, hi: f32| if c & bit != 0 { hi } else { lo };
            self.vertices.push(Vec3::new(
                pick(1, min.x, max.x),
                pick(2, min.y, max.y),
                pick(4, min.z, max.z),
            ));
        }
        for [a, b, c, d] in BOX_FACES {
            self.triangles.push([base + a, base + b, base + c]);
            self.triangles.push([base + a, base + c, base + d]);
        }
    }
}

/// The six faces of a box as corner quads, counter-clockwise seen from outside:
/// -x, +x, -y, +y, -z, +z.
const BOX_FACES: [[u32; 4]; 6] = [
    [0, 4, 6, 2],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 2, 3, 1],
    [4, 5, 7, 6],
];

/// One street of a city: along `x` (constant `z` band) or along `z`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Street {
    along_x: bool,
    /// The centre line's coordinate across the street.
    center: f32,
    /// The street's length (the city's side).
    length: f32,
}

impl Street {
    /// A random street of a city with `blocks` blocks per side (edge streets included).
    pub(crate) fn random(rng: &mut SplitMix64, blocks: u32) -> Self {
        let k = rng.below(u64::from(blocks) + 1) as f32;
        Self {
            along_x: rng.chance(0.5),
            center: k * PITCH + 0.5 * STREET,
            length: size(blocks),
        }
    }

    /// A random `(x, z)` on the street, kept a metre away from its edges.
    pub(crate) fn random_point(&self, rng: &mut SplitMix64) -> (f32, f32) {
        let half = 0.5 * STREET - 1.0;
        let across = self.center + rng.range_f32(-half, half);
        let along = rng.range_f32(0.0, self.length);
        if self.along_x {
            (along, across)
        } else {
            (across, along)
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;

    /// True if coordinate `c` is strictly inside a street band (by more than rounding).
    fn in_street(c: f32) -> bool {
        (0.01..STREET - 0.01).contains(&(c % PITCH))
    }

    #[test]
    fn same_seed_same_city() {
        assert_eq!(mesh(6, 11), mesh(6, 11));
        assert_ne!(mesh(6, 11), mesh(6, 12));
    }

    #[test]
    fn counts_are_ground_plus_twelve_per_box() {
        let m = mesh(10, 1);
        let buildings = (m.triangle_count() - 2) / 12;
        assert_eq!(m.triangle_count(), 2 + 12 * buildings);
        assert_eq!(m.vertices().len(), 4 + 8 * buildings);
        // 100 blocks of 1 to 9 lots, 90% built: far from the extremes.
        assert!((150..=800).contains(&buildings), "{buildings}");
        assert_eq!(mesh(0, 1).triangle_count(), 2, "no blocks: just the ground");
    }

    #[test]
    fn boxes_are_closed_and_wound_outwards() {
        let m = mesh(5, 3);
        let tris = &m.triangles()[2..];
        for (k, b) in tris.chunks(12).enumerate() {
            // Every directed edge appears once and its reverse once: closed and consistently wound.
            let mut edges = HashMap::new();
            for t in b {
                for e in 0..3 {
                    *edges.entry((t[e], t[(e + 1) % 3])).or_insert(0) += 1;
                }
            }
            assert_eq!(edges.len(), 36, "box {k}");
            for (&(a, c), &n) in &edges {
                assert_eq!(
                    (n, edges.get(&(c, a))),
                    (1, Some(&1)),
                    "box {k} edge {a}-{c}"
                );
            }
            let corners: Vec<Vec3> = b
                .iter()
                .flatten()
                .map(|&i| m.vertices()[i as usize])
                .collect();
            let center = corners.iter().sum::<Vec3>() / corners.len() as f32;
            for t in b {
                let [p, q, r] = t.map(|i| m.vertices()[i as usize]);
                let outward = (q - p).cross(r - p).dot((p + q + r) / 3.0 - center);
                assert!(outward > 0.0, "box {k} triangle {t:?}");
            }
        }
    }

    #[test]
    fn buildings_stay_inside_their_blocks() {
        let blocks = 8;
        let m = mesh(blocks, 5);
        let b = m.bounds();
        assert_eq!((b.min.x, b.min.z), (0.0, 0.0));
        assert_eq!((b.max.x, b.max.z), (size(blocks), size(blocks)));
        assert_eq!(b.min.y, FOUNDATION);
        assert!(b.max.y > GROUND + 6.0 && b.max.y <= GROUND + 250.0);
        assert_eq!(blocks_from_extent(b.extent().x), blocks);
        // No building vertex lies inside a street (the tolerance absorbs rounding at the kerb).
        for v in &m.vertices()[4..] {
            assert!(!in_street(v.x) && !in_street(v.z), "{v}");
        }
    }

    #[test]
    fn street_points_are_in_streets() {
        let mut rng = SplitMix64::new(2);
        for _ in 0..1000 {
            let (x, z) = Street::random(&mut rng, 4).random_point(&mut rng);
            assert!(in_street(x) || in_street(z), "({x}, {z})");
            assert!((0.0..=size(4)).contains(&x) && (0.0..=size(4)).contains(&z));
        }
    }
}
