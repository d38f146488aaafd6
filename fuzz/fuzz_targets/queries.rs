//! Mesh + ray queries on any bytes: a small mesh (vertices on a coarse grid, so that edges,
//! vertices, ties and degenerate triangles are common) and rays (origins and directions on the
//! same grid, or raw bit patterns: NaN, infinities, huge and tiny values), every structure of
//! the catalog: no panic, no hang, and the closest hit (bit for bit, tie rule included), the
//! any-hit answer and the batched answers equal brute force.
#![no_main]

use std::sync::Arc;

use libfuzzer_sys::fuzz_target;
use raybatch::glam::Vec3;
use raybatch::brute_force;
use raybatch::{AccelKind, BuildOptions, Kernel, Mesh, Ray};

/// Reads the fuzzer's bytes as the mesh and rays.
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn byte(&mut self) -> Option<u8> {
        let (&b, rest) = self.0.split_first()?;
        self.0 = rest;
        Some(b)
    }

    /// A coordinate on a grid of step 0.25 in [-4, 4).
    fn grid(&mut self) -> Option<f32> {
        Some(f32::from(self.byte()? as i8 >> 3) * 0.25)
    }

    fn raw(&mut self) -> Option<f32> {
        let bytes = [self.byte()?, self.byte()?, self.byte()?, self.byte()?];
        Some(f32::from_le_bytes(bytes))
    }

    fn point(&mut self, raw: bool) -> Option<Vec3> {
        if raw {
            Some(Vec3::new(self.raw()?, self.raw()?, self.raw()?))
        } else {
            Some(Vec3::new(self.grid()?, self.grid()?, self.grid()?))
        }
    }
}

fn mesh(bytes: &mut Bytes) -> Option<Mesh> {
    let vertex_count = usize::from(bytes.byte()? % 16) + 3;
    let triangle_count = usize::from(bytes.byte()? % 24) + 1;
    let vertices: Option<Vec<Vec3>> = (0..vertex_count).map(|_| bytes.point(false)).collect();
    let index = |b: u8| u32::from(b) % vertex_count as u32;
    let triangles: Option<Vec<[u32; 3]>> = (0..triangle_count)
        .map(|_| {
            Some([
                index(bytes.byte()?),
                index(bytes.byte()?),
                index(bytes.byte()?),
            ])
        })
        .collect();
    Mesh::new(vertices?, triangles?).ok()
}

fn ray(bytes: &mut Bytes) -> Option<Ray> {
    let flags = bytes.byte()?;
    let origin = bytes.point(flags & 1 != 0)?;
    let dir = bytes.point(flags & 2 != 0)?;
    let (tmin, tmax) = match flags >> 2 & 3 {
        0 => (0.0, f32::INFINITY),
        1 => (bytes.grid()?.abs(), bytes.grid()?.abs() * 4.0),
        _ => (bytes.raw()?, bytes.raw()?),
    };
    Some(Ray::with_range(origin, dir, tmin, tmax))
}

fuzz_target!(|data: &[u8]| {
    let mut bytes = Bytes(data);
    let Some(mesh) = mesh(&mut bytes) else { return };
    let rays: Vec<Ray> = std::iter::from_fn(|| ray(&mut bytes)).take(64).collect();
    let mesh = Arc::new(mesh);
    let bits = |h: Option<raybatch::Hit>| {
        h.map(|h| (h.t.to_bits(), h.triangle, h.u.to_bits(), h.v.to_bits()))
    };
    for kind in AccelKind::ALL {
        let options = BuildOptions::default().with_leaf_size(1 + data.len() as u32 % 4);
        let tree = kind
            .build(mesh.clone(), &options)
            .expect("small meshes always build");
        for kernel in Kernel::ALL {
            let mut batched = vec![None; rays.len()];
            let batch = raybatch::BatchOptions::default()
                .with_kernel(kernel)
                .with_parallel(false);
            tree.cast_ray_batch_with(&rays, &mut batched, &batch)
                .expect("one slot per ray");
            let mut occluded = vec![false; rays.len()];
            tree.occluded_batch_with(&rays, &mut occluded, &batch)
                .expect("one slot per ray");
            for (i, ray) in rays.iter().enumerate() {
                let expected = brute_force::cast_ray(&mesh, ray, kernel);
                let name = kind.name();
                assert_eq!(
                    bits(tree.cast_ray_with(ray, kernel)),
                    bits(expected),
                    "{name} {ray:?}"
                );
                assert_eq!(bits(batched[i]), bits(expected), "{name} batched {ray:?}");
                let (visited, _) = tree.cast_ray_visits(ray, kernel);
                assert_eq!(bits(visited), bits(expected), "{name} visits {ray:?}");
                let any = brute_force::occluded(&mesh, ray, kernel);
                assert_eq!(tree.occluded_with(ray, kernel), any, "{name} any {ray:?}");
                assert_eq!(occluded[i], any, "{name} batched any {ray:?}");
            }
        }
    }
});
