//! The ray-file reader on any bytes: never panics; a whole number of records reads back, and
//! writes back, bit for bit, whether the length is known up front or the file is streamed;
//! anything else is `Truncated`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raybatch_tools::formats::{RAY_BYTES, RayFileError, decode_rays, encode_rays, read_rays};

fuzz_target!(|data: &[u8]| {
    let known = decode_rays(data);
    let streamed = read_rays(data, None);
    match (&known, &streamed) {
        (Ok(a), Ok(b)) => {
            assert_eq!(a.len(), data.len() / RAY_BYTES);
            let bits = |rays: &[raybatch::Ray]| encode_rays(rays);
            assert_eq!(bits(a), data);
            assert_eq!(bits(b), data);
        }
        (Err(RayFileError::Truncated { len: a }), Err(RayFileError::Truncated { len: b })) => {
            assert_eq!((*a, *b), (data.len() as u64, data.len() as u64));
            assert!(data.len() % RAY_BYTES != 0);
        }
        other => panic!("unexpected {other:?}"),
    }
});
