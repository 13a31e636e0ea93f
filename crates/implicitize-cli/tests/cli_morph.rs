//! `implicitize morph`: frames and a strip from two fitted models, and its errors.

use std::process::Command;

use implicitize::model::Model;
use implicitize::{DVec3, grid::Resolution, pipeline::MeshFitOptions};
use implicitize_test_support::meshes::{sphere, torus};
use implicitize_test_support::topology;

/// Fits `mesh` at a small resolution.
fn fitted(mesh: &implicitize::mesh::Mesh) -> Model {
    let mut options = MeshFitOptions::default();
    options.resolution = Resolution::LongestAxis(40);
    options.fit.max_iterations = 12;
    implicitize::pipeline::fit_mesh(mesh, &options).unwrap().model
}

/// A sphere of radius 1.5 and a torus of radii 2 and 0.7 around z, both at the origin.
fn sphere_and_torus() -> (Model, Model) {
    let sphere = fitted(&sphere(DVec3::ZERO, 1.5, 32, 64));
    let torus = fitted(&torus(2.0, 0.7, 96, 48));
    (sphere, torus)
}
fn implicitize() -> Command {
    Command::new(env!("CARGO_BIN_EXE_implicitize"))
}

#[test]
fn the_command_line_writes_frames_and_a_strip() {
    let (sphere, torus) = sphere_and_torus();
    let dir = tempfile::tempdir().unwrap();
    let (a, b, out) =
        (dir.path().join("a.json"), dir.path().join("b.json"), dir.path().join("frames"));
    sphere.save(&a).unwrap();
    torus.save(&b).unwrap();
    let status = implicitize()
        .arg("morph")
        .args([&a, &b])
        .args([
            "--steps",
            "3",
            "--method",
            "variational",
            "--align",
            "--resolution",
            "40",
            "--strip-width",
            "64",
            "-q",
            "-o",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    for i in 0..3 {
        let (mesh, _) = implicitize::mesh::read(&out.join(format!("frame-{i:03}.ply"))).unwrap();
        topology::assert_closed(&mesh, &format!("frame {i}"));
    }
    assert!(!out.join("frame-003.ply").exists());
    let strip = std::fs::read(out.join("strip.png")).unwrap();
    assert_eq!(&strip[1..4], b"PNG");
    // The strip is three 64 x 48 pictures side by side: width and height in the IHDR chunk.
    assert_eq!(u32::from_be_bytes(strip[16..20].try_into().unwrap()), 3 * 64);
    assert_eq!(u32::from_be_bytes(strip[20..24].try_into().unwrap()), 48);

    let fails = |args: &[&str], want: &[&str]| {
        let o = implicitize()
            .arg("morph")
            .args([&a, &b])
            .args(args)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{args:?} should fail");
        let e = String::from_utf8_lossy(&o.stderr);
        for w in want {
            assert!(e.contains(w), "{args:?}: {e} does not say {w}");
        }
    };
    fails(&["--steps", "1"], &["at least 2"]);
    fails(&["--steps", "3", "--method", "sideways"], &["sideways", "blend"]);
    let o = implicitize()
        .arg("morph")
        .arg(&a)
        .arg(dir.path().join("missing.json"))
        .args(["--steps", "3", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.json"));
}
