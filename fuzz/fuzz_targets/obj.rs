//! The OBJ loader on any bytes: never panics; what it accepts is a valid mesh whose
//! triangles index its vertices; text and bytes parse alike.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raybatch::Mesh;
use raybatch::mesh::obj::{parse_obj, parse_obj_bytes};

fuzz_target!(|data: &[u8]| {
    let parsed = parse_obj_bytes(data);
    if let Ok((vertices, triangles)) = &parsed {
        assert!(
            triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < vertices.len())
        );
        assert!(vertices.iter().all(|v| v.is_finite()));
    }
    if let Ok(text) = std::str::from_utf8(data) {
        assert_eq!(parse_obj(text), parsed);
    }
    if let Ok(mesh) = Mesh::from_obj_bytes(data) {
        let (vertices, triangles) = parsed.expect("the mesh parsed");
        assert_eq!(mesh.vertices(), &vertices[..]);
        assert_eq!(mesh.triangles(), &triangles[..]);
    }
});
