//! The binary file formats of `raybatch query`, all little-endian.
//!
//! - Rays: 32-byte records of 8 `f32`: `ox oy oz dx dy dz tmin tmax`.
//! - Closest hits: 16 bytes per ray: `f32 t`, `u32 triangle`, `f32 u`, `f32 v`; a miss is
//!   `t = +inf`, `triangle = u32::MAX`, `u = v = 0`.
//! - Any hits: 1 byte per ray, 1 if occluded, else 0.

use std::fmt;

use raybatch::glam::Vec3;
use raybatch::{Hit, Ray};

/// Bytes per ray record.
pub const RAY_BYTES: usize = 32;
/// Bytes per closest-hit record.
pub const HIT_BYTES: usize = 16;

/// A ray file whose length is not a whole number of records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Truncated {
    pub len: usize,
}

impl fmt::Display for Truncated {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} bytes is not a multiple of {RAY_BYTES}", self.len)
    }
}

/// Decodes a ray file. Any bit pattern is a ray; invalid rays are the queries' business.
pub fn decode_rays(bytes: &[u8]) -> Result<Vec<Ray>, Truncated> {
    if !bytes.len().is_multiple_of(RAY_BYTES) {
        return Err(Truncated { len: bytes.len() });
    }
    Ok(bytes.chunks_exact(RAY_BYTES).map(decode_ray).collect())
}

/// Encodes rays as records (the inverse of [`decode_rays`], bit for bit).
pub fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rays.len() * RAY_BYTES);
    for r in rays {
        let fields = [r.origin.to_array(), r.dir.to_array()].concat();
        for value in fields.into_iter().chain([r.tmin, r.tmax]) {
            out.extend_from_slice(&value.to_le_bytes());
        }
    }
    out
}

fn decode_ray(record: &[u8]) -> Ray {
    let f = |i: usize| {
        let word = record[4 * i..4 * i + 4].try_into().expect("4-byte slice");
        f32::from_le_bytes(word)
    };
    Ray::with_range(
        Vec3::new(f(0), f(1), f(2)),
        Vec3::new(f(3), f(4), f(5)),
        f(6),
        f(7),
    )
}

/// Encodes one record per ray (closest hits).
pub fn encode_closest(hits: &[Option<Hit>]) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * HIT_BYTES);
    for hit in hits {
        let (t, triangle, u, v) = match hit {
            Some(h) => (h.t, h.triangle, h.u, h.v),
            None => (f32::INFINITY, u32::MAX, 0.0, 0.0),
        };
        out.extend_from_slice(&t.to_le_bytes());
        out.extend_from_slice(&triangle.to_le_bytes());
        out.extend_from_slice(&u.to_le_bytes());
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Encodes one byte per ray (any hit).
pub fn encode_occluded(occluded: &[bool]) -> Vec<u8> {
    occluded.iter().map(|&o| u8::from(o)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_round_trip_and_truncation_is_reported() {
        let values: [f32; 8] = [1.0, 2.0, 3.0, 0.0, 0.0, -1.0, 0.5, f32::INFINITY];
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let rays = decode_rays(&bytes).unwrap();
        assert_eq!(encode_rays(&rays), bytes);
        assert_eq!(
            rays,
            [Ray::with_range(
                Vec3::new(1.0, 2.0, 3.0),
                -Vec3::Z,
                0.5,
                f32::INFINITY
            )]
        );
        assert_eq!(decode_rays(&bytes[..31]), Err(Truncated { len: 31 }));
        assert_eq!(decode_rays(&[]), Ok(vec![]));
    }

    #[test]
    fn misses_are_encoded_as_documented() {
        let bytes = encode_closest(&[None]);
        assert_eq!(&bytes[0..4], &f32::INFINITY.to_le_bytes());
        assert_eq!(&bytes[4..8], &[0xff; 4]);
        assert_eq!(&bytes[8..16], &[0; 8]);
        assert_eq!(encode_occluded(&[true, false]), [1, 0]);
    }
}
