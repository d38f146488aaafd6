//! End-to-end tests of the `raybatch` binary: `query` output against the brute-force reference,
//! the batched engine and thread pools against the per-ray engine (byte for byte), its JSON
//! statistics line, its handling of bad input (non-zero exit, no output file), and a tiny
//! `bench` run.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

use raybatch::brute_force;
use raybatch::glam::Vec3;
use raybatch::{Kernel, Mesh, Ray};

/// A quad at z = 1 written as one polygon (triangles 0 and 1), a triangle at z = 2 over part of
/// it (triangle 2), and a degenerate triangle (3), which is never hit.
const OBJ: &str = "\
# test mesh
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
v 0.2 0.2 2
v 0.9 0.3 2
v 0.4 0.8 2
f 1 2 3 4
f 5/1 6/2 7/3
f 1 1 2
";

/// A fresh, empty directory under the system temp dir, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(test: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let name = format!("raybatch-cli-{}-{test}-{n}", std::process::id());
        let dir = std::env::temp_dir().join(name);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create temp dir");
        Self(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// The names of the files in the directory, sorted.
    fn files(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .expect("list temp dir")
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Upward rays on a grid over and around the mesh (some through shared edges and vertices),
/// slanted and downward rays, a segment that stops between the layers, and invalid rays.
fn test_rays() -> Vec<Ray> {
    let mut rays = Vec::new();
    for i in 0..=12 {
        for j in 0..=12 {
            let (x, y) = (-0.1 + 0.1 * i as f32, -0.1 + 0.1 * j as f32);
            rays.push(Ray::new(Vec3::new(x, y, 0.0), Vec3::Z));
            rays.push(Ray::new(Vec3::new(x, y, 3.0), Vec3::new(0.1, -0.2, -1.0)));
        }
    }
    rays.push(Ray::with_range(Vec3::new(0.5, 0.5, 0.0), Vec3::Z, 0.0, 1.5));
    rays.push(Ray::with_range(Vec3::new(0.5, 0.5, 0.0), Vec3::Z, 1.5, 9.0));
    rays.push(Ray::new(Vec3::new(f32::NAN, 0.5, 0.0), Vec3::Z));
    rays.push(Ray::new(Vec3::new(0.5, 0.5, 0.0), Vec3::ZERO));
    rays.push(Ray::with_range(Vec3::new(0.5, 0.5, 0.0), Vec3::Z, 2.0, 1.0));
    rays
}

fn encode_rays(rays: &[Ray]) -> Vec<u8> {
    rays.iter()
        .flat_map(|r| {
            [
                r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax,
            ]
        })
        .flat_map(f32::to_le_bytes)
        .collect()
}

/// Writes the test mesh and rays into `dir`; returns their paths.
fn write_inputs(dir: &TempDir, rays: &[Ray]) -> (PathBuf, PathBuf) {
    let (mesh, ray_file) = (dir.path("mesh.obj"), dir.path("rays.bin"));
    std::fs::write(&mesh, OBJ).unwrap();
    std::fs::write(&ray_file, encode_rays(rays)).unwrap();
    (mesh, ray_file)
}

fn raybatch(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_raybatch"))
        .args(args)
        .output()
        .expect("run raybatch")
}

fn query(mesh: &Path, rays: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "query",
        "--mesh",
        mesh.to_str().unwrap(),
        "--rays",
        rays.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    raybatch(&args)
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// The integer value of `"key":N` in a one-line JSON object.
fn json_int(line: &str, key: &str) -> Option<u64> {
    let start = line.find(&format!("\"{key}\":"))? + key.len() + 3;
    let digits: String = line[start..]
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits.parse().ok()
}

/// Checks the stderr of a successful query: exactly one JSON line with the expected counts.
fn check_json(output: &Output, rays: usize, hits: usize) {
    let err = stderr(output);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "stderr: {err}");
    let line = lines[0];
    assert!(line.starts_with('{') && line.ends_with('}'), "{line}");
    for key in [
        "rays",
        "build_ms",
        "query_ms",
        "mrays_per_s",
        "tree",
        "kind",
        "hits",
    ] {
        assert!(line.contains(&format!("\"{key}\":")), "no {key} in {line}");
    }
    assert_eq!(json_int(line, "rays"), Some(rays as u64), "{line}");
    assert_eq!(json_int(line, "hits"), Some(hits as u64), "{line}");
    // The build's peak holds at least the structure it returns.
    let tree_bytes = json_int(line, "tree_bytes").expect("tree_bytes");
    let peak = json_int(line, "build_peak_bytes").expect("build_peak_bytes");
    assert!(peak >= tree_bytes, "{line}");
}

/// The string value of `"key":"value"` in a one-line JSON object (no escapes).
fn json_str<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let start = line.find(&format!("\"{key}\":\""))? + key.len() + 4;
    let len = line[start..].find('"')?;
    Some(&line[start..start + len])
}

fn f32_at(bytes: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

#[test]
fn closest_hits_match_brute_force() {
    let dir = TempDir::new("closest");
    let rays = test_rays();
    let (mesh_path, rays_path) = write_inputs(&dir, &rays);
    let mesh = Mesh::from_obj_str(OBJ).unwrap();
    for tree in raybatch::AccelKind::ALL.map(|k| k.name()) {
        for kernel in Kernel::ALL {
            let out = dir.path(&format!("hits-{tree}-{}.bin", kernel.name()));
            let extra = [
                "--kind",
                "closest",
                "--tree",
                tree,
                "--kernel",
                kernel.name(),
            ];
            let output = query(&mesh_path, &rays_path, &out, &extra);
            assert!(output.status.success(), "{}", stderr(&output));
            let bytes = std::fs::read(&out).unwrap();
            assert_eq!(bytes.len(), 16 * rays.len());
            let mut hits = 0;
            for (i, (ray, record)) in rays.iter().zip(bytes.chunks_exact(16)).enumerate() {
                let triangle = u32::from_le_bytes(record[4..8].try_into().unwrap());
                let got = (
                    f32_at(record, 0),
                    triangle,
                    f32_at(record, 8),
                    f32_at(record, 12),
                );
                let expected = match brute_force::cast_ray(&mesh, ray, kernel) {
                    Some(h) => (h.t, h.triangle, h.u, h.v),
                    None => (f32::INFINITY, u32::MAX, 0.0, 0.0),
                };
                hits += usize::from(expected.1 != u32::MAX);
                let bits = |(t, id, u, v): (f32, u32, f32, f32)| {
                    (t.to_bits(), id, u.to_bits(), v.to_bits())
                };
                assert_eq!(
                    bits(got),
                    bits(expected),
                    "{tree} {kernel:?} ray {i}: {ray:?}"
                );
            }
            assert!(
                hits > 0 && hits < rays.len(),
                "the rays should both hit and miss"
            );
            check_json(&output, rays.len(), hits);
        }
    }
}

#[test]
fn any_hits_match_brute_force() {
    let dir = TempDir::new("any");
    let rays = test_rays();
    let (mesh_path, rays_path) = write_inputs(&dir, &rays);
    let mesh = Mesh::from_obj_str(OBJ).unwrap();
    let out = dir.path("hits.bin");
    let output = query(
        &mesh_path,
        &rays_path,
        &out,
        &["--kind", "any", "--batched"],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    let expected: Vec<u8> = rays
        .iter()
        .map(|r| u8::from(brute_force::occluded(&mesh, r, Kernel::Watertight)))
        .collect();
    assert_eq!(std::fs::read(&out).unwrap(), expected);
    let hits = expected.iter().filter(|&&b| b == 1).count();
    check_json(&output, rays.len(), hits);
}

/// Many rays (upward and slanted, on a fine grid over the mesh, plus [`test_rays`]), enough for
/// the batched engine to cut them into several chunks on two threads.
fn many_rays() -> Vec<Ray> {
    let mut rays = test_rays();
    let n = 120;
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (
                -0.1 + 1.2 * i as f32 / n as f32,
                -0.1 + 1.2 * j as f32 / n as f32,
            );
            rays.push(Ray::new(Vec3::new(x, y, 0.0), Vec3::new(0.05, 0.02, 1.0)));
            rays.push(Ray::new(Vec3::new(x, y, 3.0), Vec3::new(-0.1, 0.2, -1.0)));
        }
    }
    rays
}

/// Runs a successful query with `extra` flags; returns the output bytes and the JSON line.
fn query_ok(dir: &TempDir, mesh: &Path, rays: &Path, extra: &[&str]) -> (Vec<u8>, String) {
    let out = dir.path("hits.bin");
    let output = query(mesh, rays, &out, extra);
    assert!(output.status.success(), "{extra:?}: {}", stderr(&output));
    let bytes = std::fs::read(&out).unwrap();
    std::fs::remove_file(&out).unwrap();
    (bytes, stderr(&output).trim_end().to_string())
}

/// `cook` writes a file that `query` answers from as from the OBJ mesh, bit for bit, for a
/// binary and a wide tree; a `--tree` of another kind is a usage error, a damaged file an
/// input error.
#[test]
fn cooked_files_answer_as_the_mesh() {
    let dir = TempDir::new("cooked");
    let rays = many_rays();
    let (mesh, rays_path) = write_inputs(&dir, &rays);
    let cooked = dir.path("mesh.rbt");
    for kind in ["aabb", "bvh8q"] {
        let args = [
            "cook",
            "--mesh",
            mesh.to_str().unwrap(),
            "--out",
            cooked.to_str().unwrap(),
        ];
        let output = raybatch(&[&args[..], &["--tree", kind, "--loads", "2"]].concat());
        assert!(output.status.success(), "{}", stderr(&output));
        let line = stderr(&output);
        assert_eq!(json_str(line.trim_end(), "tree"), Some(kind), "{line}");
        for query_kind in ["closest", "any"] {
            let from_mesh = query_ok(
                &dir,
                &mesh,
                &rays_path,
                &["--kind", query_kind, "--tree", kind],
            );
            let from_file = query_ok(
                &dir,
                &cooked,
                &rays_path,
                &["--kind", query_kind, "--batched"],
            );
            assert!(from_mesh.0 == from_file.0, "{kind} {query_kind}");
            assert!(from_file.1.contains("\"load_ms\""), "{}", from_file.1);
        }
    }
    let other = ["--kind", "any", "--tree", "bvh4"];
    assert_fails(
        &dir,
        &cooked,
        &rays_path,
        &other,
        2,
        "holds a cooked bvh8q tree",
    );
    let mut bytes = std::fs::read(&cooked).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    std::fs::write(&cooked, bytes).unwrap();
    assert_fails(&dir, &cooked, &rays_path, &["--kind", "any"], 1, "damaged");
}

/// Without `--tree` the query builds the fastest structure for the mesh
/// (`AccelKind::for_mesh`: the 8-wide tree for a mesh this small), answering as it does.
#[test]
fn the_default_tree_is_the_one_for_the_mesh() {
    let dir = TempDir::new("default-tree");
    let rays = many_rays();
    let (mesh, rays_path) = write_inputs(&dir, &rays);
    let expected = raybatch::AccelKind::for_mesh(&Mesh::from_obj_str(OBJ).unwrap());
    assert_eq!(expected, raybatch::AccelKind::DEFAULT);
    let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &["--kind", "closest"]);
    assert_eq!(json_str(&line, "tree"), Some(expected.name()), "{line}");
    let named = ["--kind", "closest", "--tree", expected.name()];
    assert!(query_ok(&dir, &mesh, &rays_path, &named).0 == bytes);
}

