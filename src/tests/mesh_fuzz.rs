//! Property tests for the mesh readers: random bytes, valid files cut short and valid files
//! with bytes changed give a mesh or an error naming the file, never a panic.

use std::path::Path;
use std::sync::LazyLock;

use implicitize::DVec3;
use implicitize::mesh::{self, Format, Mesh};
use proptest::prelude::*;

const FORMATS: [(Format, &str); 4] = [
    (Format::Obj, "fuzz.obj"),
    (Format::Ply, "fuzz.ply"),
    (Format::Stl, "fuzz.stl"),
    (Format::Off, "fuzz.off"),
];

/// A tetrahedron, the smallest closed mesh.
fn tetrahedron() -> Mesh {
    Mesh {
        vertices: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.5, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(0.0, 0.0, 0.5),
        ],
        triangles: vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
    }
}

/// Valid files of every format and encoding, as (format, bytes). The binary ones come from
/// the crate's writers, the text ones are written here.
static VALID: LazyLock<Vec<(Format, Vec<u8>)>> = LazyLock::new(valid_files);

fn valid_files() -> Vec<(Format, Vec<u8>)> {
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for (format, name) in FORMATS {
        let path = dir.path().join(name);
        mesh::write(&path, &tetrahedron()).unwrap();
        files.push((format, std::fs::read(&path).unwrap()));
    }
    let ply_ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
        property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\n1.5 0 0\n0 2 0\n0 0 0.5\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n";
    files.push((Format::Ply, ply_ascii.into()));
    let ply_big = ply_ascii.replace("ascii", "binary_big_endian");
    let mut big = ply_big.as_bytes()[..ply_big.find("end_header\n").unwrap() + 11].to_vec();
    for v in tetrahedron().vertices {
        for c in v.to_array() {
            big.extend((c as f32).to_be_bytes());
        }
    }
    for t in tetrahedron().triangles {
        big.push(3);
        for i in t {
            big.extend((i as i32).to_be_bytes());
        }
    }
    files.push((Format::Ply, big));
    let mut stl = String::from("solid t\n");
    for t in 0..4 {
        stl += "facet normal 0 0 0\nouter loop\n";
        for p in tetrahedron().corners(t) {
            stl += &format!("vertex {} {} {}\n", p.x, p.y, p.z);
        }
        stl += "endloop\nendfacet\n";
    }
    files.push((Format::Stl, (stl + "endsolid t\n").into()));
    files
}

fn name(format: Format) -> &'static str {
    FORMATS.iter().find(|(f, _)| *f == format).unwrap().1
}

/// Reads `bytes`; an error must name the file. Returns whether it read.
fn read_checked(bytes: &[u8], format: Format) -> Result<bool, TestCaseError> {
    let path = Path::new("dir").join(name(format));
    match mesh::read_bytes(bytes, format, &path) {
        Ok((m, _)) => {
            prop_assert!(!m.triangles.is_empty());
            Ok(true)
        }
        Err(e) => {
            let message = e.to_string();
            prop_assert!(message.starts_with(&path.display().to_string()), "{}", message);
            prop_assert!(!message.contains('\n'), "not one line: {}", message);
            Ok(false)
        }
    }
}

proptest! {
    #[test]
    fn random_bytes_are_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        for (format, _) in FORMATS {
            prop_assert!(!read_checked(&bytes, format)?);
        }
    }

    #[test]
    fn random_bytes_after_a_valid_start_never_panic(
        file in 0..VALID.len(),
        keep in 0.0..1.0f64,
        tail in proptest::collection::vec(any::<u8>(), 0..512),
    ) {
        let (format, bytes) = &VALID[file];
        let mut bytes = bytes[..(keep * bytes.len() as f64) as usize].to_vec();
        bytes.extend(tail);
        read_checked(&bytes, *format)?;
    }

    #[test]
    fn changed_bytes_never_panic(
        file in 0..VALID.len(),
        changes in proptest::collection::vec((0.0..1.0f64, any::<u8>()), 1..8),
    ) {
        let (format, mut bytes) = VALID[file].clone();
        for (at, byte) in changes {
            let i = (at * bytes.len() as f64) as usize;
            bytes[i] = byte;
        }
        read_checked(&bytes, format)?;
    }
}

#[test]
fn valid_files_read_and_every_truncation_is_handled() {
    for (format, bytes) in VALID.iter().cloned() {
        let (m, _) = mesh::read_bytes(&bytes, format, Path::new(name(format))).unwrap();
        assert_eq!(m.triangles.len(), 4);
        assert_eq!(m.vertices.len(), 4);
        for cut in 0..bytes.len() {
            read_checked(&bytes[..cut], format).unwrap();
        }
    }
}

#[test]
fn truncated_binary_files_are_errors() {
    for (format, bytes) in VALID.iter().cloned() {
        if bytes.contains(&0) {
            for cut in 0..bytes.len() {
                assert!(!read_checked(&bytes[..cut], format).unwrap(), "{format:?} cut at {cut}");
            }
        }
    }
}

#[test]
fn huge_declared_counts_take_no_time() {
    let header = "ply\nformat binary_little_endian 1.0\nelement nothing 18446744073709551615\n\
        element vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\n\
        end_header\n";
    let mut bytes = header.as_bytes().to_vec();
    bytes.extend([0u8; 30]);
    let e = mesh::read_bytes(&bytes, Format::Ply, Path::new("huge.ply")).unwrap_err();
    let message = e.to_string();
    // Refused from the header alone: 4e9 vertices need 48e9 bytes.
    assert!(
        message.contains("the header declares 4000000000 'vertex' elements")
            && message.contains("the file has 30 bytes after its header"),
        "{message}"
    );
    let off = "OFF\n4000000000 4000000000 0\n0 0 0\n";
    let e = mesh::read_bytes(off.as_bytes(), Format::Off, Path::new("huge.off")).unwrap_err();
    assert!(e.to_string().contains("after 1 of 4000000000 vertices"), "{e}");
    let mut stl = vec![0u8; 80];
    stl.extend(u32::MAX.to_le_bytes());
    let e = mesh::read_bytes(&stl, Format::Stl, Path::new("huge.stl")).unwrap_err();
    assert!(e.to_string().contains("truncated"), "{e}");
}
