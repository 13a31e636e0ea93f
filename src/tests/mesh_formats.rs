//! Reading and writing every mesh format and encoding, and every kind of bad input.
//!
//! Test files are written here, by hand and independently of the crate's writers, so a reader
//! and a writer cannot share a mistake. The reference shape is a box, 2 x 3 x 4 and away from
//! the origin, made of six quads; read back it must be closed, outward-facing and enclose 24.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use implicitize::mesh::{self, Format, Mesh, ReadReport};
use implicitize::{DVec3, Error};

const ORIGIN: [f64; 3] = [10.25, -5.5, 7.0];
const SIZE: [f64; 3] = [2.0, 3.0, 4.0];

/// The box's corners: bit 0 of the index picks x, bit 1 y, bit 2 z.
fn box_vertices() -> Vec<[f64; 3]> {
    (0..8)
        .map(|i| std::array::from_fn(|a| ORIGIN[a] + if i >> a & 1 == 1 { SIZE[a] } else { 0.0 }))
        .collect()
}

/// The box's faces, counter-clockwise seen from outside.
const QUADS: [[u32; 4]; 6] = [
    [0, 2, 3, 1], // z min
    [4, 5, 7, 6], // z max
    [0, 1, 5, 4], // y min
    [2, 6, 7, 3], // y max
    [0, 4, 6, 2], // x min
    [1, 3, 7, 5], // x max
];

/// The box as the readers must return it: each quad split into a fan around its first corner.
fn box_mesh() -> Mesh {
    Mesh {
        vertices: box_vertices().into_iter().map(DVec3::from_array).collect(),
        triangles: QUADS.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect(),
    }
}