#[test]
fn batched_and_threaded_output_equals_per_ray_output() {
    let dir = TempDir::new("batched");
    let rays = many_rays();
    let (mesh, rays_path) = write_inputs(&dir, &rays);
    let kinds = raybatch::AccelKind::ALL.map(|k| k.name());
    let pairs = kinds
        .iter()
        .flat_map(|&tree| [("closest", tree), ("any", tree)]);
    for (kind, tree) in pairs {
        let base = ["--kind", kind, "--tree", tree];
        let (expected, line) = query_ok(&dir, &mesh, &rays_path, &base);
        assert_eq!(json_str(&line, "engine"), Some("per-ray"), "{line}");
        assert_eq!(json_int(&line, "threads"), Some(1), "{line}");
        let hits = json_int(&line, "hits").unwrap();
        assert!(hits > 0 && hits < rays.len() as u64, "{line}");
        for (batched, threads) in [(true, "1"), (true, "2"), (false, "2")] {
            let mut extra = [base.as_slice(), &["--threads", threads]].concat();
            let engine = if batched { "batched" } else { "per-ray" };
            if batched {
                extra.push("--batched");
            }
            let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &extra);
            assert!(bytes == expected, "{extra:?}: output differs");
            assert_eq!(json_str(&line, "engine"), Some(engine), "{line}");
            assert_eq!(json_int(&line, "threads"), threads.parse().ok(), "{line}");
            assert_eq!(json_int(&line, "hits"), Some(hits), "{line}");
        }
        let extra = [base.as_slice(), &["--batched"]].concat();
        let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &extra);
        assert!(bytes == expected, "{extra:?}: output differs");
        assert_eq!(json_str(&line, "engine"), Some("batched"), "{line}");
    }
}

