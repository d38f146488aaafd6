//! The binary file formats of `raybatch query` and `raybatch rays`, all little-endian.
//!
//! - Rays: 32-byte records of 8 `f32`: `ox oy oz dx dy dz tmin tmax`.
//! - Closest hits: 16 bytes per ray: `f32 t`, `u32 triangle`, `f32 u`, `f32 v`; a miss is
//!   `t = +inf`, `triangle = u32::MAX`, `u = v = 0`.
//! - Any hits: 1 byte per ray, 1 if occluded, else 0.
//!
//! Reading and writing stream through fixed-size buffers: a ray file is never held in memory
//! beside its rays (reading it whole would take about three times the file's size).

use std::fmt;
use std::io::{self, Read, Write};

use raybatch::glam::Vec3;
use raybatch::{Hit, Ray};

/// Bytes per ray record.
pub const RAY_BYTES: usize = 32;
/// Bytes per closest-hit record.
pub const HIT_BYTES: usize = 16;
/// Records per read or write: 64 KiB at a time.
const CHUNK_RECORDS: usize = 2048;

/// Why a ray file could not be read.
#[derive(Debug)]
pub enum RayFileError {
    /// The length is not a whole number of records (`len` bytes were read).
    Truncated {
        /// Bytes read.
        len: u64,
    },
    /// There is not enough memory for the rays the file holds.
    TooLarge {
        /// Rays in the file.
        rays: u64,
    },
    /// Reading failed.
    Io(io::Error),
}

impl fmt::Display for RayFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RayFileError::Truncated { len } => {
                write!(f, "truncated: {len} bytes is not a multiple of {RAY_BYTES}")
            }
            RayFileError::TooLarge { rays } => {
                write!(f, "{rays} rays do not fit in memory")
            }
            RayFileError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for RayFileError {}

impl From<io::Error> for RayFileError {
    fn from(e: io::Error) -> Self {
        RayFileError::Io(e)
    }
}

/// Reads a ray file from `reader`, whose length is `expected` bytes if known (room for its
/// rays is reserved at once, and a length that is not a whole number of records fails before
/// anything is read). Any bit pattern is a ray; invalid rays are the queries' business.
pub fn read_rays(mut reader: impl Read, expected: Option<u64>) -> Result<Vec<Ray>, RayFileError> {
    let mut rays = Vec::new();
    if let Some(len) = expected {
        if !len.is_multiple_of(RAY_BYTES as u64) {
            return Err(RayFileError::Truncated { len });
        }
        let count = len / RAY_BYTES as u64;
        usize::try_from(count)
            .ok()
            .and_then(|n| rays.try_reserve_exact(n).ok())
            .ok_or(RayFileError::TooLarge { rays: count })?;
    }
    let mut buffer = vec![0u8; CHUNK_RECORDS * RAY_BYTES];
    let (mut filled, mut total) = (0, 0u64);
    loop {
        let n = match reader.read(&mut buffer[filled..]) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e.into()),
        };
        (filled, total) = (filled + n, total + n as u64);
        let whole = filled - filled % RAY_BYTES;
        rays.extend(buffer[..whole].chunks_exact(RAY_BYTES).map(decode_ray));
        buffer.copy_within(whole..filled, 0);
        filled -= whole;
    }
    if filled != 0 {
        return Err(RayFileError::Truncated { len: total });
    }
    Ok(rays)
}

/// Decodes a ray file held in memory ([`read_rays`] on a slice).
pub fn decode_rays(bytes: &[u8]) -> Result<Vec<Ray>, RayFileError> {
    read_rays(bytes, Some(bytes.len() as u64))
}

/// Writes rays as records (the inverse of [`read_rays`], bit for bit).
pub fn write_rays(out: &mut dyn Write, rays: &[Ray]) -> io::Result<()> {
    write_records(out, rays, |r, bytes| {
        let fields = [r.origin.to_array(), r.dir.to_array()].concat();
        for value in fields.into_iter().chain([r.tmin, r.tmax]) {
            bytes.extend_from_slice(&value.to_le_bytes());
        }
    })
}

