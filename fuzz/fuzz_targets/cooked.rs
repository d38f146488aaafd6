//! Cooked files on any bytes: loading never panics, whatever the header or payload. The first
//! byte picks how the rest is read: odd, as a whole file (header paths: magic, version,
//! lengths, checksum); even, as a payload under a right header for kind `byte / 2` (or a
//! scene), so that the structure checks behind the checksum are what gets fuzzed. What loads
//! cooks back to the same bytes and answers rays as brute force does over its own mesh.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raybatch::glam::Vec3;
use raybatch::{AnyAccel, Kernel, Ray, RayQueries, Scene, brute_force};

/// The file of `payload` under a right header for content `content`.
fn file(content: u32, payload: &[u8]) -> Vec<u8> {
    let mut out = b"RAYBATCH".to_vec();
    out.extend_from_slice(&raybatch::cook::FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&content.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// Rays through the structure's mesh: from the corners of its box towards its vertices.
fn check_answers(tree: &AnyAccel) {
    let Some(mesh) = tree.mesh() else { return };
    let bounds = tree.mesh_bounds();
    for (k, &target) in mesh.vertices().iter().take(16).enumerate() {
        let origin = if k % 2 == 0 { bounds.min } else { bounds.max } - Vec3::splat(1.0);
        let ray = Ray::new(origin, target - origin + Vec3::new(1e-3, 2e-3, 0.0));
        assert_eq!(
            tree.cast_ray(&ray),
            brute_force::cast_ray(mesh, &ray, Kernel::Watertight)
        );
        assert_eq!(
            tree.occluded(&ray),
            brute_force::occluded(mesh, &ray, Kernel::Watertight)
        );
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let bytes = match mode % 2 {
        1 => rest.to_vec(),
        _ if mode == 0 => file(0x100, rest),
        _ => file(u32::from(mode / 2), rest),
    };
    if let Ok(tree) = AnyAccel::from_cooked(&bytes) {
        assert_eq!(tree.to_cooked().expect("a loaded kind cooks"), bytes);
        check_answers(&tree);
    }
    if let Ok(scene) = Scene::from_cooked(&bytes) {
        assert_eq!(scene.to_cooked().expect("a loaded scene cooks"), bytes);
    }
});