/// `--passes`, `--batch-size`, `--max-chunk`, `--wide-leaf`, `--leaf-copy` and `--ordering`
/// change the timing, never the output; the JSON line reports every pass, the chunk, the wide
/// leaf size, the leaf copy and the ordering asked for.
#[test]
fn passes_and_batch_size_keep_the_output() {
    let dir = TempDir::new("passes");
    let rays = many_rays();
    let (mesh, rays_path) = write_inputs(&dir, &rays);
    for tree in raybatch::AccelKind::ALL.map(|k| k.name()) {
        let base = ["--kind", "closest", "--tree", tree];
        let (expected, _) = query_ok(&dir, &mesh, &rays_path, &base);
        let extra = [
            base.as_slice(),
            &["--batched", "--passes", "3", "--batch-size", "1000"],
        ]
        .concat();
        let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &extra);
        assert!(bytes == expected, "{extra:?}: output differs");
        assert_eq!(json_int(&line, "passes"), Some(3), "{line}");
        assert_eq!(json_int(&line, "batch_size"), Some(1000), "{line}");
        let passes = line
            .split("\"passes_ms\":[")
            .nth(1)
            .and_then(|r| r.split(']').next());
        assert_eq!(passes.map(|p| p.split(',').count()), Some(3), "{line}");
        // Chunks of 7 rays: many chunks, each walked on its own; the same answers.
        let extra = [base.as_slice(), &["--batched", "--max-chunk", "7"]].concat();
        let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &extra);
        assert!(bytes == expected, "{extra:?}: output differs");
        assert_eq!(json_int(&line, "max_chunk"), Some(7), "{line}");
        // The wide trees without merged leaves: another tree, the same answers.
        let extra = [base.as_slice(), &["--wide-leaf", "1"]].concat();
        let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &extra);
        assert!(bytes == expected, "{extra:?}: output differs");
        let wide = raybatch::AccelKind::from_name(tree).is_some_and(|k| k.is_wide());
        assert_eq!(json_int(&line, "wide_leaf"), wide.then_some(1), "{line}");
        // Every batch ordering: the same answers.
        for ordering in raybatch::BatchOrdering::ALL.map(raybatch::BatchOrdering::name) {
            let extra = [base.as_slice(), &["--batched", "--ordering", ordering]].concat();
            let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &extra);
            assert!(bytes == expected, "{extra:?}: output differs");
            assert_eq!(json_str(&line, "ordering"), Some(ordering), "{line}");
        }
        // Every leaf copy: the same answers, per ray and batched.
        for copy in ["nothing", "indices", "corners"] {
            for engine in [&[][..], &["--batched"]] {
                let extra = [base.as_slice(), &["--leaf-copy", copy], engine].concat();
                let (bytes, line) = query_ok(&dir, &mesh, &rays_path, &extra);
                assert!(bytes == expected, "{extra:?}: output differs");
                assert_eq!(json_str(&line, "leaf_copy"), Some(copy), "{line}");
            }
        }
    }
}

