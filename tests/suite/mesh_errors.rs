//! Bad input gives typed errors, never a panic: every `MeshError` variant that input can
//! produce, OBJ errors naming the line, and `BuildError::BadLeafSize`.

use glam::Vec3;
use proptest::prelude::*;
use raybatch::mesh::obj::{ObjError, ObjErrorKind};
use raybatch::mesh::{MAX_COORDINATE, MAX_TRIANGLES};
use raybatch::{AabbTree, AccelKind, BuildError, BuildOptions, Mesh, MeshError, QuantizedAabbTree};

fn tri() -> Vec<Vec3> {
    vec![Vec3::ZERO, Vec3::X, Vec3::Y]
}

#[test]
fn index_out_of_range() {
    for (triangles, triangle, index) in [
        (vec![[0, 1, 3]], 0, 3),
        (vec![[0, 1, 2], [0, 1, 2], [2, 7, 9]], 2, 7),
        (vec![[u32::MAX, 0, 1]], 0, u32::MAX),
        (vec![[0, 1, 2], [1, 2, 3]], 1, 3),
    ] {
        assert_eq!(
            Mesh::new(tri(), triangles.clone()),
            Err(MeshError::IndexOutOfRange {
                triangle,
                index,
                vertex_count: 3
            }),
            "{triangles:?}"
        );
    }
    // No vertices at all: index 0 is already out of range.
    assert_eq!(
        Mesh::new(vec![], vec![[0, 0, 0]]),
        Err(MeshError::IndexOutOfRange {
            triangle: 0,
            index: 0,
            vertex_count: 0
        })
    );
    let e = Mesh::new(tri(), vec![[0, 1, 5]]).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("triangle 0") && msg.contains('5') && msg.contains('3'),
        "{msg}"
    );
}

#[test]
fn non_finite_vertices() {
    let bad = [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    for value in bad {
        for axis in 0..3 {
            for vertex in 0..3 {
                let mut v = tri();
                v[vertex][axis] = value;
                // Reported whether or not a triangle uses the vertex.
                for triangles in [vec![], vec![[0, 1, 2]]] {
                    assert_eq!(
                        Mesh::new(v.clone(), triangles),
                        Err(MeshError::NonFiniteVertex { vertex }),
                        "{value} at {vertex}.{axis}"
                    );
                }
            }
        }
    }
    let msg = MeshError::NonFiniteVertex { vertex: 7 }.to_string();
    assert!(msg.contains("vertex 7"), "{msg}");
}

#[test]
fn coordinate_too_large() {
    // The limit itself is accepted, anything beyond is not, on every axis and sign.
    assert_eq!(MAX_COORDINATE, (1u64 << 40) as f32);
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            let mut v = tri();
            v[1][axis] = sign * MAX_COORDINATE;
            assert!(Mesh::new(v.clone(), vec![[0, 1, 2]]).is_ok());
            for big in [MAX_COORDINATE.next_up(), 1e13, f32::MAX] {
                v[1][axis] = sign * big;
                assert_eq!(
                    Mesh::new(v.clone(), vec![[0, 1, 2]]),
                    Err(MeshError::CoordinateTooLarge { vertex: 1 }),
                    "{}",
                    sign * big
                );
            }
        }
    }
    // From OBJ text too: a finite f32 that is too large is a mesh error, not an OBJ error.
    assert_eq!(
        Mesh::from_obj_str("v 0 0 0\nv 2e12 0 0\nv 0 1 0\nf 1 2 3\n"),
        Err(MeshError::CoordinateTooLarge { vertex: 1 })
    );
    assert!(
        MeshError::CoordinateTooLarge { vertex: 1 }
            .to_string()
            .contains("vertex 1")
    );
}

/// The OBJ error (line and kind) of a text.
fn obj_error(text: &str) -> ObjError {
    match Mesh::from_obj_str(text) {
        Err(MeshError::Obj(e)) => e,
        other => panic!("expected an OBJ error for {text:?}, got {other:?}"),
    }
}

