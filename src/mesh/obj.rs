//! Minimal, fast Wavefront OBJ reader for triangle meshes.
//!
//! Supported: `v x y z [w ...]` positions (anything after `z` is ignored) and
//! `f` faces whose vertices are written `i`, `i/t`, `i//n` or `i/t/n`; only the
//! position index is used. Indices are 1-based, negative indices are relative to
//! the vertices declared so far. Comments (`#`, also after data), blank lines,
//! a leading UTF-8 BOM and every other statement (`vt`, `vn`, `g`, `usemtl`, ...)
//! are accepted and ignored. Lines end with `\n`, `\r\n` or a lone `\r` (old Mac
//! files), each counted as one line. The input is bytes: a comment may hold any
//! bytes (exporters write file names and author names in Latin-1), while the rest
//! of a line must be UTF-8, else the error names the line.
//!
//! Triangle order guarantee: polygons are fan-triangulated as `(v0,v1,v2)`,
//! `(v0,v2,v3)`, ... and triangles are emitted in file order. The position of a
//! triangle in the output is its triangle id for the whole library, so this
//! order is never changed.

use glam::Vec3;
use std::fmt;

/// A parse error: what went wrong, and on which line (1-based).
#[derive(Clone, Debug, PartialEq)]
pub struct ObjError {
    /// 1-based line number of the offending statement.
    pub line: usize,
    /// What went wrong.
    pub kind: ObjErrorKind,
}

/// The kinds of error [`parse_obj`] can report.
#[derive(Clone, Debug, PartialEq)]
pub enum ObjErrorKind {
    /// A vertex coordinate token that is not a number.
    BadNumber(String),
    /// A vertex coordinate that is NaN or infinite (including overflow such as `1e99`).
    NonFiniteCoordinate,
    /// A `v` statement with fewer than 3 numbers.
    MissingCoordinate,
    /// An `f` statement with fewer than 3 vertices (the count found).
    TooFewFaceVertices(usize),
    /// A face vertex token whose position index is not an integer (or does not
    /// fit in an `i64`), or is `0`. Holds the whole token.
    BadIndex(String),
    /// A face index, as written in the file, that does not refer to one of the
    /// `vertex_count` vertices declared before this line (negative indices are
    /// resolved relative to that count).
    IndexOutOfRange {
        /// The index as written in the file (may be negative).
        index: i64,
        /// Number of vertices declared before the face.
        vertex_count: usize,
    },
    /// The file declares more than `u32::MAX` vertices.
    TooManyVertices,
    /// The line (outside a comment) is not valid UTF-8: most likely not a text file.
    NotUtf8,
}

impl fmt::Display for ObjError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: ", self.line)?;
        match &self.kind {
            ObjErrorKind::BadNumber(tok) => write!(f, "invalid number `{tok}`"),
            ObjErrorKind::NonFiniteCoordinate => {
                write!(f, "vertex coordinate is not finite (nan or inf)")
            }
            ObjErrorKind::MissingCoordinate => write!(f, "vertex needs 3 coordinates"),
            ObjErrorKind::TooFewFaceVertices(n) => {
                write!(f, "face has {n} vertices, at least 3 are needed")
            }
            ObjErrorKind::BadIndex(tok) => write!(f, "invalid face index `{tok}`"),
            ObjErrorKind::IndexOutOfRange {
                index,
                vertex_count,
            } => write!(
                f,
                "face index {index} out of range (only {vertex_count} {} so far)",
                if *vertex_count == 1 {
                    "vertex"
                } else {
                    "vertices"
                }
            ),
            ObjErrorKind::TooManyVertices => {
                write!(f, "more than {} vertices", u32::MAX)
            }
            ObjErrorKind::NotUtf8 => write!(f, "not UTF-8 text (is this an OBJ file?)"),
        }
    }
}

impl std::error::Error for ObjError {}