/// Encodes rays as records in memory ([`write_rays`] into a `Vec`).
pub fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rays.len() * RAY_BYTES);
    write_rays(&mut out, rays).expect("writing to a Vec cannot fail");
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

/// Writes one record per ray (closest hits).
pub fn write_closest(out: &mut dyn Write, hits: &[Option<Hit>]) -> io::Result<()> {
    write_records(out, hits, |hit, bytes| {
        let (t, triangle, u, v) = match hit {
            Some(h) => (h.t, h.triangle, h.u, h.v),
            None => (f32::INFINITY, u32::MAX, 0.0, 0.0),
        };
        bytes.extend_from_slice(&t.to_le_bytes());
        bytes.extend_from_slice(&triangle.to_le_bytes());
        bytes.extend_from_slice(&u.to_le_bytes());
        bytes.extend_from_slice(&v.to_le_bytes());
    })
}

/// Writes one byte per ray (any hit).
pub fn write_occluded(out: &mut dyn Write, occluded: &[bool]) -> io::Result<()> {
    write_records(out, occluded, |&o, bytes| bytes.push(u8::from(o)))
}

/// Encodes `items` with `encode` and writes them [`CHUNK_RECORDS`] at a time.
fn write_records<T>(
    out: &mut dyn Write,
    items: &[T],
    encode: impl Fn(&T, &mut Vec<u8>),
) -> io::Result<()> {
    let mut bytes = Vec::with_capacity(CHUNK_RECORDS * RAY_BYTES);
    for chunk in items.chunks(CHUNK_RECORDS) {
        bytes.clear();
        chunk.iter().for_each(|item| encode(item, &mut bytes));
        out.write_all(&bytes)?;
    }
    Ok(())
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
        assert!(matches!(
            decode_rays(&bytes[..31]),
            Err(RayFileError::Truncated { len: 31 })
        ));
        // Without a known length, the truncation shows at the end.
        assert!(matches!(
            read_rays(&bytes[..31], None),
            Err(RayFileError::Truncated { len: 31 })
        ));
        assert!(decode_rays(&[]).unwrap().is_empty());
    }

    /// A reader handing out a few bytes at a time, across record boundaries.
    struct Trickle<'a>(&'a [u8], usize);

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            self.1 = self.1 % 7 + 3;
            let n = self.1.min(buf.len()).min(self.0.len());
            buf[..n].copy_from_slice(&self.0[..n]);
            self.0 = &self.0[n..];
            Ok(n)
        }
    }

    #[test]
    fn streamed_reads_equal_whole_reads_across_chunks() {
        let rays: Vec<Ray> = (0..CHUNK_RECORDS * 2 + 5)
            .map(|i| Ray::new(Vec3::splat(i as f32), Vec3::new(1.0, -(i as f32), 0.5)))
            .collect();
        let bytes = encode_rays(&rays);
        assert_eq!(read_rays(Trickle(&bytes, 0), None).unwrap(), rays);
        assert_eq!(
            read_rays(&bytes[..], Some(bytes.len() as u64)).unwrap(),
            rays
        );
        assert!(matches!(
            read_rays(&bytes[..], Some(u64::MAX - 31)),
            Err(RayFileError::TooLarge { .. })
        ));
    }

    #[test]
    fn misses_are_encoded_as_documented() {
        let mut bytes = Vec::new();
        write_closest(&mut bytes, &[None]).unwrap();
        assert_eq!(&bytes[0..4], &f32::INFINITY.to_le_bytes());
        assert_eq!(&bytes[4..8], &[0xff; 4]);
        assert_eq!(&bytes[8..16], &[0; 8]);
        let mut bytes = Vec::new();
        write_occluded(&mut bytes, &[true, false]).unwrap();
        assert_eq!(bytes, [1, 0]);
    }
}