/// `rays` writes the benchmark ray sets as ray files: the same seed gives the same bytes, and
/// `query` reads them.
#[test]
fn rays_writes_repeatable_ray_files() {
    let dir = TempDir::new("rays");
    let (mesh, _) = write_inputs(&dir, &[]);
    let mesh_arg = mesh.to_str().unwrap();
    let write = |name: &str, set: &str, seed: &str| {
        let out = dir.path(name);
        let args = ["rays", "--mesh", mesh_arg, "--set", set, "--count", "500"];
        let output =
            raybatch(&[&args[..], &["--seed", seed, "--out", out.to_str().unwrap()]].concat());
        assert!(output.status.success(), "{}", stderr(&output));
        std::fs::read(&out).unwrap()
    };
    // Camera rays are a pixel grid: the seed does not change them.
    for (set, seeded) in [
        ("incoherent", true),
        ("line-of-sight", true),
        ("camera", false),
    ] {
        let a = write("a.bin", set, "7");
        assert_eq!(a.len(), 500 * 32, "{set}");
        assert!(a == write("b.bin", set, "7"), "{set}: not repeatable");
        assert_eq!(a != write("c.bin", set, "8"), seeded, "{set}: seed");
    }
    let (_, line) = query_ok(&dir, &mesh, &dir.path("a.bin"), &["--kind", "closest"]);
    assert_eq!(json_int(&line, "rays"), Some(500), "{line}");
    let bad = raybatch(&[
        "rays", "--mesh", mesh_arg, "--set", "sideways", "--count", "5", "--out", "x",
    ]);
    assert_eq!(bad.status.code(), Some(2), "{}", stderr(&bad));
}

