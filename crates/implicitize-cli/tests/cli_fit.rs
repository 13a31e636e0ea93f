//! `implicitize fit` and `implicitize demo` through the command line, on the vendored triceratops.

use std::path::Path;
use std::process::Command;

use implicitize_test_support::data::triceratops;

fn implicitize() -> Command {
    Command::new(env!("CARGO_BIN_EXE_implicitize"))
}

#[test]
fn fit_writes_the_model_the_report_and_the_surface() {
    let dir = tempfile::tempdir().unwrap();
    let (model, report, surface) =
        (dir.path().join("t.json"), dir.path().join("r.json"), dir.path().join("t.ply"));
    let out = implicitize()
        .arg("fit")
        .arg(triceratops())
        .args(["--resolution", "64", "--quiet", "-o"])
        .arg(&model)
        .arg("--report")
        .arg(&report)
        .arg("--mesh-out")
        .arg(&surface)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    for key in [
        "iterations",
        "constraints",
        "max_error_voxels",
        "weighted_error",
        "rms_error_voxels",
        "timings_s",
        "dims",
        "origin",
        "voxel_size",
        "per_iteration",
        "model_bytes",
        "mesh_bytes",
    ] {
        assert!(report.get(key).is_some(), "the report has no {key}");
    }
    assert_eq!(report["version"].as_u64(), Some(u64::from(implicitize::fit::REPORT_VERSION)));
    // The initialization alone puts boundary constraints on the surface and interior and
    // exterior ones on either side of it (paper 5.1).
    for key in ["boundary", "interior", "exterior"] {
        let count = report["constraints"][key].as_u64().unwrap();
        assert!(count > 0, "{count} {key} constraints");
    }
    assert_eq!(
        report["per_iteration"].as_array().unwrap().len() as u64,
        report["iterations"].as_u64().unwrap()
    );
    assert!(report["per_iteration"].as_array().unwrap().iter().all(|i| i["grid"] == "full"));
    assert!(report["max_error_voxels"].as_f64().unwrap() <= 3.0);
    let model_bytes = report["model_bytes"].as_u64().unwrap();
    assert!(
        model_bytes < report["mesh_bytes"].as_u64().unwrap(),
        "the model is smaller than the mesh"
    );
    let (mesh, _) = implicitize::mesh::read(&surface).unwrap();
    assert!(mesh.triangles.len() > 1000);
    implicitize::model::Model::load(&model).unwrap();
    // The mesh against the written surface, both ways, in voxels; the model file keeps them.
    let embedded: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&model).unwrap()).unwrap();
    for way in ["mesh_to_model", "model_to_mesh"] {
        let figures = &report["mesh_distance"][way];
        let [max, p999, mean] = ["max", "p99.9", "mean"].map(|key| {
            figures[key].as_f64().unwrap_or_else(|| panic!("no {way}.{key} in {figures}"))
        });
        assert!(0.0 < mean && mean < 1.0 && mean <= p999 && p999 <= max, "{way}: {figures}");
        assert_eq!(&embedded["report"]["mesh_distance"][way], figures);
    }
}

/// The grid of each iteration of a fit of two iterations at 128 voxels, with and without
/// `--full-resolution`; the report's reason for stopping is the iteration limit.
fn grids_at_128(flags: &[&str]) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("r.json");
    let out = implicitize()
        .arg("fit")
        .arg(triceratops())
        .args(["--resolution", "128", "--max-iterations", "2", "--quiet", "-o"])
        .arg(dir.path().join("t.json"))
        .arg("--report")
        .arg(&report)
        .args(flags)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    // Two iterations cannot reach E 2 on this grid: the report says the limit stopped the fit.
    assert_eq!(report["termination"], serde_json::json!({"reason": "iteration_limit", "limit": 2}));
    let iterations = report["per_iteration"].as_array().unwrap();
    iterations.iter().map(|i| i["grid"].as_str().unwrap().to_string()).collect()
}