#[test]
fn malformed_obj_names_the_line() {
    let head = "# a comment\nv 0 0 0\nv 1 0 0\n\nv 0 1 0\n"; // 5 lines, 3 vertices
    let cases: Vec<(String, usize, ObjErrorKind)> = vec![
        (
            format!("{head}v 1 x 0\n"),
            6,
            ObjErrorKind::BadNumber("x".into()),
        ),
        (format!("{head}v 1 2\n"), 6, ObjErrorKind::MissingCoordinate),
        (format!("{head}v\n"), 6, ObjErrorKind::MissingCoordinate),
        (
            format!("{head}v nan 0 0\n"),
            6,
            ObjErrorKind::NonFiniteCoordinate,
        ),
        (
            format!("{head}v 0 inf 0\n"),
            6,
            ObjErrorKind::NonFiniteCoordinate,
        ),
        (
            format!("{head}v 0 0 1e99\n"),
            6,
            ObjErrorKind::NonFiniteCoordinate,
        ),
        (
            format!("{head}f 1 2\n"),
            6,
            ObjErrorKind::TooFewFaceVertices(2),
        ),
        (format!("{head}f\n"), 6, ObjErrorKind::TooFewFaceVertices(0)),
        (
            format!("{head}f 0 1 2\n"),
            6,
            ObjErrorKind::BadIndex("0".into()),
        ),
        (
            format!("{head}f 1 b 3\n"),
            6,
            ObjErrorKind::BadIndex("b".into()),
        ),
        (
            format!("{head}f 1 2 /3\n"),
            6,
            ObjErrorKind::BadIndex("/3".into()),
        ),
        (
            format!("{head}f 1 2 4\n"),
            6,
            ObjErrorKind::IndexOutOfRange {
                index: 4,
                vertex_count: 3,
            },
        ),
        (
            format!("{head}f -4 1 2\n"),
            6,
            ObjErrorKind::IndexOutOfRange {
                index: -4,
                vertex_count: 3,
            },
        ),
        // A face may only use vertices declared before it.
        (
            "v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n".into(),
            2,
            ObjErrorKind::IndexOutOfRange {
                index: 2,
                vertex_count: 1,
            },
        ),
        // Line numbers count CRLF lines, blank lines and a leading BOM correctly.
        (
            "\u{feff}v 0 0 0\r\n\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\nf 1 2 9\r\n".into(),
            6,
            ObjErrorKind::IndexOutOfRange {
                index: 9,
                vertex_count: 3,
            },
        ),
        // The first error wins.
        (
            format!("{head}f 1 2 3\nv a 0 0\nf 9 9 9\n"),
            7,
            ObjErrorKind::BadNumber("a".into()),
        ),
    ];
    for (text, line, kind) in cases {
        let e = obj_error(&text);
        assert_eq!((e.line, &e.kind), (line, &kind), "{text:?}");
        let msg = MeshError::Obj(e).to_string();
        assert!(msg.contains(&format!("line {line}")), "{msg}");
    }
    // The same faces without the error parse.
    let m = Mesh::from_obj_str(&format!("{head}f 1 2 3\nf -3 -2 -1\n")).unwrap();
    assert_eq!(m.triangles(), &[[0, 1, 2], [0, 1, 2]]);
}