/// Parses OBJ text into vertex positions and triangles (0-based indices into
/// the returned positions).
///
/// Triangles come out in file order, polygons fan-triangulated; see the module
/// documentation. Never panics; malformed input yields an [`ObjError`] carrying
/// the 1-based line number.
pub fn parse_obj(text: &str) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), ObjError> {
    parse_obj_bytes(text.as_bytes())
}

/// [`parse_obj`] on the file's bytes: comments may hold bytes that are not UTF-8 (see the
/// module documentation).
pub fn parse_obj_bytes(bytes: &[u8]) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), ObjError> {
    // Indices are u32, so vertex ids 0..=u32::MAX are addressable.
    parse_obj_with_limit(bytes, u32::MAX as usize + 1)
}

/// The lines of `bytes`, ended by `\n`, `\r\n` or a lone `\r` (the ending not included).
fn lines(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = Some(bytes);
    std::iter::from_fn(move || {
        let text = rest?;
        match text.iter().position(|&b| b == b'\n' || b == b'\r') {
            None => {
                rest = None;
                // A final line without an ending (none at all for an empty tail).
                (!text.is_empty()).then_some(text)
            }
            Some(end) => {
                let skip = if text[end..].starts_with(b"\r\n") {
                    2
                } else {
                    1
                };
                rest = Some(&text[end + skip..]);
                Some(&text[..end])
            }
        }
    })
}

/// [`parse_obj`] with a configurable vertex limit (so the limit is testable).
fn parse_obj_with_limit(
    bytes: &[u8],
    max_vertices: usize,
) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), ObjError> {
    let bytes = bytes.strip_prefix("\u{feff}".as_bytes()).unwrap_or(bytes);
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    // Reused per face to avoid an allocation per polygon.
    let mut poly: Vec<u32> = Vec::with_capacity(8);

    for (line_idx, raw_line) in lines(bytes).enumerate() {
        let line_no = line_idx + 1;
        let err = |kind| ObjError {
            line: line_no,
            kind,
        };
        // Strip a trailing comment (`#` is ASCII, never part of a longer UTF-8 sequence), then
        // require text.
        let data = raw_line.split(|&b| b == b'#').next().unwrap_or(&[]);
        let line = std::str::from_utf8(data).map_err(|_| err(ObjErrorKind::NotUtf8))?;
        let mut tokens = line.split_ascii_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut xyz = [0.0f32; 3];
                for c in &mut xyz {
                    let tok = tokens
                        .next()
                        .ok_or_else(|| err(ObjErrorKind::MissingCoordinate))?;
                    let value: f32 = tok
                        .parse()
                        .map_err(|_| err(ObjErrorKind::BadNumber(tok.to_owned())))?;
                    if !value.is_finite() {
                        return Err(err(ObjErrorKind::NonFiniteCoordinate));
                    }
                    *c = value;
                }
                if positions.len() >= max_vertices {
                    return Err(err(ObjErrorKind::TooManyVertices));
                }
                positions.push(Vec3::from_array(xyz));
            }
            Some("f") => {
                poly.clear();
                for tok in tokens {
                    poly.push(resolve_index(tok, positions.len()).map_err(err)?);
                }
                if poly.len() < 3 {
                    return Err(err(ObjErrorKind::TooFewFaceVertices(poly.len())));
                }
                if let Some((&first, rest)) = poly.split_first() {
                    triangles.extend(rest.windows(2).map(|w| [first, w[0], w[1]]));
                }
            }
            // Blank/comment lines and every other statement are ignored.
            _ => {}
        }
    }
    Ok((positions, triangles))
}

