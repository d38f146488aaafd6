//! When the system refuses new threads, builds and batched queries fall back to the calling
//! thread instead of panicking (rayon's global pool would panic on first use).
//!
//! Thread creation is made to fail in a child process: `RUST_MIN_STACK` asks for a stack larger
//! than the address space, so every `std::thread` spawn (and so rayon's pool start) fails with
//! an I/O error. The child is this test binary, running only [`child`] on its main thread.

use std::process::Command;

use raybatch::{AccelKind, BatchOptions, BuildOptions, Mesh, Ray};
use raybatch::{BatchQueries, RayQueries};

/// Set in the child process.
const CHILD_ENV: &str = "RAYBATCH_NO_THREADS_CHILD";

#[test]
fn builds_and_batches_without_threads() {
    let exe = std::env::current_exe().expect("the test binary's path");
    let output = Command::new(exe)
        .args([
            "--exact",
            "no_threads::child",
            "--test-threads=1",
            "--nocapture",
        ])
        .env(CHILD_ENV, "1")
        .env("RUST_MIN_STACK", (1u64 << 50).to_string())
        .output()
        .expect("the test binary runs");
    let text = String::from_utf8_lossy(&output.stdout).into_owned()
        + &String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "child failed:\n{text}");
    assert!(text.contains("child: done"), "child did not run:\n{text}");
}

/// The child's work: only runs when [`CHILD_ENV`] is set.
#[test]
fn child() {
    if std::env::var_os(CHILD_ENV).is_none() {
        return;
    }
    assert!(
        std::thread::Builder::new().spawn(|| ()).is_err(),
        "this system started a thread despite RUST_MIN_STACK; the test cannot check the fallback"
    );
    let mesh = grid_mesh(200);
    for kind in AccelKind::ALL {
        let options = BuildOptions::default().with_parallel(true);
        let tree = kind.build(mesh.clone(), &options).expect("build");
        let rays: Vec<Ray> = (0..10_000)
            .map(|i| {
                let x = (i % 100) as f32 * 2.0 + 0.5;
                let y = (i / 100) as f32 * 2.0 + 0.5;
                Ray::new(
                    glam::Vec3::new(x, y, 1.0),
                    glam::Vec3::new(0.01, 0.02, -1.0),
                )
            })
            .collect();
        let batch = BatchOptions::default().with_parallel(true);
        let mut hits = vec![None; rays.len()];
        tree.cast_rays_with(&rays, &mut hits, &batch)
            .expect("lengths match");
        let mut occluded = vec![false; rays.len()];
        tree.occluded_batch_with(&rays, &mut occluded, &batch)
            .expect("lengths match");
        for (i, ray) in rays.iter().enumerate() {
            assert_eq!(hits[i], tree.cast_ray(ray), "{} ray {i}", kind.name());
            assert_eq!(occluded[i], tree.occluded(ray), "{} ray {i}", kind.name());
        }
        assert!(hits.iter().all(Option::is_some));
    }
    println!("child: done");
}

/// A flat `n` x `n` grid of unit squares in the plane z = 0, two triangles each.
fn grid_mesh(n: u32) -> Mesh {
    let mut vertices = Vec::new();
    for y in 0..=n {
        for x in 0..=n {
            vertices.push(glam::Vec3::new(x as f32, y as f32, 0.0));
        }
    }
    let at = |x: u32, y: u32| y * (n + 1) + x;
    let mut triangles = Vec::new();
    for y in 0..n {
        for x in 0..n {
            triangles.push([at(x, y), at(x + 1, y), at(x + 1, y + 1)]);
            triangles.push([at(x, y), at(x + 1, y + 1), at(x, y + 1)]);
        }
    }
    Mesh::new(vertices, triangles).expect("valid grid")
}
