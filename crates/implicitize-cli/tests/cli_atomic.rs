//! Outputs are never half-written: `fit`, `sdf` and `mesh` killed (SIGKILL) at random moments,
//! 50 times each, leave every output path absent or complete and loadable, and never remove a
//! previous complete output before the new one is complete. Output folders are checked before
//! the work starts.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use implicitize::model::Model;
use implicitize_test_support::data::triceratops;

/// Kills per command.
const KILLS: usize = 50;

fn command(args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_implicitize"));
    command.args(args).arg("--quiet").stdout(Stdio::null()).stderr(Stdio::null());
    command
}

/// A small deterministic generator (xorshift64*), for the moments of the kills.
struct Moments(u64);

impl Moments {
    /// A uniform fraction in [0, 1).
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// How long one whole run of `args` takes here; it must succeed.
fn full_run(args: &[&str]) -> Duration {
    let start = Instant::now();
    let status = command(args).status().unwrap();
    assert!(status.success(), "{args:?} failed");
    start.elapsed()
}

/// Runs `args` `KILLS` times, each killed after a random fraction of 1.3 times a full run
/// (some runs end first), and calls `check` on the outputs after each; every other run starts
/// from the complete outputs of a full run, which must then still be there.
fn kill_at_random(args: &[&str], outputs: &[&Path], seed: u64, check: impl Fn(&Path)) {
    let full = full_run(args);
    let mut moments = Moments(seed);
    for run in 0..KILLS {
        let keep_previous = run % 2 == 1;
        if keep_previous {
            full_run(args);
        } else {
            outputs.iter().filter(|p| p.exists()).for_each(|p| std::fs::remove_file(p).unwrap());
        }
        let mut child = command(args).spawn().unwrap();
        std::thread::sleep(full.mul_f64(1.3 * moments.next()));
        let _ = child.kill();
        child.wait().unwrap();
        for path in outputs {
            assert!(!keep_previous || path.exists(), "run {run}: {} removed", path.display());
            if path.exists() {
                check(path);
            }
        }
    }
}

/// The number of files in `dir`, temporary ones included.
fn entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

fn check_mesh(path: &Path) {
    let (mesh, _) = implicitize::mesh::read(path)
        .unwrap_or_else(|e| panic!("{} is not a complete mesh: {e}", path.display()));
    assert!(mesh.triangles.len() > 100, "{}: {} triangles", path.display(), mesh.triangles.len());
}

fn check_json(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("{} is not complete JSON: {e}", path.display()));
    assert!(value.is_object(), "{}", path.display());
}

fn check_fit_output(path: &Path) {
    match path.extension().and_then(|e| e.to_str()) {
        Some("ply") => check_mesh(path),
        _ if path.file_name().is_some_and(|n| n == "model.imp") => {
            let model = Model::load(path)
                .unwrap_or_else(|e| panic!("{} is not a complete model: {e}", path.display()));
            assert!(model.implicit().is_some_and(|f| f.len() > 10));
        }
        _ => check_json(path),
    }
}

fn check_volume_output(path: &Path) {
    if path.extension().is_some_and(|e| e == "json") {
        return check_json(path);
    }
    let bytes = std::fs::read(path).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..])
        .unwrap_or_else(|e| panic!("{} is not a complete .npy: {e}", path.display()));
    let voxels: u64 = npy.shape().iter().product();
    let data = npy.into_vec::<f32>().unwrap();
    assert_eq!(data.len() as u64, voxels);
    assert_eq!(voxels, 128 * 60 * 48, "{}", path.display());
}

#[test]
fn fit_killed_at_random_leaves_complete_outputs_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let [model, report, surface] =
        ["model.imp", "report.json", "surface.ply"].map(|n| dir.path().join(n));
    let mesh = triceratops();
    let args = [
        "fit",
        mesh.to_str().unwrap(),
        "--resolution",
        "48",
        "-o",
        model.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
        "--mesh-out",
        surface.to_str().unwrap(),
    ];
    kill_at_random(&args, &[&model, &report, &surface], 1, check_fit_output);
}

#[test]
fn sdf_killed_at_random_leaves_complete_outputs_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let volume = dir.path().join("sdf.npy");
    let mesh = triceratops();
    let args =
        ["sdf", mesh.to_str().unwrap(), "--resolution", "128", "-o", volume.to_str().unwrap()];
    kill_at_random(&args, &[&volume, &volume.with_extension("json")], 2, check_volume_output);
}

#[test]
fn mesh_killed_at_random_leaves_a_complete_mesh_or_none() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.json");
    let mesh = triceratops();
    let fit = ["fit", mesh.to_str().unwrap(), "--resolution", "40", "-o", model.to_str().unwrap()];
    full_run(&fit);
    let out = dir.path().join("surface.ply");
    let args =
        ["mesh", model.to_str().unwrap(), "--resolution", "128", "-o", out.to_str().unwrap()];
    kill_at_random(&args, &[&out], 3, check_mesh);
}

#[test]
fn a_missing_output_folder_fails_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("missing/model.json");
    let mesh = triceratops();
    // At 600 the fit would take many seconds; the refusal comes before the mesh is read.
    let o = command(&["fit", mesh.to_str().unwrap(), "--resolution", "600"])
        .args(["-o", model.to_str().unwrap()])
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("missing/model.json") && stderr.contains("does not exist"), "{stderr}");
    assert!(entries(dir.path()).is_empty());
}

#[test]
fn a_successful_run_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let volume = dir.path().join("v.npy");
    let mesh = triceratops();
    full_run(&[
        "sdf",
        mesh.to_str().unwrap(),
        "--resolution",
        "32",
        "-o",
        volume.to_str().unwrap(),
    ]);
    let mut names = entries(dir.path());
    names.sort();
    assert_eq!(names, ["v.json", "v.npy"]);
}