#[test]
fn a_large_grid_starts_at_half_the_resolution_unless_told_not_to() {
    // The start at half the resolution leaves at least a quarter of the iterations to the full grid.
    assert_eq!(grids_at_128(&[]), ["half", "full"]);
    assert_eq!(grids_at_128(&["--full-resolution"]), ["full", "full"]);
}

#[test]
fn fit_of_a_missing_file_fails_with_one_line_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = implicitize()
        .args(["fit", "no-such-mesh.obj", "-o"])
        .arg(dir.path().join("m.json"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no-such-mesh.obj"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
}

#[test]
fn fit_of_a_flat_mesh_fails_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let flat = dir.path().join("flat.obj");
    std::fs::write(&flat, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n").unwrap();
    let out = implicitize()
        .arg("fit")
        .arg(&flat)
        .arg("-o")
        .arg(dir.path().join("m.json"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("flat.obj"), "{stderr}");
}

/// The demo's grid at 48 voxels leaves a third of the triceratops on walls about 3 voxels
/// thick: the fit goes ahead and warns on stderr, even with --quiet, naming a flag that holds
/// them.
#[test]
fn demo_writes_into_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    let out = implicitize()
        .args(["demo", "--resolution", "48", "--max-iterations", "3", "--quiet", "-o"])
        .arg(dir.path().join("demo"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.starts_with("warning: triceratops.obj (built in): "), "{stderr}");
    assert!(stderr.contains("voxels thick") && stderr.contains("--resolution "), "{stderr}");
    for file in ["model.imp", "report.json", "surface.ply"] {
        assert!(dir.path().join("demo").join(file).is_file(), "no {file}");
    }
}

#[test]
fn the_same_mesh_and_seed_give_the_same_model_file_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let fit = |name: &str, seed: &str| {
        let path = dir.path().join(name);
        let out = implicitize()
            .arg("fit")
            .arg(triceratops())
            .args(["--resolution", "56", "--quiet", "--seed", seed, "-o"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        std::fs::read(path).unwrap()
    };
    assert_eq!(fit("a.json", "1"), fit("b.json", "1"));
    assert_ne!(fit("a.json", "1"), fit("c.json", "2"));
}

/// Fits the triceratops at the default resolution with `IMPLICITIZE_ISA` set to `isa` (or
/// unset), and returns the report.
fn fit_with_isa(dir: &Path, isa: Option<&str>) -> serde_json::Value {
    let name = isa.unwrap_or("default");
    let (model, report) = (dir.join(format!("{name}.json")), dir.join(format!("{name}-r.json")));
    let mut command = implicitize();
    command.env_remove(implicitize::rbf::ISA_ENV);
    if let Some(isa) = isa {
        command.env(implicitize::rbf::ISA_ENV, isa);
    }
    let out = command
        .arg("fit")
        .arg(triceratops())
        .args(["--quiet", "-o"])
        .arg(&model)
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    assert!(out.status.success(), "{name}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap()
}

/// The portable loops (`IMPLICITIZE_ISA=baseline`) fit the triceratops as well as the loops
/// this CPU runs best do: E at most 2 voxels both, with constraint counts within 5% of each
/// other. Not the same model: each level's f32 loop of the volume passes has its own logarithm
/// and rounding, within a hundredth of a voxel of each other (`tests/fit.rs`), which is enough
/// to tip the choice of a candidate here and there.
#[test]
fn the_baseline_loops_fit_the_triceratops_as_well_as_the_default_ones() {
    let dir = tempfile::tempdir().unwrap();
    let baseline = fit_with_isa(dir.path(), Some("baseline"));
    let default = fit_with_isa(dir.path(), None);
    let count = |report: &serde_json::Value| {
        let c = &report["constraints"];
        ["boundary", "interior", "exterior"].iter().map(|k| c[k].as_f64().unwrap()).sum::<f64>()
    };
    for (name, report) in [("baseline", &baseline), ("default", &default)] {
        let e = report["max_error_voxels"].as_f64().unwrap();
        assert!(e <= 2.0, "{name}: E = {e}");
    }
    let (a, b) = (count(&baseline), count(&default));
    assert!((a - b).abs() <= 0.05 * a.max(b), "{a} constraints against {b}");
}

/// `IMPLICITIZE_ISA` naming no instruction set, or one this CPU lacks, is a one-line error with
/// exit status 1, whatever the command.
#[test]
fn an_unknown_or_unsupported_isa_is_a_one_line_error() {
    use implicitize::rbf::{Isa, IsaLevel};
    let lacking = IsaLevel::ALL.into_iter().filter(|&l| Isa::supported(l).is_none());
    let values: Vec<&str> = ["sse9"].into_iter().chain(lacking.map(IsaLevel::name)).collect();
    for value in values {
        let dir = tempfile::tempdir().unwrap();
        let out = implicitize()
            .env(implicitize::rbf::ISA_ENV, value)
            .arg("fit")
            .arg(triceratops())
            .args(["--resolution", "32", "-o"])
            .arg(dir.path().join("m.json"))
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{value}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(&format!("IMPLICITIZE_ISA={value}")), "{stderr}");
        assert!(!dir.path().join("m.json").exists());
    }
}

/// Fits the triceratops at `resolution` into `dir/name` with `flags`; the report.
fn fit_to(dir: &Path, name: &str, flags: &[&str]) -> (std::process::Output, serde_json::Value) {
    let report = dir.join(format!("{name}.report.json"));
    let out = implicitize()
        .arg("fit")
        .arg(triceratops())
        .args(flags)
        .arg("--quiet")
        .arg("-o")
        .arg(dir.join(name))
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    let report = std::fs::read(&report)
        .map_or(serde_json::Value::Null, |bytes| serde_json::from_slice(&bytes).unwrap());
    (out, report)
}

#[test]
fn fit_writes_binary_unless_the_name_or_the_format_says_json() {
    let dir = tempfile::tempdir().unwrap();
    let flags = ["--resolution", "64"];
    let (out, report) = fit_to(dir.path(), "t.imp", &flags);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let binary = std::fs::read(dir.path().join("t.imp")).unwrap();
    assert!(binary.starts_with(implicitize::model::BINARY_MAGIC));
    assert_eq!(report["model_bytes"].as_u64(), Some(binary.len() as u64));
    let (out, _) = fit_to(dir.path(), "t.json", &flags);
    assert!(out.status.success());
    let (out, _) = fit_to(dir.path(), "t.model", &[&flags[..], &["--format", "json"]].concat());
    assert!(out.status.success());
    let json = std::fs::read(dir.path().join("t.json")).unwrap();
    assert!(json.starts_with(b"{"));
    assert_eq!(json, std::fs::read(dir.path().join("t.model")).unwrap());
    // The two files hold the same function: equal values, bit for bit.
    let [a, b] =
        ["t.imp", "t.json"].map(|n| implicitize::model::Model::load(&dir.path().join(n)).unwrap());
    let bounds = a.bounds();
    let points: Vec<_> =
        (0..=20).map(|i| bounds.min + (bounds.max - bounds.min) * (f64::from(i) / 20.0)).collect();
    use implicitize::Field;
    assert_eq!(a.values(&points), b.values(&points));
}

#[test]
fn a_byte_budget_writes_a_model_within_it_and_says_what_it_chose() {
    let dir = tempfile::tempdir().unwrap();
    let (out, report) = fit_to(dir.path(), "t.imp", &["--max-bytes", "1500"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::metadata(dir.path().join("t.imp")).unwrap().len();
    assert!(bytes <= 1500, "{bytes} bytes");
    let budget = &report["byte_budget"];
    assert_eq!(budget["max_bytes"], 1500);
    let tried = budget["tried"].as_array().unwrap();
    assert!(tried.len() >= 2, "the default fit is larger than 1500 bytes: {budget}");
    let chosen = &tried[budget["chosen"].as_u64().unwrap() as usize];
    assert_eq!(chosen["bytes"].as_u64(), Some(bytes));
    assert_eq!(chosen["resolution"].as_u64(), report["dims"][0].as_u64());
}

#[test]
fn a_byte_budget_no_model_fits_in_is_refused_naming_the_smallest() {
    let dir = tempfile::tempdir().unwrap();
    let (out, _) = fit_to(dir.path(), "t.imp", &["--max-bytes", "100"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("no model fits in 100 bytes: the smallest is "), "{stderr}");
    assert!(!dir.path().join("t.imp").exists());
}

/// Every command that reads a model reads the binary file, and gives the same output from it
/// as from the same model written as JSON (the two evaluate bit for bit alike).
#[test]
fn every_consumer_reads_the_binary_model_as_it_reads_json() {
    let dir = tempfile::tempdir().unwrap();
    let (out, _) = fit_to(dir.path(), "t.imp", &["--resolution", "48"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let model = implicitize::model::Model::load(&dir.path().join("t.imp")).unwrap();
    model.save_as(&dir.path().join("t.json"), implicitize::model::ModelFormat::Json).unwrap();
    let points = dir.path().join("points.csv");
    std::fs::write(&points, "x,y,z\n0,0,0\n1,2,3\n-2,0.5,1\n").unwrap();
    let outputs = |stem: &str| -> String {
        let d = dir.path().join(stem);
        std::fs::create_dir_all(&d).unwrap();
        let m = dir.path().join(format!("t.{stem}"));
        let m = m.to_str().unwrap();
        let d = d.to_str().unwrap();
        let p = points.to_str().unwrap();
        let commands: [Vec<String>; 7] = [
            ["eval", m, "--points", p, "-o", &format!("{d}/values.npy")].map(String::from).into(),
            ["mesh", m, "--resolution", "40", "-o", &format!("{d}/surface.ply")]
                .map(String::from)
                .into(),
            ["render", m, "--size", "64", "48", "-o", &format!("{d}/picture.png")]
                .map(String::from)
                .into(),
            ["view", m, "-o", &format!("{d}/page.html")].map(String::from).into(),
            ["export", m, "--format", "glsl", "-o", &format!("{d}/shader.glsl")]
                .map(String::from)
                .into(),
            ["csg", "union", m, m, "--blend", "0.5", "-o", &format!("{d}/union.json")]
                .map(String::from)
                .into(),
            ["morph", m, m, "--steps", "2", "--resolution", "24", "-o", &format!("{d}/morph")]
                .map(String::from)
                .into(),
        ];
        for args in &commands {
            let out = implicitize().args(args).arg("--quiet").output().unwrap();
            assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
        }
        d.to_string()
    };
    let (binary, json) = (outputs("imp"), outputs("json"));
    for file in ["values.npy", "surface.ply", "picture.png", "union.json", "morph/frame-001.ply"] {
        let read = |d: &str| std::fs::read(Path::new(d).join(file)).unwrap();
        assert!(read(&binary) == read(&json), "{file} differs between t.imp and t.json");
    }
    // The page and the shader name the model file they were made from, and the page its size.
    for file in ["page.html", "shader.glsl"] {
        let read =
            |d: &str| without_file_size(&std::fs::read_to_string(Path::new(d).join(file)).unwrap());
        assert_eq!(read(&binary).replace("t.imp", "t.json"), read(&json), "{file}");
    }
}

/// The text with the digits after each `"bytes":` taken out.
fn without_file_size(text: &str) -> String {
    let mut parts = text.split("\"bytes\":");
    let mut out = parts.next().unwrap_or_default().to_string();
    for part in parts {
        out.push_str(part.trim_start_matches(|c: char| c.is_ascii_digit()));
    }
    out
}
