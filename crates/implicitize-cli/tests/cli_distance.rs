//! `implicitize distance` through the binary: a sphere and points at known distances.

use std::path::Path;
use std::process::Command;

use implicitize::{DVec3, mesh};
use implicitize_test_support::meshes::sphere;

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_implicitize")).args(args).output().unwrap()
}

fn load(path: &Path) -> (Vec<u64>, Vec<f64>) {
    let bytes = std::fs::read(path).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    (npy.shape().to_vec(), npy.into_vec::<f64>().unwrap())
}

#[test]
fn distances_signs_and_closest_points_of_a_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let ball = sphere(DVec3::ZERO, 1.0, 32, 64);
    mesh::write(Path::new(&path("ball.obj")), &ball).unwrap();
    // The poles and the equator's first vertex are vertices, so these distances are exact.
    std::fs::write(path("points.csv"), "x,y,z\n0,0,3\n0,0,-1.5\n2,0,0\n0,0,0.5\n").unwrap();
    let ball_obj = path("ball.obj");
    let args = ["distance", &ball_obj, "--points", &path("points.csv"), "-o"];
    let o = run(&[&args[..], &[&path("d.npy"), "--closest", &path("c.npy")]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (shape, d) = load(Path::new(&path("d.npy")));
    assert_eq!(shape, [4]);
    assert_eq!(&d[..3], &[-2.0, -0.5, -1.0]);
    assert!(d[3] > 0.49 && d[3] <= 0.5, "{d:?}");
    let (shape, c) = load(Path::new(&path("c.npy")));
    assert_eq!(shape, [4, 3]);
    let expected = [0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0];
    assert!(c.iter().zip(expected).all(|(c, e)| (c - e).abs() < 1e-15), "{c:?}");
    assert!((DVec3::from_slice(&c[9..]).length() - 1.0).abs() < 0.01);

    let o = run(&[&args[..], &[&path("u.npy"), "--unsigned"]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, u) = load(Path::new(&path("u.npy")));
    assert_eq!(u, d.iter().map(|v| v.abs()).collect::<Vec<_>>());

    std::fs::write(path("bad.csv"), "x,y,z\n0,0,oops\n").unwrap();
    let o = run(&["distance", &ball_obj, "--points", &path("bad.csv"), "-o", &path("b.npy")]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("bad.csv"), "{stderr}");
    assert!(!Path::new(&path("b.npy")).exists());
}
