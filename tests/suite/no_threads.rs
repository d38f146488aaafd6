//! When the system refuses new threads, builds, batched queries (plain, scenes), the
//! line-of-sight queue and batched audio occlusion fall back to the calling thread instead of
//! panicking (rayon's global pool would panic on first use), with the same answers.
//!
//! Thread creation is made to fail in a child process: `RUST_MIN_STACK` asks for a stack larger
//! than the address space, so every `std::thread` spawn (and so rayon's pool start) fails with
//! an I/O error. The child is this test binary, running only [`child`] on its main thread.

use std::process::Command;

use raybatch::scene::{InstanceDesc, Rigid, Scene};
use raybatch::users::{LosQueue, Materials, Occlusion, occlusion, occlusion_batch};
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
        tree.cast_ray_batch_with(&rays, &mut hits, &batch)
            .expect("lengths match");
        let mut occluded = vec![false; rays.len()];
        tree.occluded_batch_with(&rays, &mut occluded, &batch)
            .expect("lengths match");
        for (i, ray) in rays.iter().enumerate() {
            assert_eq!(hits[i], tree.cast_ray(ray), "{} ray {i}", kind.name());
            assert_eq!(occluded[i], tree.occluded(ray), "{} ray {i}", kind.name());
        }
        assert!(hits.iter().all(Option::is_some));
        let every = std::sync::Mutex::new(0usize);
        tree.for_each_hit_batch_with(&rays, &batch, &|_, _| *every.lock().unwrap() += 1);
        assert_eq!(every.into_inner().unwrap(), rays.len(), "{}", kind.name());
    }
    scene_queue_and_audio(&mesh);
    println!("child: done");
}

/// The users' layer without threads: a scene's batched queries, a line-of-sight queue's
/// flush and batched audio occlusion answer as one ray at a time does.
fn scene_queue_and_audio(mesh: &Mesh) {
    let tree = AccelKind::DEFAULT
        .build(mesh.clone(), &BuildOptions::default())
        .expect("build");
    let scene = Scene::new(vec![tree], &[InstanceDesc::new(0, Rigid::IDENTITY)]).expect("scene");
    let segments: Vec<Ray> = (0..5_000)
        .map(|i| {
            let p = glam::Vec3::new((i % 100) as f32 + 0.5, (i / 100) as f32 + 0.5, 1.0);
            Ray::segment(p, p - glam::Vec3::Z * (1 + i % 3) as f32)
        })
        .collect();
    let mut occluded = vec![false; segments.len()];
    scene
        .occluded_batch(&segments, &mut occluded)
        .expect("lengths match");
    let queue = LosQueue::with_capacity(segments.len()).expect("capacity");
    let first = queue.submit_all(&segments).expect("room");
    assert_eq!(queue.flush(&scene), Ok(segments.len()));
    let materials = Materials::uniform(&scene, 6.0).expect("one loss per triangle");
    let mut losses = vec![Occlusion::default(); segments.len()];
    occlusion_batch(&scene, &materials, &segments, u32::MAX, &mut losses).expect("lengths");
    for (k, ray) in segments.iter().enumerate() {
        assert_eq!(occluded[k], scene.occluded(ray), "scene, segment {k}");
        assert_eq!(
            queue.occluded(first.offset(k)),
            Ok(occluded[k]),
            "queue, segment {k}"
        );
        assert_eq!(
            losses[k],
            occlusion(&scene, &materials, ray, u32::MAX),
            "audio {k}"
        );
    }
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
