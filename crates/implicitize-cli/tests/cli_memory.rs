//! The memory budget: work estimated to need more memory than the limit (`--memory-limit`, by
//! default what the machine has available, within `ulimit -v`) is refused with one line naming
//! the estimate, the limit and the largest resolution that fits; readers refuse headers that
//! claim more than their file holds.

use std::process::{Command, Output};

use implicitize_test_support::data::triceratops;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_implicitize")
}

fn run(args: &[&str]) -> Output {
    Command::new(bin()).args(args).arg("--quiet").output().unwrap()
}

/// Checks that `o` failed with exit 1 and one line on stderr holding every one of `parts`,
/// and returns that line.
fn refused(o: &Output, parts: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    for part in parts {
        assert!(stderr.contains(part), "{part:?} not in {stderr}");
    }
    stderr
}

/// The refusal's parts: the estimate, the limit and the largest resolution.
const BUDGET: [&str; 3] =
    ["needs about", "exceeds the memory limit of", "the largest that fits is --resolution "];

/// The largest resolution a refusal names.
fn largest(message: &str) -> usize {
    let tail = message.split("--resolution ").last().unwrap();
    tail.trim().parse().unwrap()
}

#[test]
fn sdf_and_fit_at_4096_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triceratops();
    let out = dir.path().join("out.npy");
    for command in ["sdf", "voxelize", "fit"] {
        let out = if command == "fit" { dir.path().join("m.json") } else { out.clone() };
        let o = run(&[
            command,
            mesh.to_str().unwrap(),
            "--resolution",
            "4096",
            "-o",
            out.to_str().unwrap(),
        ]);
        let message = refused(&o, &BUDGET);
        assert!(message.contains("triceratops.obj: a grid of 4096 x "), "{message}");
        assert!((8..4096).contains(&largest(&message)), "{message}");
        assert!(!out.exists());
    }
}

#[test]
fn a_memory_limit_refuses_sdf_at_600_and_names_a_resolution_that_fits() {
    let dir = tempfile::tempdir().unwrap();
    // A cube fills its grid: 600^3 voxels (the triceratops at 600 fits in 1G).
    let mesh = dir.path().join("cube.obj");
    let corners = (0..8).map(|c| format!("v {} {} {}\n", c & 1, c >> 1 & 1, c >> 2 & 1));
    let faces = "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    std::fs::write(&mesh, corners.collect::<String>() + faces).unwrap();
    let out = dir.path().join("out.npy");
    let args = |r: &str| {
        let out = out.to_str().unwrap();
        let args = ["sdf", mesh.to_str().unwrap(), "--resolution", r, "-o", out];
        args.into_iter()
            .chain(["--memory-limit", "1G", "--quiet"])
            .map(String::from)
            .collect::<Vec<_>>()
    };
    let o = Command::new(bin()).args(args("600")).output().unwrap();
    let message = refused(&o, &BUDGET);
    assert!(message.contains("memory limit of 1.0 GB"), "{message}");
    let fits = largest(&message);
    assert!((100..600).contains(&fits), "{message}");
    // One more than the largest resolution named does not fit; a small one runs.
    let o = Command::new(bin()).args(args(&(fits + 1).to_string())).output().unwrap();
    refused(&o, &BUDGET);
    let o = Command::new(bin()).args(args("64")).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn under_an_address_space_limit_the_refusal_comes_instead_of_an_abort() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.npy");
    let script = format!(
        "ulimit -v 2000000; exec '{}' sdf '{}' --resolution 1500 -o '{}'",
        bin(),
        triceratops().display(),
        out.display()
    );
    let o = Command::new("sh").args(["-c", &script]).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!stderr.contains("memory allocation"), "{stderr}");
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    let refusal = stderr.lines().last().unwrap();
    for part in BUDGET {
        assert!(refusal.contains(part), "{part:?} not in {stderr}");
    }
}

#[test]
fn a_batch_under_an_address_space_limit_lists_each_refusal_and_writes_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let lib = dir.path().join("lib");
    std::fs::create_dir(&lib).unwrap();
    for name in ["a.obj", "b.obj"] {
        std::fs::copy(triceratops(), lib.join(name)).unwrap();
    }
    let out = dir.path().join("out");
    let script = format!(
        "ulimit -v 3000000; exec '{}' batch '{}' -o '{}' --resolution 4096 --jobs 2 --quiet",
        bin(),
        lib.display(),
        out.display()
    );
    let o = Command::new("sh").args(["-c", &script]).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked") && !stderr.contains("memory allocation"), "{stderr}");
    let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap();
    for line in manifest.lines() {
        let entry: serde_json::Value = serde_json::from_str(line).unwrap();
        assert_eq!(entry["status"], "failed");
        let error = entry["error"].as_str().unwrap();
        for part in BUDGET {
            assert!(error.contains(part), "{part:?} not in {error}");
        }
        assert!((8..4096).contains(&largest(error)), "{error}");
    }
    let files: Vec<_> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(files, ["manifest.jsonl"], "nothing but the manifest is written");
}

