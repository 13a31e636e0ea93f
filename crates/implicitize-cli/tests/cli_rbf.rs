//! `implicitize solve` and `implicitize eval` through the command line.

use std::path::Path;
use std::process::{Command, Output};

use implicitize_test_support::data::test_data;

fn implicitize(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_implicitize")).args(args).output().unwrap()
}

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn read_vector(path: &Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    assert_eq!(npy.shape(), &[2000]);
    npy.into_vec::<f64>().unwrap()
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

#[test]
fn solve_then_eval_matches_scipy_on_the_bunny() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("bunny.json");
    let out = implicitize(&["solve", s(&test_data("bunny_constraints.csv")), "-o", s(&model)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("solved 700 constraints"), "{}", stderr(&out));
    let values = dir.path().join("values.npy");
    let out = implicitize(&[
        "eval",
        s(&model),
        "--points",
        s(&test_data("bunny_points.npy")),
        "-o",
        s(&values),
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(out.stderr.is_empty(), "--quiet prints nothing");
    let ours = read_vector(&values);
    let scipy = read_vector(&test_data("bunny_scipy_values.npy"));
    let reference = scipy.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let worst = ours.iter().zip(&scipy).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst <= 1e-6 * reference, "{worst:e}");
    // float32 points and CSV points give the values at those points.
    let (points, _) = implicitize::npy::read_rows(&test_data("bunny_points.npy")).unwrap();
    let f32_points = dir.path().join("points32.npy");
    let rounded: Vec<f32> = points.iter().map(|&v| v as f32).collect();
    implicitize::npy::write(&f32_points, &[2000, 3], &rounded).unwrap();
    let csv_points = dir.path().join("points.csv");
    let mut text = String::from("x,y,z\n");
    for p in rounded.chunks(3) {
        let [x, y, z] = [p[0], p[1], p[2]].map(f64::from);
        text += &format!("{x},{y},{z}\n");
    }
    std::fs::write(&csv_points, text).unwrap();
    let loaded = implicitize::model::Model::load(&model).unwrap();
    let direct = loaded
        .implicit()
        .unwrap()
        .values_flat(&rounded.iter().map(|&v| f64::from(v)).collect::<Vec<_>>());
    for points in [&f32_points, &csv_points] {
        let out = implicitize(&["eval", s(&model), "--points", s(points), "-o", s(&values)]);
        assert!(out.status.success(), "{}", stderr(&out));
        assert!(read_vector(&values) == direct, "{} gives other values", points.display());
    }
}

#[test]
fn kernels_are_chosen_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.json");
    for kernel in ["r2logr", "r3", "r"] {
        let out = implicitize(&[
            "solve",
            s(&test_data("bunny_constraints.csv")),
            "-o",
            s(&model),
            "--kernel",
            kernel,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&model).unwrap()).unwrap();
        assert_eq!(json["shape"]["kernel"], kernel);
    }
    let out = implicitize(&[
        "solve",
        s(&test_data("bunny_constraints.csv")),
        "-o",
        s(&model),
        "--kernel",
        "gauss",
    ]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("unknown kernel"), "{}", stderr(&out));
}

#[test]
fn bad_input_gives_one_clear_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("bad.csv");
    let model = dir.path().join("m.json");
    let check = |out: Output, want: &[&str]| {
        assert!(!out.status.success());
        let message = stderr(&out);
        assert_eq!(message.lines().count(), 1, "{message}");
        for w in want {
            assert!(message.contains(w), "expected {w:?} in {message}");
        }
    };
    std::fs::write(&csv, "x,y,z,value\n0,0,0,0\n1,0,0,zero\n").unwrap();
    check(
        implicitize(&["solve", s(&csv), "-o", s(&model)]),
        &["bad.csv", "line 3", "not a number"],
    );
    std::fs::write(&csv, "x,y,z,value\n0,0,0,0\n1,0,0,0\n0,1,0,1\n0,0,1,-1\n1,0,0,1\n").unwrap();
    check(
        implicitize(&["solve", s(&csv), "-o", s(&model)]),
        &["bad.csv", "constraints 2 and 5", "coincide"],
    );
    std::fs::write(&csv, "x,y,z,value\n0,0,0,0\n1,0,0,0\n0,1,0,1\n").unwrap();
    check(implicitize(&["solve", s(&csv), "-o", s(&model)]), &["bad.csv", "affinely independent"]);
    // A 2D model and 3D points.
    std::fs::write(&csv, "x,y,value\n0,0,0\n1,0,0\n0,1,1\n1,1,-1\n").unwrap();
    let out = implicitize(&["solve", s(&csv), "-o", s(&model)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let values = dir.path().join("v.npy");
    check(
        implicitize(&[
            "eval",
            s(&model),
            "--points",
            s(&test_data("bunny_points.npy")),
            "-o",
            s(&values),
        ]),
        &["bunny_points.npy", "3 coordinates", "2D model"],
    );
    std::fs::write(&model, "{\"format\": \"implicitize-model\", \"version\": 9}").unwrap();
    check(
        implicitize(&[
            "eval",
            s(&model),
            "--points",
            s(&test_data("bunny_points.npy")),
            "-o",
            s(&values),
        ]),
        &["m.json", "version 9"],
    );
    check(implicitize(&["eval", s(&model), "--points", s(&csv), "-o", s(&values)]), &["m.json"]);
}
