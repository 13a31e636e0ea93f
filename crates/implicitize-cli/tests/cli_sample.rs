//! `implicitize sample` through the binary: the `.npz` read back entry by entry (the ZIP's
//! headers, CRCs and the arrays), DeepSDF's layout, seeds, and a refused option.

use std::path::Path;
use std::process::Command;

use implicitize::{DVec3, mesh};
use implicitize_test_support::meshes::sphere;

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_implicitize")).args(args).output().unwrap()
}

/// CRC-32 (IEEE, reflected), bit by bit: independent of the writer's.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

fn u16_at(b: &[u8], at: usize) -> usize {
    u16::from_le_bytes([b[at], b[at + 1]]) as usize
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// The entries of a ZIP of stored files, `(name, bytes)`, read from the local headers and
/// checked against the central directory and their CRCs.
fn unzip(zip: &[u8]) -> Vec<(String, Vec<u8>)> {
    let end = zip.len() - 22;
    assert_eq!(u32_at(zip, end), 0x0605_4b50, "the end of the central directory");
    let count = u16_at(zip, end + 10);
    let mut central = u32_at(zip, end + 16) as usize;
    let mut entries = Vec::new();
    for _ in 0..count {
        assert_eq!(u32_at(zip, central), 0x0201_4b50);
        let offset = u32_at(zip, central + 42) as usize;
        let name_length = u16_at(zip, central + 28);
        let central_name = &zip[central + 46..central + 46 + name_length];
        assert_eq!(u32_at(zip, offset), 0x0403_4b50);
        assert_eq!(u16_at(zip, offset + 8), 0, "stored, not compressed");
        let (crc, size) = (u32_at(zip, offset + 14), u32_at(zip, offset + 18) as usize);
        assert_eq!(size, u32_at(zip, offset + 22) as usize);
        assert_eq!(crc, u32_at(zip, central + 16));
        let name = &zip[offset + 30..offset + 30 + u16_at(zip, offset + 26)];
        assert_eq!(name, central_name);
        let start = offset + 30 + name.len() + u16_at(zip, offset + 28);
        let data = zip[start..start + size].to_vec();
        assert_eq!(crc32(&data), crc, "the CRC of {}", String::from_utf8_lossy(name));
        entries.push((String::from_utf8(name.to_vec()).unwrap(), data));
        central += 46 + name_length;
    }
    entries
}

/// An array's shape and values.
fn array<T: npyz::Deserialize>(bytes: &[u8]) -> (Vec<u64>, Vec<T>) {
    let npy = npyz::NpyFile::new(bytes).unwrap();
    (npy.shape().to_vec(), npy.into_vec::<T>().unwrap())
}

#[test]
fn the_npz_holds_points_distances_and_deepsdfs_layout() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let ball = sphere(DVec3::ZERO, 1.0, 24, 48);
    mesh::write(Path::new(&path("ball.obj")), &ball).unwrap();
    let ball = path("ball.obj");
    let args = ["sample", &ball, "-n", "2001", "--near-surface", "0.01,0.002", "--uniform", "0.3"];
    let o = run(&[&args[..], &["-o", &path("s.npz")]].concat());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("sampled 2001 points (1401 near the surface, 600 uniform;"),
        "{stderr}"
    );

    let zip = std::fs::read(path("s.npz")).unwrap();
    let entries = unzip(&zip);
    let names: Vec<&str> = entries.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["points.npy", "sdf.npy", "pos.npy", "neg.npy"]);
    let (shape, points) = array::<f64>(&entries[0].1);
    assert_eq!(shape, [2001, 3]);
    let (shape, sdf) = array::<f64>(&entries[1].1);
    assert_eq!(shape, [2001]);
    let (pos_shape, pos) = array::<f32>(&entries[2].1);
    let (neg_shape, neg) = array::<f32>(&entries[3].1);
    let outside = sdf.iter().filter(|&&s| s < 0.0).count();
    assert_eq!((pos_shape, neg_shape), (vec![outside as u64, 4], vec![2001 - outside as u64, 4]));
    assert!(outside > 1000 && outside < 2001, "{outside} outside the ball");
    // DeepSDF's rows: the points with the distance negated, split by its sign, in order.
    let (mut p, mut q) = (pos.chunks(4), neg.chunks(4));
    for (point, &s) in points.chunks(3).zip(&sdf) {
        let row = if s < 0.0 { p.next() } else { q.next() }.unwrap();
        let expected = [point[0] as f32, point[1] as f32, point[2] as f32, -s as f32];
        assert_eq!(row, expected);
    }
    // Every distance is the ball's: within its tessellation (1 - cos(pi / 24) < 0.01).
    for (point, &s) in points.chunks(3).zip(&sdf) {
        let radial = 1.0 - DVec3::from_slice(point).length();
        assert!((s - radial).abs() < 0.01, "{point:?}: {s} against {radial}");
    }

    let again = run(&[&args[..], &["-o", &path("again.npz")]].concat());
    assert!(again.status.success());
    assert_eq!(std::fs::read(path("again.npz")).unwrap(), zip, "same seed, same bytes");
    let other = run(&[&args[..], &["--seed", "2", "-o", &path("other.npz")]].concat());
    assert!(other.status.success());
    assert_ne!(std::fs::read(path("other.npz")).unwrap(), zip);
}

#[test]
fn a_bad_option_is_refused_in_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let ball = dir.path().join("ball.obj");
    mesh::write(&ball, &sphere(DVec3::ZERO, 1.0, 8, 8)).unwrap();
    let out = dir.path().join("s.npz");
    for (option, value, said) in [
        ("--uniform", "1.5", "--uniform must be a fraction"),
        ("--near-surface", "0.01,-1", "--near-surface standard deviations"),
    ] {
        let args = ["sample", ball.to_str().unwrap(), "-n", "100", option, value, "-o"];
        let o = run(&[&args[..], &[out.to_str().unwrap()]].concat());
        assert!(!o.status.success());
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(said), "{stderr}");
        assert!(!out.exists());
    }
}