#[test]
fn empty_ray_file_gives_empty_output() {
    let dir = TempDir::new("empty");
    let (mesh_path, rays_path) = write_inputs(&dir, &[]);
    let out = dir.path("hits.bin");
    let output = query(&mesh_path, &rays_path, &out, &["--kind", "closest"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert_eq!(std::fs::read(&out).unwrap(), Vec::<u8>::new());
    check_json(&output, 0, 0);
}

/// Runs a query expected to fail with `code`; checks the message and that nothing was written.
fn assert_fails(dir: &TempDir, mesh: &Path, rays: &Path, extra: &[&str], code: i32, says: &str) {
    let before = dir.files();
    let out = dir.path("hits.bin");
    let output = query(mesh, rays, &out, extra);
    let err = stderr(&output);
    assert_eq!(output.status.code(), Some(code), "{err}");
    assert!(err.contains(says), "expected '{says}' in: {err}");
    assert!(!err.contains('{'), "no statistics on failure: {err}");
    assert!(!out.exists(), "HITS.bin must not be written");
    assert_eq!(dir.files(), before, "no file may be left behind");
}

#[test]
fn bad_input_fails_without_writing_output() {
    let dir = TempDir::new("bad");
    let (mesh, rays) = write_inputs(&dir, &test_rays());
    let closest = ["--kind", "closest"];

    let truncated = dir.path("truncated.bin");
    std::fs::write(&truncated, [0u8; 33]).unwrap();
    let msg = "is not a multiple of 32";
    assert_fails(&dir, &mesh, &truncated, &closest, 1, msg);

    let missing = dir.path("missing.obj");
    assert_fails(&dir, &missing, &rays, &closest, 1, "missing.obj");

    let malformed = dir.path("malformed.obj");
    std::fs::write(&malformed, "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    assert_fails(&dir, &malformed, &rays, &closest, 1, "line 3");

    let missing_rays = dir.path("missing.bin");
    assert_fails(&dir, &mesh, &missing_rays, &closest, 1, "missing.bin");
}

#[test]
fn bad_flags_are_usage_errors() {
    let dir = TempDir::new("flags");
    let (mesh, rays) = write_inputs(&dir, &test_rays());
    assert_fails(&dir, &mesh, &rays, &["--kind", "nearest"], 2, "--kind");
    assert_fails(&dir, &mesh, &rays, &[], 2, "--kind <KIND>");
    let unknown = ["--kind", "any", "--fast"];
    assert_fails(
        &dir,
        &mesh,
        &rays,
        &unknown,
        2,
        "unexpected argument '--fast'",
    );
    let twice = ["--kind", "any", "--leaf", "2", "--leaf", "3"];
    assert_fails(
        &dir,
        &mesh,
        &rays,
        &twice,
        2,
        "cannot be used multiple times",
    );
    assert_fails(
        &dir,
        &mesh,
        &rays,
        &["--kind", "any", "--leaf", "0"],
        2,
        "--leaf",
    );
    let bad_threads = ["--kind", "any", "--threads", "x"];
    assert_fails(&dir, &mesh, &rays, &bad_threads, 2, "--threads");

    let output = raybatch(&["frobnicate"]);
    assert_eq!(output.status.code(), Some(2));
    let help = raybatch(&["--help"]);
    assert!(help.status.success());
    let text = String::from_utf8_lossy(&help.stdout);
    for command in ["bench", "query", "rays", "render", "cook"] {
        assert!(text.contains(command), "{text}");
    }
    // Each command has its own help, listing every structure for --tree.
    let help = raybatch(&["query", "--help"]);
    assert!(help.status.success());
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(text.contains("--mesh <MESH.obj|TREE.rbt>"), "{text}");
    for kind in raybatch::AccelKind::ALL {
        assert!(text.contains(kind.name()), "{text}");
    }
    let help = raybatch(&["bench", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("--trees <LIST>"));
}

/// The Markdown tables of `text`: runs of lines starting with `| `.
fn tables(text: &str) -> Vec<Vec<&str>> {
    let mut tables: Vec<Vec<&str>> = Vec::new();
    let mut previous_was_row = false;
    for line in text.lines() {
        let row = line.starts_with("| ");
        match (row, previous_was_row) {
            (true, true) => tables.last_mut().unwrap().push(line),
            (true, false) => tables.push(vec![line]),
            _ => {}
        }
        previous_was_row = row;
    }
    tables
}

#[test]
fn quick_bench_prints_the_tables_and_writes_the_report() {
    let target = TempDir::new("bench_report");
    let output = Command::new(env!("CARGO_BIN_EXE_raybatch"))
        .args(["bench", "--quick", "--scenes", "bunny", "--rays", "2000"])
        .env("CARGO_TARGET_DIR", &target.0)
        .output()
        .expect("run raybatch");
    let out = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(out.contains("### bunny (69,451 triangles)"), "{out}");
    for line in [
        "Kernels, closest",
        "Per-ray vs batched",
        "Partition kernels",
    ] {
        assert!(out.contains(line), "no '{line}' in {out}");
    }
    let tables = tables(&out);
    assert_eq!(tables.len(), 5, "{out}");
    // Header, rule, and one row per structure of the catalog (--quick: pns only).
    let kinds = raybatch::AccelKind::ALL;
    let main = &tables[0];
    assert_eq!(main.len(), 2 + kinds.len(), "{out}");
    assert!(main[0].starts_with("| tree "), "{out}");
    for (row, kind) in main[2..].iter().zip(kinds) {
        assert!(row.starts_with(&format!("| {} ", kind.name())), "{out}");
    }
    // Per-ray vs batched: 6 queries on each pns tree.
    let batched = &tables[1];
    assert_eq!(batched.len(), 2 + 6 * kinds.len(), "{out}");
    assert!(batched[0].contains("by-octant") && batched[0].contains("2 threads"));
    for (k, kind) in kinds.iter().enumerate() {
        let first = &batched[2 + 6 * k];
        assert!(
            first.starts_with(&format!("| {}/pns ", kind.name())),
            "{out}"
        );
    }
    // Batch sizes: 64, then all 2000 (4096 is more than the rays).
    let sweep = &tables[2];
    assert_eq!(sweep.len(), 2 + 2, "{out}");
    assert!(
        sweep[2].contains(" 64 |") && sweep[3].contains("2,000 (all)"),
        "{out}"
    );
    // Modes: 9 modes x 5 ray sets; leaks: 3 closed meshes x 9 modes.
    assert_eq!(tables[3].len(), 2 + 9 * 5, "{out}");
    assert!(tables[3][2].starts_with("| bvh8 watertight "), "{out}");
    assert_eq!(tables[4].len(), 2 + 3 * 9, "{out}");
    let report = target.0.join("raybatch-report");
    let csv = std::fs::read_to_string(report.join("report.csv")).expect("report.csv written");
    assert!(csv.starts_with("machine,commit,date,section,"), "{csv}");
    assert!(
        csv.lines()
            .any(|l| l.contains(",modes,bunny,aabb 16-bit vertices,")),
        "{csv}"
    );
    let page = std::fs::read_to_string(report.join("index.html")).expect("index.html written");
    for chart in [
        "speed_vs_error",
        "speed_vs_memory",
        "per_ray_vs_batched",
        "batch_size_sweep",
    ] {
        assert!(
            page.contains(&format!("{chart}.svg")),
            "no {chart} in the page"
        );
        assert!(
            report.join(format!("{chart}.svg")).is_file(),
            "no {chart}.svg"
        );
    }
    // Progress bars are drawn only on a terminal: a pipe gets nothing.
    assert_eq!(stderr(&output), "");
}

/// `--trees` and `--scenes` select a slice of the bench: only the named structures' rows.
#[test]
fn bench_filters_select_trees() {
    let args = [
        "bench", "--quick", "--scenes", "bunny", "--trees", "kd,bvh8", "--rays", "500",
    ];
    let output = raybatch(&args);
    let out = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{}", stderr(&output));
    let tables = tables(&out);
    // The main table and per-ray vs batched (the sweep needs the default tree, bvh8: present).
    let main = &tables[0];
    assert_eq!(main.len(), 2 + 2, "{out}");
    assert!(
        main[2].starts_with("| bvh8 ") && main[3].starts_with("| kd "),
        "{out}"
    );
    assert!(!out.contains("Zero memory"), "{out}");
    let bad = raybatch(&["bench", "--trees", "octree"]);
    assert_eq!(bad.status.code(), Some(2));
    let both = raybatch(&["bench", "--mesh", "x.obj", "--scenes", "bunny"]);
    assert_eq!(both.status.code(), Some(2));
}

/// `--threads` is capped at 4 per core (20,000 threads would abort the process after
/// minutes): a usage error naming the limit, before any work.
#[test]
fn threads_are_capped() {
    let dir = TempDir::new("threads");
    let (mesh, rays) = write_inputs(&dir, &test_rays());
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let max = (4 * cores).to_string();
    let over = (4 * cores + 1).to_string();
    let ok = ["--kind", "any", "--batched", "--threads", &max];
    query_ok(&dir, &mesh, &rays, &ok);
    let too_many = ["--kind", "any", "--threads", &over];
    assert_fails(
        &dir,
        &mesh,
        &rays,
        &too_many,
        2,
        &format!("more than {max}"),
    );
    assert_fails(
        &dir,
        &mesh,
        &rays,
        &["--kind", "any", "--threads", "20000"],
        2,
        "per core",
    );
}

/// `--out` never destroys an input: the same file by its own path, through a symbolic link
/// or a hard link is refused before anything is written.
#[test]
fn output_equal_to_an_input_is_refused() {
    let dir = TempDir::new("same-file");
    let (mesh, rays) = write_inputs(&dir, &test_rays());
    let before = std::fs::read(&rays).unwrap();
    let hard = dir.path("hard.bin");
    std::fs::hard_link(&rays, &hard).unwrap();
    let soft = dir.path("soft.bin");
    std::os::unix::fs::symlink(&rays, &soft).unwrap();
    let dotted = dir.0.join(".").join("rays.bin");
    for out in [&rays, &hard, &soft, &dotted, &mesh] {
        let args = ["--kind", "closest"];
        let output = query(&mesh, &rays, out, &args);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{out:?}: {}",
            stderr(&output)
        );
        assert!(
            stderr(&output).contains("the same file as the input"),
            "{}",
            stderr(&output)
        );
    }
    assert_eq!(std::fs::read(&rays).unwrap(), before);
    assert!(
        std::fs::symlink_metadata(&soft)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    let rays_out = raybatch(&[
        "rays",
        "--mesh",
        mesh.to_str().unwrap(),
        "--set",
        "camera",
        "--count",
        "5",
        "--out",
        mesh.to_str().unwrap(),
    ]);
    assert_eq!(rays_out.status.code(), Some(2), "{}", stderr(&rays_out));
    assert_eq!(std::fs::read_to_string(&mesh).unwrap(), OBJ);
}

/// A symbolic link is written through (its target replaced, the link kept); a device is
/// written into, not replaced by a regular file; `-` is stdout; a directory and a link to
/// nothing are refused.
#[test]
fn output_targets_that_are_not_regular_files() {
    let dir = TempDir::new("targets");
    let (mesh, rays) = write_inputs(&dir, &test_rays());
    let (expected, _) = query_ok(&dir, &mesh, &rays, &["--kind", "closest"]);

    let target = dir.path("target.bin");
    std::fs::write(&target, b"old").unwrap();
    let link = dir.path("link.bin");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let output = query(&mesh, &rays, &link, &["--kind", "closest"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(std::fs::read(&target).unwrap() == expected);

    let null = Path::new("/dev/null");
    let output = query(&mesh, &rays, null, &["--kind", "closest"]);
    assert!(output.status.success(), "{}", stderr(&output));
    use std::os::unix::fs::FileTypeExt;
    assert!(
        std::fs::metadata(null)
            .unwrap()
            .file_type()
            .is_char_device()
    );

    let output = query(&mesh, &rays, Path::new("-"), &["--kind", "closest"]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(output.stdout == expected, "stdout holds the answers");

    let dangling = dir.path("dangling.bin");
    std::os::unix::fs::symlink(dir.path("nothing"), &dangling).unwrap();
    for (out, says) in [(&dangling, "link to nothing"), (&dir.0, "a directory")] {
        let output = query(&mesh, &rays, out, &["--kind", "closest"]);
        assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
        assert!(stderr(&output).contains(says), "{}", stderr(&output));
    }
}

/// Files that are not OBJ meshes fail with a clear message instead of loading as an empty
/// mesh that every ray misses.
#[test]
fn files_that_are_not_obj_are_refused() {
    let dir = TempDir::new("not-obj");
    let (_, rays) = write_inputs(&dir, &test_rays());
    let stl = "solid cube\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 1\n      \
               vertex 1 0 1\n      vertex 0 1 1\n    endloop\n  endfacet\nendsolid cube\n";
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let readme = "# raybatch\n\nBatches of ray queries against triangle meshes.\n";
    let random: String = (0..500u32)
        .map(|i| char::from(b'!' + (i * 37 % 90) as u8))
        .collect();
    let vertices_only = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (name, text) in [
        ("cube.stl", stl),
        ("cube.ply", ply),
        ("README.md", readme),
        ("random.txt", random.as_str()),
        ("points.obj", vertices_only),
    ] {
        let path = dir.path(name);
        std::fs::write(&path, text).unwrap();
        let says = "no faces found (is this an OBJ file?)";
        assert_fails(&dir, &path, &rays, &["--kind", "closest"], 1, says);
    }
    // Binary STL: an 80-byte header, then binary records: not text, the line is named.
    let mut binary = vec![b' '; 80];
    binary.extend_from_slice(&1u32.to_le_bytes());
    binary.extend((0..50).map(|i| 0x80 + i as u8));
    let path = dir.path("binary.stl");
    std::fs::write(&path, binary).unwrap();
    assert_fails(
        &dir,
        &path,
        &rays,
        &["--kind", "closest"],
        1,
        "line 1: not UTF-8",
    );
}

/// Old Mac `\r` line endings are lines; a non-UTF-8 byte in a comment is accepted, elsewhere
/// the error names its line.
#[test]
fn obj_line_endings_and_bytes() {
    let dir = TempDir::new("endings");
    let rays = test_rays();
    let (mesh, rays_path) = write_inputs(&dir, &rays);
    let (expected, _) = query_ok(&dir, &mesh, &rays_path, &["--kind", "closest"]);
    let mac = dir.path("mac.obj");
    std::fs::write(&mac, OBJ.replace('\n', "\r")).unwrap();
    let (bytes, _) = query_ok(&dir, &mac, &rays_path, &["--kind", "closest"]);
    assert!(bytes == expected, "a \\r-only file is the same mesh");

    let mut latin1 = b"# auteur: Ren\xe9\n".to_vec();
    latin1.extend_from_slice(OBJ.as_bytes());
    let commented = dir.path("latin1.obj");
    std::fs::write(&commented, &latin1).unwrap();
    let (bytes, _) = query_ok(&dir, &commented, &rays_path, &["--kind", "closest"]);
    assert!(bytes == expected, "a comment may hold any bytes");

    latin1.extend_from_slice(b"g caf\xe9\n");
    let bad = dir.path("bad.obj");
    std::fs::write(&bad, &latin1).unwrap();
    let lines = OBJ.lines().count() + 2;
    let says = format!("line {lines}: not UTF-8");
    assert_fails(&dir, &bad, &rays_path, &["--kind", "closest"], 1, &says);
}

/// The PNG's width, height and RGB bytes (decoded with the png crate).
fn decode_png(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut rgb = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut rgb).expect("one frame");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    rgb.truncate(info.buffer_size());
    (info.width, info.height, rgb)
}

/// `render` draws the mesh: the quad seen from above covers the middle of the image and not
/// its corners; per-ray and batched images are the same; the heat map marks every pixel whose
/// ray entered the structure.
#[test]
fn render_draws_the_mesh() {
    let dir = TempDir::new("render");
    let (mesh, _) = write_inputs(&dir, &[]);
    let mesh_arg = mesh.to_str().unwrap();
    let render = |extra: &[&str]| {
        let out = dir.path("image.png");
        let args = [
            "render",
            "--mesh",
            mesh_arg,
            "--out",
            out.to_str().unwrap(),
            "--width",
            "40",
            "--height",
            "30",
            "--view",
            "0,0,1",
        ];
        let output = raybatch(&[&args[..], extra].concat());
        assert!(output.status.success(), "{extra:?}: {}", stderr(&output));
        decode_png(&std::fs::read(&out).unwrap())
    };
    let (w, h, normal) = render(&[]);
    assert_eq!((w, h, normal.len()), (40, 30, 40 * 30 * 3));
    let pixel = |img: &[u8], x: usize, y: usize| img[3 * (y * 40 + x)..][..3].to_vec();
    let background = pixel(&normal, 0, 0);
    assert_ne!(
        pixel(&normal, 20, 15),
        background,
        "the mesh is in the middle"
    );
    for kind in raybatch::AccelKind::ALL.map(|k| k.name()) {
        let (_, _, batched) = render(&["--batched", "--tree", kind]);
        assert!(batched == normal, "{kind}: batched image differs");
        let (_, _, heat) = render(&["--shade", "heat", "--tree", kind]);
        assert_ne!(
            pixel(&heat, 20, 15),
            [0, 0, 0],
            "{kind}: the walk entered nodes"
        );
    }
    let (_, _, depth) = render(&["--shade", "depth"]);
    assert_ne!(pixel(&depth, 20, 15), pixel(&depth, 0, 0));
    let heat_batched = raybatch(&[
        "render",
        "--mesh",
        mesh_arg,
        "--out",
        "x.png",
        "--shade",
        "heat",
        "--batched",
    ]);
    assert_eq!(
        heat_batched.status.code(),
        Some(2),
        "{}",
        stderr(&heat_batched)
    );
}

/// Without threads (every thread spawn fails: `RUST_MIN_STACK` asks for more stack than the
/// address space), every command runs on the calling thread with the same output, or, for
/// `bench`, which times thread pools, fails with a message: never a panic.
#[test]
fn commands_without_threads() {
    let no_threads = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_raybatch"))
            .args(args)
            .env("RUST_MIN_STACK", (1u64 << 50).to_string())
            .output()
            .expect("run raybatch")
    };
    let dir = TempDir::new("no-threads");
    let rays = many_rays();
    let (mesh, rays_path) = write_inputs(&dir, &rays);
    let (mesh, rays_path) = (mesh.to_str().unwrap(), rays_path.to_str().unwrap());
    for kind in ["closest", "any"] {
        let base = ["query", "--mesh", mesh, "--rays", rays_path, "--kind", kind];
        let with = dir.path("with.bin");
        let without = dir.path("without.bin");
        let expected = raybatch(&[&base[..], &["--out", with.to_str().unwrap()]].concat());
        assert!(expected.status.success(), "{}", stderr(&expected));
        for extra in [&["--batched"][..], &[]] {
            let out = ["--out", without.to_str().unwrap()];
            let got = no_threads(&[&base[..], extra, &out].concat());
            assert_eq!(got.status.code(), Some(0), "{extra:?}: {}", stderr(&got));
            assert!(std::fs::read(&with).unwrap() == std::fs::read(&without).unwrap());
        }
    }
    let written = |f: &dyn Fn(&[&str]) -> Output, name: &str| {
        let out = dir.path(name);
        let args = [
            "rays",
            "--mesh",
            mesh,
            "--set",
            "incoherent",
            "--count",
            "3000",
        ];
        let run = f(&[&args[..], &["--out", out.to_str().unwrap()]].concat());
        assert_eq!(run.status.code(), Some(0), "{}", stderr(&run));
        std::fs::read(out).unwrap()
    };
    assert!(written(&raybatch, "a.bin") == written(&no_threads, "b.bin"));
    let image = dir.path("image.png");
    let render = no_threads(&[
        "render",
        "--mesh",
        mesh,
        "--out",
        image.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "48",
        "--batched",
    ]);
    assert_eq!(render.status.code(), Some(0), "{}", stderr(&render));
    let bench = no_threads(&["bench", "--quick", "--mesh", mesh]);
    assert_eq!(bench.status.code(), Some(1), "{}", stderr(&bench));
    assert!(stderr(&bench).contains("threads"), "{}", stderr(&bench));
}

/// Counts that would exhaust memory are usage errors naming the limit, not aborts.
#[test]
fn huge_counts_are_usage_errors() {
    for args in [
        &[
            "query",
            "--mesh",
            "m.obj",
            "--rays",
            "r.bin",
            "--kind",
            "any",
            "--out",
            "-",
            "--passes",
            "4294967295",
        ][..],
        &[
            "rays",
            "--mesh",
            "m.obj",
            "--set",
            "incoherent",
            "--count",
            "18446744073709551615",
            "--out",
            "-",
        ],
        &[
            "rays",
            "--mesh",
            "m.obj",
            "--set",
            "incoherent",
            "--count",
            "1000000000",
            "--out",
            "-",
        ],
        &["bench", "--rays", "1000000000"],
    ] {
        let output = raybatch(args);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{args:?}: {}",
            stderr(&output)
        );
        assert!(
            stderr(&output).contains("more than"),
            "{args:?}: {}",
            stderr(&output)
        );
    }
}