#[test]
fn polygonizing_and_pictures_are_budgeted_too() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("ball.json");
    let csv = dir.path().join("ball.csv");
    std::fs::write(
        &csv,
        "x,y,z,value\n0,0,0,1\n1,0,0,0\n-1,0,0,0\n0,1,0,0\n0,-1,0,0\n0,0,1,0\n0,0,-1,0\n",
    )
    .unwrap();
    assert!(run(&["solve", csv.to_str().unwrap(), "-o", model.to_str().unwrap()]).status.success());
    let out = dir.path().join("ball.obj");
    let o = run(&[
        "mesh",
        model.to_str().unwrap(),
        "--resolution",
        "4096",
        "--dense",
        "-o",
        out.to_str().unwrap(),
        "--memory-limit",
        "1G",
    ]);
    refused(&o, &["ball.json: a grid of 4096 x 4096 x 4096 voxels", BUDGET[0], BUDGET[2]]);
    let png = dir.path().join("ball.png");
    let o = run(&[
        "render",
        model.to_str().unwrap(),
        "--size",
        "8000",
        "8000",
        "-o",
        png.to_str().unwrap(),
        "--memory-limit",
        "1G",
    ]);
    refused(&o, &["ball.png: a picture of 8000 x 8000 pixels", BUDGET[0], BUDGET[1]]);
    assert!(!out.exists() && !png.exists());
}

#[test]
fn a_bad_memory_limit_is_refused() {
    let o = run(&["sdf", triceratops().to_str().unwrap(), "-o", "x.npy", "--memory-limit", "lots"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("memory size \"lots\""));
}

#[test]
fn a_ply_header_claiming_more_than_the_file_holds_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (format, claim) in [("binary_little_endian", "4000000000"), ("ascii", "900000000")] {
        let path = dir.path().join(format!("{format}.ply"));
        let header = format!(
            "ply\nformat {format} 1.0\nelement vertex {claim}\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        );
        std::fs::write(&path, header + "0 0 0\n").unwrap();
        let o =
            run(&["sdf", path.to_str().unwrap(), "-o", dir.path().join("o.npy").to_str().unwrap()]);
        refused(&o, &[&format!("{format}.ply: the header declares {claim} 'vertex' elements")]);
    }
}

#[test]
fn a_numpy_header_claiming_more_than_the_file_holds_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("ball.json");
    let csv = dir.path().join("ball.csv");
    std::fs::write(
        &csv,
        "x,y,z,value\n0,0,0,1\n1,0,0,0\n-1,0,0,0\n0,1,0,0\n0,-1,0,0\n0,0,1,0\n0,0,-1,0\n",
    )
    .unwrap();
    assert!(run(&["solve", csv.to_str().unwrap(), "-o", model.to_str().unwrap()]).status.success());
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    let mut header =
        "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000, 3), }".to_string();
    while !(10 + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    npy.extend_from_slice(&(header.len() as u16).to_le_bytes());
    npy.extend_from_slice(header.as_bytes());
    npy.extend_from_slice(&[0u8; 48]);
    let points = dir.path().join("points.npy");
    std::fs::write(&points, npy).unwrap();
    let out = dir.path().join("values.npy");
    let o = run(&[
        "eval",
        model.to_str().unwrap(),
        "--points",
        points.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    refused(&o, &["points.npy: the header's shape [1000000000000, 3] needs 24000000000000 bytes"]);
}

#[test]
fn a_png_declaring_more_pixels_than_its_bytes_hold_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.png");
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, 4000, 4000);
        encoder.set_color(png::ColorType::Grayscale);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(&vec![255u8; 4000 * 4000]).unwrap();
    }
    bytes.truncate(2000);
    std::fs::write(&path, bytes).unwrap();
    let o =
        run(&["fit2d", path.to_str().unwrap(), "-o", dir.path().join("m.json").to_str().unwrap()]);
    refused(
        &o,
        &["huge.png: the header declares 4000 x 4000 pixels", "more than its 2000 bytes can hold"],
    );
}