#[test]
fn unreadable_file_is_an_io_error() {
    for path in ["/nonexistent/dir/mesh.obj", "/"] {
        match Mesh::load_obj(path) {
            Err(MeshError::Io { path: p, message }) => {
                assert_eq!(p, path);
                assert!(!message.is_empty());
            }
            other => panic!("{path}: expected an I/O error, got {other:?}"),
        }
    }
    // A readable file goes through the same checks as text.
    let dir = std::env::temp_dir().join(format!("raybatch-mesh-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("good.obj");
    std::fs::write(&good, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_eq!(Mesh::load_obj(&good).unwrap().triangle_count(), 1);
    let bad = dir.join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap();
    assert!(matches!(
        Mesh::load_obj(&bad),
        Err(MeshError::Obj(ObjError { line: 3, .. }))
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The count limits cannot be reached by real input here (billions of elements); their
/// values and messages are checked directly.
#[test]
fn count_limits_and_messages() {
    assert_eq!(MAX_TRIANGLES, u32::MAX as usize - 1);
    let e = MeshError::TooManyTriangles {
        count: MAX_TRIANGLES + 1,
        max: MAX_TRIANGLES,
    };
    assert!(e.to_string().contains(&MAX_TRIANGLES.to_string()));
    let e = MeshError::TooManyVertices {
        count: 1 << 33,
        max: 1 << 32,
    };
    assert!(e.to_string().contains(&(1u64 << 33).to_string()));
}

#[test]
fn bad_leaf_sizes() {
    let mesh = Mesh::new(tri(), vec![[0, 1, 2]]).unwrap();
    let empty = Mesh::new(vec![], vec![]).unwrap();
    for m in [mesh, empty] {
        let bad_sizes = [0u32, 17, 100, u32::MAX].into_iter();
        let with_leaf = |leaf| BuildOptions::default().with_leaf_size(leaf);
        let with_wide_leaf = |leaf| BuildOptions::default().with_wide_leaf_size(leaf);
        for (leaf, options) in bad_sizes.flat_map(|l| [(l, with_leaf(l)), (l, with_wide_leaf(l))]) {
            assert_eq!(
                <AabbTree>::build(m.clone(), &options).err(),
                Some(BuildError::BadLeafSize(leaf))
            );
            assert_eq!(
                QuantizedAabbTree::build(m.clone(), &options).err(),
                Some(BuildError::BadLeafSize(leaf))
            );
            for kind in AccelKind::ALL {
                assert_eq!(
                    kind.build(m.clone(), &options).err(),
                    Some(BuildError::BadLeafSize(leaf)),
                    "{}",
                    kind.name()
                );
            }
            assert!(
                BuildError::BadLeafSize(leaf)
                    .to_string()
                    .contains(&leaf.to_string())
            );
        }
        let good_sizes = [1u32, 16].into_iter();
        for options in good_sizes.flat_map(|l| [with_leaf(l), with_wide_leaf(l)]) {
            assert!(<AabbTree>::build(m.clone(), &options).is_ok());
            assert!(QuantizedAabbTree::build(m.clone(), &options).is_ok());
            for kind in AccelKind::ALL {
                assert!(kind.build(m.clone(), &options).is_ok(), "{}", kind.name());
            }
        }
    }
}

fn any_coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -10.0f32..10.0,
        1 => any::<f32>(),
        1 => prop::sample::select(vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            MAX_COORDINATE,
            MAX_COORDINATE.next_up(),
            -0.0,
        ]),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Arbitrary arrays: `Mesh::new` never panics, accepts exactly the valid ones, and names
    /// the first bad vertex (vertices are checked before indices) or the first bad triangle.
    #[test]
    fn mesh_new_accepts_exactly_valid_input(
        vertices in prop::collection::vec((any_coord(), any_coord(), any_coord()), 0..12),
        triangles in prop::collection::vec((0u32..14, 0u32..14, 0u32..14), 0..12),
    ) {
        let vertices: Vec<Vec3> = vertices.iter().map(|&(x, y, z)| Vec3::new(x, y, z)).collect();
        let triangles: Vec<[u32; 3]> = triangles.iter().map(|&(a, b, c)| [a, b, c]).collect();
        let first_bad_vertex = vertices.iter().position(|v| {
            !v.is_finite() || v.abs().max_element() > MAX_COORDINATE
        });
        let first_bad_triangle = triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= vertices.len()));
        let result = Mesh::new(vertices.clone(), triangles.clone());
        match (first_bad_vertex, first_bad_triangle) {
            (None, None) => {
                let m = result.unwrap();
                prop_assert_eq!(m.vertices(), &vertices[..]);
                prop_assert_eq!(m.triangles(), &triangles[..]);
            }
            (Some(vertex), _) => {
                let expected = if vertices[vertex].is_finite() {
                    MeshError::CoordinateTooLarge { vertex }
                } else {
                    MeshError::NonFiniteVertex { vertex }
                };
                prop_assert_eq!(result, Err(expected));
            }
            (None, Some(triangle)) => {
                let index = *triangles[triangle]
                    .iter()
                    .find(|&&i| i as usize >= vertices.len())
                    .unwrap();
                prop_assert_eq!(
                    result,
                    Err(MeshError::IndexOutOfRange { triangle, index, vertex_count: vertices.len() })
                );
            }
        }
    }

    /// Arbitrary OBJ-like text never panics; an OBJ error names a line of the text (lines end
    /// with `\n`, `\r\n` or a lone `\r`).
    #[test]
    fn obj_parsing_never_panics(
        lines in prop::collection::vec(
            prop_oneof![
                Just("v 0 0 0".to_string()),
                Just("v 1 2 3 4".to_string()),
                Just("f 1 2 3".to_string()),
                Just("f -1 -2 -3 -4".to_string()),
                Just("f 1/1/1 2//2 3/3".to_string()),
                Just("# comment".to_string()),
                Just(String::new()),
                "[vf] [-0-9./e a-z]{0,16}",
                ".{0,20}",
            ],
            0..20,
        ),
    ) {
        let text = lines.join("\n");
        // A lone `\r` ends a line too (old Mac files), `\r\n` is one ending.
        let line_count = text.replace("\r\n", "\n").replace('\r', "\n").split('\n').count();
        match Mesh::from_obj_str(&text) {
            Ok(m) => {
                let n = m.vertices().len() as u32;
                prop_assert!(m.triangles().iter().flatten().all(|&i| i < n));
            }
            Err(MeshError::Obj(e)) => {
                prop_assert!(e.line >= 1 && e.line <= line_count, "{e:?}");
                prop_assert!(!e.to_string().is_empty());
            }
            Err(MeshError::CoordinateTooLarge { .. }) => {}
            Err(other) => prop_assert!(false, "unexpected error {other:?}"),
        }
    }
}