/// Resolves one face vertex token (`i`, `i/t`, `i//n`, `i/t/n`) to a 0-based
/// position index, checked against the `vertex_count` vertices declared so far.
fn resolve_index(tok: &str, vertex_count: usize) -> Result<u32, ObjErrorKind> {
    let pos = tok.split('/').next().unwrap_or("");
    let index: i64 = match pos.parse() {
        Ok(i) if i != 0 => i,
        _ => return Err(ObjErrorKind::BadIndex(tok.to_owned())),
    };
    let out_of_range = || ObjErrorKind::IndexOutOfRange {
        index,
        vertex_count,
    };
    let count = i64::try_from(vertex_count).map_err(|_| out_of_range())?;
    // Positive: 1-based. Negative: -1 is the last vertex declared so far.
    // Neither branch can overflow: index is non-zero and count >= 0.
    let zero_based = if index > 0 { index - 1 } else { count + index };
    if (0..count).contains(&zero_based) {
        u32::try_from(zero_based).map_err(|_| out_of_range())
    } else {
        Err(out_of_range())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok(text: &str) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        parse_obj(text).expect("should parse")
    }

    fn err_of(text: &str) -> ObjError {
        parse_obj(text).expect_err("should fail")
    }

    const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

    #[test]
    fn single_triangle() {
        let (v, t) = ok("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        assert_eq!(
            v,
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            "positions in declaration order"
        );
        assert_eq!(t, vec![[0, 1, 2]]);
    }

    #[test]
    fn quad_fan_triangulated_in_order() {
        let (v, t) = ok(&format!("{SQUARE}f 1 2 3 4\n"));
        assert_eq!(v.len(), 4);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn pentagon_fan_triangulated_in_order() {
        let (_, t) = ok(&format!("{SQUARE}v 0.5 2 0\nf 5 4 3 2 1\n"));
        assert_eq!(t, vec![[4, 3, 2], [4, 2, 1], [4, 1, 0]]);
    }

    #[test]
    fn triangles_keep_file_order_across_faces() {
        let (_, t) = ok(&format!("{SQUARE}f 4 3 2\nf 1 2 3 4\nf 2 3 4\n"));
        assert_eq!(t, vec![[3, 2, 1], [0, 1, 2], [0, 2, 3], [1, 2, 3]]);
    }

    #[test]
    fn slash_forms() {
        let text = format!(
            "{SQUARE}vt 0 0\nvt 1 0\nvn 0 0 1\n\
             f 1/1/1 2/2/1 3/1/1\nf 1//1 3//1 4//1\nf 2/1 3/2 4/1\n"
        );
        let (_, t) = ok(&text);
        assert_eq!(t, vec![[0, 1, 2], [0, 2, 3], [1, 2, 3]]);
    }

    #[test]
    fn negative_indices_are_relative() {
        let (_, t) = ok("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 1 1 1\nf -1 -2/1 -4//2\n");
        assert_eq!(t, vec![[0, 1, 2], [3, 2, 0]]);
    }

    #[test]
    fn w_colors_and_exponents() {
        let (v, _) = ok("v 1e0 -2.5E-1 +3 1.0\nv 1 2 3 0.5 0.25 0.125\n");
        assert_eq!(
            v,
            vec![Vec3::new(1.0, -0.25, 3.0), Vec3::new(1.0, 2.0, 3.0)]
        );
    }

    #[test]
    fn crlf_tabs_comments_and_ignored_statements() {
        let text = "\u{feff}# header\r\n\r\nmtllib a.mtl\r\no thing\r\ng grp\r\n\
                    s off\r\nusemtl m\r\nv\t0  0\t 0 # trailing\r\nv 1 0 0#x\r\n\
                    vp 0.5\r\nv 0 1 0\r\n  \t \r\nl 1 2\r\np 1\r\nfoo bar\r\n\
                    #f 9 9 9\r\n\tf 1 2 3 # tri\r\n";
        let (v, t) = ok(text);
        assert_eq!(v, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(t, vec![[0, 1, 2]]);
    }

    #[test]
    fn old_mac_line_endings_are_lines() {
        let (v, t) = ok("v 0 0 0\rv 1 0 0\r\rv 0 1 0\rf 1 2 3\r");
        assert_eq!((v.len(), t), (3, vec![[0, 1, 2]]));
        // Mixed endings: `\r\n` is one ending, a lone `\r` another; line numbers follow.
        let e = err_of("v 0 0 0\r\nv 1 0 0\rv 0 1 0\nf 1 2 9\r\n");
        assert_eq!(e.line, 4);
        let e = err_of("v 0 0 0\r\rf 1 2 3");
        assert_eq!(e.line, 3);
    }

    #[test]
    fn bytes_outside_utf8_are_accepted_in_comments_only() {
        let mut file =
            b"# made by Ren\xe9\nv 0 0 0\nv 1 0 0 # \xff\xfe\nv 0 1 0\nf 1 2 3\n".to_vec();
        let (v, t) = parse_obj_bytes(&file).expect("comments may hold any bytes");
        assert_eq!((v.len(), t.len()), (3, 1));
        file.extend_from_slice(b"g caf\xe9\n");
        let e = parse_obj_bytes(&file).unwrap_err();
        assert_eq!((e.line, &e.kind), (6, &ObjErrorKind::NotUtf8));
        assert_eq!(
            e.to_string(),
            "line 6: not UTF-8 text (is this an OBJ file?)"
        );
    }

    #[test]
    fn empty_and_comment_only_files() {
        for text in ["", "\n\n", "# nothing\r\n", "   \t"] {
            let (v, t) = ok(text);
            assert!(v.is_empty() && t.is_empty(), "{text:?}");
        }
    }

    #[test]
    fn bad_number() {
        let e = err_of("v 0 0 0\n# c\nv 1 x 2\n");
        assert_eq!(
            e,
            ObjError {
                line: 3,
                kind: ObjErrorKind::BadNumber("x".into())
            }
        );
        assert_eq!(e.to_string(), "line 3: invalid number `x`");
    }

    #[test]
    fn non_finite_coordinate() {
        for (text, line) in [
            ("v nan 0 0", 1),
            ("\nv 0 inf 0", 2),
            ("\n\nv 0 0 -infinity", 3),
            ("v 0 0 1e39", 1),
        ] {
            assert_eq!(
                err_of(text),
                ObjError {
                    line,
                    kind: ObjErrorKind::NonFiniteCoordinate
                },
                "{text:?}"
            );
        }
    }

    #[test]
    fn missing_coordinate() {
        for text in ["v 1 2 3\nv 1 2", "v 1 2 3\nv", "v 1 2 3\nv 1 2 # 3"] {
            assert_eq!(
                err_of(text),
                ObjError {
                    line: 2,
                    kind: ObjErrorKind::MissingCoordinate
                },
                "{text:?}"
            );
        }
    }

    #[test]
    fn too_few_face_vertices() {
        let e = err_of(&format!("{SQUARE}f 1 2\n"));
        assert_eq!(
            e,
            ObjError {
                line: 5,
                kind: ObjErrorKind::TooFewFaceVertices(2)
            }
        );
        assert_eq!(
            err_of(&format!("{SQUARE}\nf\n")).kind,
            ObjErrorKind::TooFewFaceVertices(0)
        );
    }

    #[test]
    fn bad_index() {
        for tok in [
            "0",
            "0//1",
            "x",
            "1.5",
            "/1/1",
            "//",
            "99999999999999999999",
            "-99999999999999999999",
        ] {
            let e = err_of(&format!("{SQUARE}f 1 2 {tok}\n"));
            assert_eq!(
                e,
                ObjError {
                    line: 5,
                    kind: ObjErrorKind::BadIndex(tok.into())
                },
                "{tok:?}"
            );
        }
    }

    #[test]
    fn index_out_of_range() {
        let e = err_of(&format!("{SQUARE}f 1 2 5\n"));
        assert_eq!(
            e,
            ObjError {
                line: 5,
                kind: ObjErrorKind::IndexOutOfRange {
                    index: 5,
                    vertex_count: 4
                }
            }
        );
        assert_eq!(
            e.to_string(),
            "line 5: face index 5 out of range (only 4 vertices so far)"
        );
        // Forward reference: vertex declared only after the face.
        let e = err_of("v 0 0 0\nf 1 2 3\nv 1 0 0\nv 0 1 0\n");
        assert_eq!(
            e.kind,
            ObjErrorKind::IndexOutOfRange {
                index: 2,
                vertex_count: 1
            }
        );
        assert_eq!(
            e.to_string(),
            "line 2: face index 2 out of range (only 1 vertex so far)"
        );
        for index in [-5, i64::MIN, i64::MAX] {
            assert_eq!(
                err_of(&format!("{SQUARE}f 1 2 {index}/3\n")).kind,
                ObjErrorKind::IndexOutOfRange {
                    index,
                    vertex_count: 4
                }
            );
        }
    }

    #[test]
    fn too_many_vertices() {
        let e = parse_obj_with_limit(b"v 0 0 0\nv 1 0 0\n\nv 0 1 0\n", 2).unwrap_err();
        assert_eq!(
            e,
            ObjError {
                line: 4,
                kind: ObjErrorKind::TooManyVertices
            }
        );
        assert_eq!(e.to_string(), "line 4: more than 4294967295 vertices");
        assert!(parse_obj_with_limit(b"v 0 0 0\nv 1 0 0\n", 2).is_ok());
    }

    #[test]
    fn stanford_bunny() {
        let (v, t) = ok(include_str!("../../data/stanford-bunny.obj"));
        assert_eq!(v.len(), 35947);
        assert_eq!(t.len(), 69451);
        assert!(t.iter().flatten().all(|&i| (i as usize) < v.len()));
        assert!(v.iter().all(|p| p.is_finite()));
    }

    /// Tiny xorshift64 so the fuzz test needs no extra crates.
    struct XorShift(u64);

    impl XorShift {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
    }

    fn check_no_panic_and_consistent(text: &str) {
        if let Ok((v, t)) = parse_obj(text) {
            assert!(t.iter().flatten().all(|&i| (i as usize) < v.len()));
            assert!(v.iter().all(|p| p.is_finite()));
        }
    }

    #[test]
    fn fuzz_never_panics() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
        // Random bytes biased towards OBJ-ish characters.
        const ALPHABET: &[u8] = b"vf \t\n\r#/-+.eE0123456789naitn";
        for _ in 0..300 {
            let len = rng.below(200);
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    if rng.below(4) == 0 {
                        rng.next() as u8
                    } else {
                        ALPHABET[rng.below(ALPHABET.len())]
                    }
                })
                .collect();
            check_no_panic_and_consistent(&String::from_utf8_lossy(&bytes));
        }
        // Mutations of a valid file: insert, replace or delete text.
        let base =
            format!("{SQUARE}vt 0 0\nvn 0 0 1\nf 1/1/1 2//1 3 4\nf -1 -2 -3\n# c\nf 4 3 2 1\n");
        let pieces: Vec<&str> = "0 - / // # f v nan e9 99999999999999999999 \r\n \u{feff} é"
            .split(' ')
            .chain([" ", "\n"])
            .collect();
        for _ in 0..500 {
            let mut text = base.clone();
            for _ in 0..1 + rng.below(4) {
                let mut at = rng.below(text.len() + 1);
                while !text.is_char_boundary(at) {
                    at -= 1;
                }
                let piece = pieces[rng.below(pieces.len())];
                match rng.below(3) {
                    0 => text.insert_str(at, piece),
                    1 => {
                        let mut end = (at + 1 + rng.below(5)).min(text.len());
                        while !text.is_char_boundary(end) {
                            end += 1;
                        }
                        text.replace_range(at..end, piece);
                    }
                    _ => {
                        let mut end = (at + rng.below(10)).min(text.len());
                        while !text.is_char_boundary(end) {
                            end += 1;
                        }
                        text.replace_range(at..end, "");
                    }
                }
            }
            check_no_panic_and_consistent(&text);
        }
    }
}