/// The signed volume a mesh encloses (positive when its triangles face outward).
fn volume(m: &Mesh) -> f64 {
    (0..m.triangles.len())
        .map(|t| {
            let [a, b, c] = m.corners(t);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// Whether every directed edge appears once and its reverse once: closed and consistently
/// oriented, with shared vertices.
fn is_closed(m: &Mesh) -> bool {
    let mut edges = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    edges.iter().all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
}

/// Asserts that `m` is the box, closed and outward-facing, with `vertices` vertices.
fn assert_box(m: &Mesh, vertices: usize) {
    assert_eq!(m.triangles.len(), 12);
    assert_eq!(m.vertices.len(), vertices);
    assert!(is_closed(m), "not closed: {:?}", m.triangles);
    assert!((volume(m) - 24.0).abs() < 1e-9, "volume {}", volume(m));
    let b = m.bounds().unwrap();
    assert_eq!(b.min.to_array(), ORIGIN);
    assert_eq!(b.size().to_array(), SIZE);
}

/// Writes `bytes` to a file called `name` in a fresh temporary directory and reads it.
fn read_file(name: &str, bytes: &[u8]) -> (Result<(Mesh, ReadReport), Error>, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    (mesh::read(&path), path)
}

/// Reads a file that must be valid.
fn read_ok(name: &str, bytes: &[u8]) -> (Mesh, ReadReport) {
    match read_file(name, bytes).0 {
        Ok(r) => r,
        Err(e) => panic!("{name}: {e}"),
    }
}

/// Reads a file that must be rejected; returns the message after checking that it names the
/// file and, when given, the place.
fn read_err(name: &str, bytes: &[u8], place: Option<&str>) -> String {
    let (result, path) = read_file(name, bytes);
    let message = match result {
        Ok((m, _)) => panic!("{name} read as {} triangles", m.triangles.len()),
        Err(e) => e.to_string(),
    };
    assert!(message.contains(&path.display().to_string()), "no file name in: {message}");
    if let Some(place) = place {
        assert!(message.contains(&format!("({place})")), "expected ({place}) in: {message}");
    }
    message
}

// ---------------------------------------------------------------------------------------------
// OBJ

/// The box as OBJ, with its faces written in `corner` form (`{}` stands for the index).
fn box_obj(corner: &str) -> String {
    let mut s = String::from("# a box\nmtllib box.mtl\no box\n");
    for v in box_vertices() {
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    s += "vt 0 0\nvn 0 0 1\ng sides\nusemtl red\ns off\n";
    for q in QUADS {
        let corners: Vec<String> =
            q.iter().map(|&i| corner.replace("{}", &(i + 1).to_string())).collect();
        s += &format!("f {}\n", corners.join(" "));
    }
    s
}

#[test]
fn obj_every_corner_form_reads_the_box() {
    for corner in ["{}", "{}/1", "{}//1", "{}/1/1", "{}/0/0"] {
        let (m, report) = read_ok("box.obj", box_obj(corner).as_bytes());
        assert_eq!(m, box_mesh(), "corner form {corner}");
        assert_eq!(report.degenerate_dropped, 0);
        assert_box(&m, 8);
    }
}

#[test]
fn obj_negative_indices_count_back_from_the_last_vertex() {
    let mut s = String::new();
    for v in box_vertices() {
        s += &format!("v {} {} {}\r\n", v[0], v[1], v[2]);
    }
    for q in QUADS {
        let c: Vec<String> = q.iter().map(|&i| format!("{}", i as i64 - 8)).collect();
        s += &format!("f {}\r\n", c.join(" "));
    }
    let (m, _) = read_ok("box.obj", s.as_bytes());
    assert_eq!(m, box_mesh());
}

#[test]
fn obj_triangles_and_unused_vertices() {
    let mut s = box_obj("{}");
    s += "v 100 100 100\n"; // used by no face
    let (m, _) = read_ok("box.obj", s.as_bytes());
    assert_eq!(m.vertices.len(), 9);
    assert_box(&Mesh { vertices: m.vertices[..8].to_vec(), triangles: m.triangles.clone() }, 8);
}

#[test]
fn obj_degenerate_triangles_are_dropped_and_counted() {
    let mut s = box_obj("{}");
    // The midpoint of edge 1-2 of the box (vertices 0 and 1), then a repeated corner and a
    // zero-area triangle.
    let [a, b] = [box_vertices()[0], box_vertices()[1]];
    s += &format!("v {} {} {}\n", (a[0] + b[0]) / 2.0, a[1], a[2]);
    s += "f 1 1 2\nf 1 2 9\nf 3 -1 3\n";
    let (m, report) = read_ok("box.obj", s.as_bytes());
    assert_eq!(report.degenerate_dropped, 3);
    assert_eq!(m.triangles, box_mesh().triangles);
}

#[test]
fn obj_bad_inputs_name_the_file_and_line() {
    let obj = box_obj("{}");
    let with = |line: &str| format!("{obj}{line}\n");
    let last = obj.lines().count() + 1;
    let place = format!("line {last}");
    let m = read_err("bad.obj", with("f 1 2 9").as_bytes(), Some(&place));
    assert!(m.contains("out of range"), "{m}");
    let m = read_err("bad.obj", with("f 0 1 2").as_bytes(), Some(&place));
    assert!(m.contains("out of range"), "{m}");
    let m = read_err("bad.obj", with("f -9 1 2").as_bytes(), Some(&place));
    assert!(m.contains("out of range"), "{m}");
    let m = read_err("bad.obj", with("v 1 nan 2").as_bytes(), Some(&place));
    assert!(m.contains("non-finite y"), "{m}");
    let m = read_err("bad.obj", with("v 1 2 inf").as_bytes(), Some(&place));
    assert!(m.contains("non-finite z"), "{m}");
    let m = read_err("bad.obj", with("v 1 2").as_bytes(), Some(&place));
    assert!(m.contains("3 coordinates"), "{m}");
    let m = read_err("bad.obj", with("v 1 2 x").as_bytes(), Some(&place));
    assert!(m.contains("not a number"), "{m}");
    let m = read_err("bad.obj", with("f 1/2/3/4 1 2").as_bytes(), Some(&place));
    assert!(m.contains("v/vt/vn"), "{m}");
    let m = read_err("bad.obj", with("f 1 2").as_bytes(), Some(&place));
    assert!(m.contains("at least 3 corners"), "{m}");
    // Forward references are rejected: the index must name a vertex defined above.
    read_err("bad.obj", b"f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", Some("line 1"));
}

#[test]
fn empty_and_flat_meshes_are_errors() {
    let m = read_err("empty.obj", b"", None);
    assert!(m.contains("empty mesh"), "{m}");
    let m = read_err("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n", None);
    assert!(m.contains("empty mesh"), "{m}");
    let m = read_err("degenerate.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n", None);
    assert!(m.contains("all 2 triangles are degenerate"), "{m}");
    let square = b"v 0 0 5\nv 1 0 5\nv 1 1 5\nv 0 1 5\nf 1 2 3 4\n";
    let m = read_err("square.obj", square, None);
    assert!(m.contains("flat") && m.contains("along z"), "{m}");
    for name in ["empty.ply", "empty.stl", "empty.off"] {
        read_err(name, b"", None);
    }
}

#[test]
fn unknown_formats_and_missing_files_name_the_file() {
    let m = read_err("box.xyz", box_obj("{}").as_bytes(), None);
    assert!(m.contains("unknown mesh format"), "{m}");
    read_err("box", box_obj("{}").as_bytes(), None);
    let missing = Path::new("/nonexistent/dir/box.obj");
    let e = mesh::read(missing).unwrap_err().to_string();
    assert!(e.contains("/nonexistent/dir/box.obj"), "{e}");
}

#[test]
fn format_follows_the_extension_without_regard_to_case() {
    let cases = [("a.obj", Format::Obj), ("b.PLY", Format::Ply), ("c.Stl", Format::Stl)];
    for (name, format) in cases.into_iter().chain([("d.OFF", Format::Off)]) {
        assert_eq!(Format::from_path(Path::new(name)).unwrap(), format);
    }
    let (m, _) = read_ok("BOX.OBJ", box_obj("{}").as_bytes());
    assert_box(&m, 8);
}

#[test]
fn the_built_in_triceratops_reads_closed() {
    let (m, report) = mesh::read(crate::tests::support::data::triceratops()).unwrap();
    assert_eq!(m.triangles.len(), 5660);
    assert_eq!(m.vertices.len(), 2832);
    assert_eq!(report.degenerate_dropped, 0);
    assert!(is_closed(&m));
    assert!(volume(&m) > 0.0);
}

// ---------------------------------------------------------------------------------------------
// PLY

/// One PLY number type, written in ASCII or as bytes in either order.
#[derive(Clone, Copy)]
enum Num {
    Char,
    UChar,
    Short,
    UShort,
    Int,
    UInt,
    Float,
    Double,
}

impl Num {
    const ALL_INTEGERS: [Num; 6] =
        [Num::Char, Num::UChar, Num::Short, Num::UShort, Num::Int, Num::UInt];

    fn name(self) -> &'static str {
        ["char", "uchar", "short", "ushort", "int", "uint", "float", "double"][self as usize]
    }

    fn bytes(self, v: f64, big: bool) -> Vec<u8> {
        macro_rules! b {
            ($t:ty) => {
                if big {
                    (v as $t).to_be_bytes().to_vec()
                } else {
                    (v as $t).to_le_bytes().to_vec()
                }
            };
        }
        match self {
            Num::Char => b!(i8),
            Num::UChar => b!(u8),
            Num::Short => b!(i16),
            Num::UShort => b!(u16),
            Num::Int => b!(i32),
            Num::UInt => b!(u32),
            Num::Float => b!(f32),
            Num::Double => b!(f64),
        }
    }
}

/// A PLY file in `encoding` with vertices as `pos` (and normals, to be ignored), faces as lists
/// of `index` counted by `count`, and a trailing element to be read past.
fn ply(
    encoding: &str,
    pos: Num,
    count: Num,
    index: Num,
    vertices: &[[f64; 3]],
    faces: &[Vec<f64>],
) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {encoding} 1.0\ncomment written by hand\nelement vertex {}\n\
         property {p} x\nproperty {p} y\nproperty {p} z\nproperty float nx\n\
         element face {}\nproperty list {} {} vertex_indices\nproperty uchar flags\n\
         element extra 1\nproperty list uchar int stuff\nend_header\n",
        vertices.len(),
        faces.len(),
        count.name(),
        index.name(),
        p = pos.name(),
    )
    .into_bytes();
    let big = encoding == "binary_big_endian";
    if encoding == "ascii" {
        for v in vertices {
            out.extend(format!("{} {} {} 0.5\n", v[0], v[1], v[2]).bytes());
        }
        for f in faces {
            let list: Vec<String> = f.iter().map(|i| i.to_string()).collect();
            out.extend(format!("{} {} 7\n", f.len(), list.join(" ")).bytes());
        }
        out.extend(b"2 1 2\n");
        return out;
    }
    for v in vertices {
        for &c in v {
            out.extend(pos.bytes(c, big));
        }
        out.extend(Num::Float.bytes(0.5, big));
    }
    for f in faces {
        out.extend(count.bytes(f.len() as f64, big));
        for &i in f {
            out.extend(index.bytes(i, big));
        }
        out.push(7);
    }
    out.push(2);
    out.extend(Num::Int.bytes(1.0, big));
    out.extend(Num::Int.bytes(2.0, big));
    out
}

fn box_faces() -> Vec<Vec<f64>> {
    QUADS.iter().map(|q| q.iter().map(|&i| i as f64).collect()).collect()
}

const ENCODINGS: [&str; 3] = ["ascii", "binary_little_endian", "binary_big_endian"];

#[test]
fn ply_every_encoding_position_type_and_index_type_reads_the_box() {
    for encoding in ENCODINGS {
        for pos in [Num::Float, Num::Double] {
            for count in [Num::UChar, Num::Int, Num::UInt] {
                for index in Num::ALL_INTEGERS {
                    let bytes = ply(encoding, pos, count, index, &box_vertices(), &box_faces());
                    let (m, _) = read_ok("box.ply", &bytes);
                    let what =
                        format!("{encoding} {} {} {}", pos.name(), count.name(), index.name());
                    assert_eq!(m, box_mesh(), "{what}");
                }
            }
        }
    }
}

#[test]
fn ply_bad_inputs_name_the_file_and_place() {
    let header_lines = 14;
    let vertices = box_vertices();
    let ascii = |faces: &[Vec<f64>], vertices: &[[f64; 3]]| {
        ply("ascii", Num::Float, Num::UChar, Num::Int, vertices, faces)
    };
    // Index out of range, in the sixth face.
    let mut faces = box_faces();
    faces[5][2] = 8.0;
    let place = format!("line {}", header_lines + 8 + 6);
    let m = read_err("bad.ply", &ascii(&faces, &vertices), Some(&place));
    assert!(m.contains("out of range"), "{m}");
    let mut faces = box_faces();
    faces[0][0] = -1.0;
    let m =
        read_err("bad.ply", &ascii(&faces, &vertices), Some(&format!("line {}", header_lines + 9)));
    assert!(m.contains("out of range"), "{m}");
    // Binary: the sixth face starts after the vertices (8 x 16 bytes) and five faces of
    // 1 + 4 x 4 + 1 bytes.
    let mut faces = box_faces();
    faces[5][2] = 8.0;
    let bytes = ply("binary_little_endian", Num::Float, Num::UChar, Num::Int, &vertices, &faces);
    let header_bytes = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let place = format!("byte {}", header_bytes + 8 * 16 + 5 * 18);
    let m = read_err("bad.ply", &bytes, Some(&place));
    assert!(m.contains("out of range"), "{m}");
    // A NaN coordinate in the fourth vertex.
    let mut nan = vertices.clone();
    nan[3][1] = f64::NAN;
    let bytes = ply("binary_big_endian", Num::Double, Num::UChar, Num::Int, &nan, &box_faces());
    let header_bytes = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let place = format!("byte {}", header_bytes + 3 * 28);
    let m = read_err("nan.ply", &bytes, Some(&place));
    assert!(m.contains("non-finite y"), "{m}");
    // ASCII PLY has no spelling for NaN: the number fails to parse, on its line.
    let m = read_err(
        "nan.ply",
        &ascii(&box_faces(), &nan),
        Some(&format!("line {}", header_lines + 4)),
    );
    assert!(m.contains("NaN"), "{m}");
    // Truncated in the binary payload and in the ASCII payload.
    let bytes =
        ply("binary_little_endian", Num::Float, Num::UChar, Num::Int, &vertices, &box_faces());
    let header_bytes = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let cut = header_bytes + 8 * 16 + 2 * 18 + 5;
    let place = format!("byte {}", header_bytes + 8 * 16 + 2 * 18);
    let m = read_err("cut.ply", &bytes[..cut], Some(&place));
    assert!(m.contains("truncated") && m.contains("face 2 of 6"), "{m}");
    // A negative list length (a char count of -1) and a floating-point one, in the first face.
    let bytes =
        ply("binary_little_endian", Num::Float, Num::Char, Num::Int, &vertices, &box_faces());
    let header_bytes = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let mut negative = bytes.clone();
    negative[header_bytes + 8 * 16] = 0xff;
    let place = format!("byte {}", header_bytes + 8 * 16);
    let m = read_err("bad.ply", &negative, Some(&place));
    assert!(m.contains("face 0 of 6") && m.contains("negative"), "{m}");
    // A floating-point length type is refused by the header check, in either encoding, and so
    // is a floating-point index list under either name beside an integer one.
    for encoding in ["binary_big_endian", "ascii"] {
        let bytes = ply(encoding, Num::Float, Num::Float, Num::Int, &vertices, &box_faces());
        let m = read_err("bad.ply", &bytes, None);
        assert!(m.contains("length is declared floating-point"), "{encoding}: {m}");
    }
    let text = String::from_utf8(ascii(&box_faces(), &vertices)).unwrap();
    let both = text.replace(
        "property uchar flags\n",
        "property uchar flags\nproperty list uchar float vertex_index\n",
    );
    assert_ne!(both, text);
    let m = read_err("bad.ply", both.as_bytes(), None);
    assert!(m.contains("'vertex_index' list holds floating-point"), "{m}");
    let text = ascii(&box_faces(), &vertices);
    let cut = text.len() - 30;
    let m = read_err("cut.ply", &text[..cut], None);
    assert!(m.contains("truncated"), "{m}");
    // A bad header line, a missing coordinate and float indices.
    let broken = String::from_utf8(text.clone()).unwrap().replace("element face", "elephant face");
    read_err("bad.ply", broken.as_bytes(), Some("line 9"));
    let no_z = String::from_utf8(text.clone()).unwrap().replace("property float z\n", "");
    let m = read_err("bad.ply", no_z.as_bytes(), None);
    assert!(m.contains("no 'z' property"), "{m}");
    let float_lists = ply("ascii", Num::Float, Num::UChar, Num::Float, &vertices, &box_faces());
    let m = read_err("bad.ply", &float_lists, None);
    assert!(m.contains("floating-point"), "{m}");
    let m = read_err("bad.ply", b"plx\n", Some("line 1"));
    assert!(m.contains("ply"), "{m}");
}

// ---------------------------------------------------------------------------------------------
// STL

/// The box's triangles as corner positions, as STL stores them.
fn box_triangles() -> Vec<[[f64; 3]; 3]> {
    let v = box_vertices();
    box_mesh().triangles.iter().map(|t| t.map(|i| v[i as usize])).collect()
}

fn stl_ascii(triangles: &[[[f64; 3]; 3]]) -> String {
    let mut s = String::from("solid box\n");
    for t in triangles {
        s += "  facet normal 0 0 0\n    outer loop\n";
        for p in t {
            s += &format!("      vertex {} {} {}\n", p[0], p[1], p[2]);
        }
        s += "    endloop\n  endfacet\n";
    }
    s + "endsolid box\n"
}

fn stl_binary(header: &[u8], triangles: &[[[f64; 3]; 3]]) -> Vec<u8> {
    let mut out = header.to_vec();
    out.resize(80, b' ');
    out.extend((triangles.len() as u32).to_le_bytes());
    for t in triangles {
        out.extend([0u8; 12]);
        for c in t.iter().flatten() {
            out.extend((*c as f32).to_le_bytes());
        }
        out.extend([0u8; 2]);
    }
    out
}

#[test]
fn stl_ascii_and_binary_weld_the_box_closed() {
    let triangles = box_triangles();
    let (m, _) = read_ok("box.stl", stl_ascii(&triangles).as_bytes());
    assert_box(&m, 8);
    let (m, _) = read_ok("box.stl", &stl_binary(b"binary box", &triangles));
    assert_box(&m, 8);
    // Binary files whose header starts with "solid" are still binary.
    let (m, _) = read_ok("box.STL", &stl_binary(b"solid box from a CAD program", &triangles));
    assert_box(&m, 8);
    // Upper-case keywords and two solids in one file.
    let two = stl_ascii(&triangles[..6]) + &stl_ascii(&triangles[6..]).to_uppercase();
    let (m, _) = read_ok("box.stl", two.as_bytes());
    assert_box(&m, 8);
}

#[test]
fn stl_bad_inputs_name_the_file_and_place() {
    let triangles = box_triangles();
    let binary = stl_binary(b"box", &triangles);
    let m =
        read_err("cut.stl", &binary[..84 + 50 * 4 + 20], Some(&format!("byte {}", 84 + 50 * 4)));
    assert!(m.contains("truncated"), "{m}");
    let mut longer = binary.clone();
    longer.extend([1u8; 7]);
    read_err("long.stl", &longer, Some(&format!("byte {}", 84 + 50 * 12)));
    let mut inf = triangles.clone();
    inf[2][1][0] = f64::INFINITY;
    let m =
        read_err("inf.stl", &stl_binary(b"box", &inf), Some(&format!("byte {}", 84 + 50 * 2 + 24)));
    assert!(m.contains("non-finite x"), "{m}");
    let text = stl_ascii(&triangles);
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    let cut = lines[..lines.len() - 3].concat();
    let m = read_err("cut.stl", cut.as_bytes(), Some(&format!("line {}", lines.len() - 3)));
    assert!(m.contains("truncated"), "{m}");
    let m = read_err(
        "nan.stl",
        text.replacen("vertex 10.25", "vertex NaN", 1).as_bytes(),
        Some("line 4"),
    );
    assert!(m.contains("non-finite"), "{m}");
    let m = read_err("bad.stl", text.replacen("endloop", "endlop", 1).as_bytes(), Some("line 7"));
    assert!(m.contains("endlop"), "{m}");
    let four = text.replacen("    endloop", "      vertex 1 2 3\n    endloop", 1);
    let m = read_err("bad.stl", four.as_bytes(), Some("line 9"));
    assert!(m.contains("3 vertices"), "{m}");
    read_err("short.stl", b"abc", Some("byte 3"));
}

// ---------------------------------------------------------------------------------------------
// OFF

fn box_off(keyword: &str, counts_on_header: bool, vertex_extra: &str) -> String {
    let mut s = String::from("# a box\n");
    let counts = "8 6 12";
    s += &if counts_on_header {
        format!("{keyword} {counts}\n")
    } else {
        format!("{keyword}\n\n{counts}\n")
    };
    for v in box_vertices() {
        s += &format!("{} {} {}{vertex_extra}\n", v[0], v[1], v[2]);
    }
    for q in QUADS {
        s += &format!("4 {} {} {} {} # a quad\n", q[0], q[1], q[2], q[3]);
    }
    s
}

#[test]
fn off_variants_read_the_box() {
    for (keyword, extra) in [("OFF", ""), ("COFF", " 255 0 0 255"), ("NOFF", " 0 0 1"), ("", "")] {
        for counts_on_header in [false, true] {
            if keyword.is_empty() && !counts_on_header {
                continue;
            }
            let text = box_off(keyword, counts_on_header, extra);
            let (m, _) = read_ok("box.off", text.as_bytes());
            assert_eq!(m, box_mesh(), "{keyword} {counts_on_header}");
        }
    }
}

#[test]
fn off_bad_inputs_name_the_file_and_line() {
    let text = box_off("OFF", false, "");
    // Line 1 comment, 2 OFF, 3 blank, 4 counts, 5..=12 vertices, 13..=18 faces.
    let m = read_err("bad.off", text.replace("4 1 3 7 5", "4 1 3 7 8").as_bytes(), Some("line 18"));
    assert!(m.contains("out of range"), "{m}");
    let m = read_err("bad.off", text.replacen("10.25", "nan", 1).as_bytes(), Some("line 5"));
    assert!(m.contains("non-finite x"), "{m}");
    let m = read_err(
        "cut.off",
        text.split_inclusive('\n').take(9).collect::<String>().as_bytes(),
        Some("line 9"),
    );
    assert!(m.contains("after 5 of 8 vertices"), "{m}");
    let m = read_err("bad.off", text.replace("OFF", "4OFF").as_bytes(), Some("line 2"));
    assert!(m.contains("4OFF"), "{m}");
    let m = read_err("bad.off", text.replace("OFF", "OFF BINARY").as_bytes(), Some("line 2"));
    assert!(m.contains("binary OFF"), "{m}");
    let m = read_err("bad.off", text.replace("8 6 12", "8").as_bytes(), Some("line 4"));
    assert!(m.contains("counts"), "{m}");
    let m = read_err("bad.off", text.replace("4 0 4 6 2", "4 0 4 6").as_bytes(), Some("line 17"));
    assert!(m.contains("declares 4 corners"), "{m}");
}

// ---------------------------------------------------------------------------------------------
// Writers

/// A small closed mesh with coordinates that f32 cannot hold exactly, far from the origin.
fn awkward_mesh() -> Mesh {
    let mut m = box_mesh();
    for (k, v) in m.vertices.iter_mut().enumerate() {
        *v = *v * 1000.1 + DVec3::new(1e5 / 3.0, -0.1 * k as f64, 1.0 / 7.0);
    }
    m
}

#[test]
fn writers_round_trip() {
    let m = awkward_mesh();
    let dir = tempfile::tempdir().unwrap();
    for name in ["m.obj", "m.ply", "m.off", "m.OBJ"] {
        let path = dir.path().join(name);
        mesh::write(&path, &m).unwrap();
        let (back, report) = mesh::read(&path).unwrap();
        assert_eq!(back, m, "{name} must round-trip exactly");
        assert_eq!(report.degenerate_dropped, 0);
    }
    let path = dir.path().join("m.stl");
    mesh::write(&path, &m).unwrap();
    let (back, _) = mesh::read(&path).unwrap();
    assert_eq!(back.triangles.len(), m.triangles.len());
    assert_eq!(back.vertices.len(), 8, "STL corners must weld back into shared vertices");
    for t in 0..m.triangles.len() {
        for (a, b) in back.corners(t).iter().zip(m.corners(t)) {
            assert_eq!(*a, b.as_vec3().as_dvec3(), "STL holds positions as f32");
        }
    }
    assert!(is_closed(&back));
}

#[test]
fn writing_rejects_bad_meshes_and_unknown_formats() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = box_mesh();
    let e = mesh::write(&dir.path().join("m.xyz"), &m).unwrap_err().to_string();
    assert!(e.contains("m.xyz") && e.contains("unknown mesh format"), "{e}");
    m.triangles.push([0, 1, 8]);
    let e = mesh::write(&dir.path().join("m.obj"), &m).unwrap_err().to_string();
    assert!(e.contains("m.obj") && e.contains("indexes past"), "{e}");
    let e = mesh::write(Path::new("/nonexistent/dir/m.obj"), &box_mesh()).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/dir/m.obj"), "{e}");
}
