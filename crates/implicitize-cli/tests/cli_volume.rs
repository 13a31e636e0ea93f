//! `implicitize voxelize` and `implicitize sdf` through the binary, on the built-in triceratops.

use std::path::Path;
use std::process::Command;

use implicitize_test_support::data::triceratops;

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_implicitize")).args(args).output().unwrap()
}

fn load(path: &Path) -> (Vec<u64>, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    assert_eq!(npy.order(), npyz::Order::C);
    (npy.shape().to_vec(), npy.into_vec::<f32>().unwrap())
}

fn grid_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path.with_extension("json")).unwrap()).unwrap()
}

#[test]
fn voxelize_writes_densities_and_the_grid() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("density.npy");
    let mesh = triceratops();
    let o = run(&[
        "voxelize",
        mesh.to_str().unwrap(),
        "--resolution",
        "48",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (shape, data) = load(&out);
    assert_eq!(*shape.iter().max().unwrap(), 48);
    assert_eq!(data.len() as u64, shape.iter().product::<u64>());
    let json = grid_json(&out);
    let dims: Vec<u64> =
        json["dims"].as_array().unwrap().iter().map(|d| d.as_u64().unwrap()).collect();
    assert_eq!(dims, shape);
    assert_eq!(json["version"].as_u64(), Some(u64::from(implicitize::grid::VOLUME_HEADER_VERSION)));
    assert!(
        json["voxel_size"].as_f64().unwrap() > 0.0 && json["origin"].as_array().unwrap().len() == 3
    );
    assert!(data.iter().all(|&d| (0.0..=1.0).contains(&d)));
    let (full, partial) = (
        data.iter().filter(|&&d| d == 1.0).count(),
        data.iter().filter(|&&d| d > 0.0 && d < 1.0).count(),
    );
    assert!(full > 1000 && partial > 500, "{full} inside, {partial} partial");
    // The margin of the grid is empty.
    let (ny, nz) = (shape[1] as usize, shape[2] as usize);
    assert!(data[..ny * nz].iter().all(|&d| d == 0.0));
}

#[test]
fn sdf_writes_the_signed_distance_on_an_exact_grid() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sd.npy");
    let mesh = triceratops();
    let o = run(&[
        "sdf",
        mesh.to_str().unwrap(),
        "--dims",
        "40",
        "24",
        "20",
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(o.stderr.is_empty() && o.stdout.is_empty());
    let (shape, sd) = load(&out);
    assert_eq!(shape, vec![40, 24, 20]);
    // Boundary voxels sit at +1/2 and their outside neighbours at -1/2; the deepest voxel is
    // well inside, the corners far outside.
    assert!(sd.iter().filter(|&&d| d == 0.5).count() > 100);
    assert!(sd.iter().filter(|&&d| d == -0.5).count() > 100);
    assert!(sd.iter().cloned().fold(f32::MIN, f32::max) > 1.5);
    assert!(sd[0] < -3.0 && sd.iter().all(|d| d.is_finite() && (d.abs() >= 0.5)));
}

#[test]
fn errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.obj");
    let out = dir.path().join("x.npy");
    let o = run(&["sdf", missing.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.obj"));
    let unwritable = dir.path().join("no/such/dir/x.npy");
    let o = run(&[
        "voxelize",
        triceratops().to_str().unwrap(),
        "--resolution",
        "20",
        "-o",
        unwritable.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("x.npy"));
    let o = run(&[
        "voxelize",
        triceratops().to_str().unwrap(),
        "--resolution",
        "3",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("grid"));
}

#[test]
fn sdf_exact_writes_mesh_units_with_the_voxel_sdfs_sign_and_a_band() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = triceratops();
    let sdf = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec!["sdf", mesh.to_str().unwrap(), "--dims", "40", "24", "20"];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", out.to_str().unwrap(), "--quiet"]);
        let o = run(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (shape, values) = load(&out);
        assert_eq!(shape, vec![40, 24, 20]);
        (values, grid_json(&out))
    };
    let (voxels, voxels_json) = sdf("voxels.npy", &[]);
    let (exact, exact_json) = sdf("exact.npy", &["--exact"]);
    let (banded, banded_json) = sdf("banded.npy", &["--exact", "--band", "2"]);
    assert_eq!(voxels_json["units"], "voxels");
    assert!(voxels_json.get("band").is_none());
    assert_eq!(exact_json["units"], "mesh");
    assert_eq!(
        (banded_json["units"].as_str(), banded_json["band"].as_f64()),
        (Some("mesh"), Some(2.0))
    );
    assert_eq!(exact_json["dims"], voxels_json["dims"]);
    let h = exact_json["voxel_size"].as_f64().unwrap();
    // Mesh units: in voxels, the exact distance is near the voxel one (which measures the
    // voxelization, thin parts lost), half the voxels within half a voxel.
    let mut gaps: Vec<f64> = Vec::new();
    for (&e, &v) in exact.iter().zip(&voxels) {
        assert_eq!(e.is_sign_positive(), v > 0.0, "{e} against {v}");
        gaps.push((f64::from(e) / h - f64::from(v)).abs());
    }
    gaps.sort_by(f64::total_cmp);
    assert!(gaps[gaps.len() / 2] < 0.5, "median {} voxels", gaps[gaps.len() / 2]);
    let limit = (2.0 * h) as f32;
    for (&b, &e) in banded.iter().zip(&exact) {
        assert_eq!(b, e.clamp(-limit, limit));
    }
    assert!(banded.iter().filter(|b| b.abs() == limit).count() > 1000);
}

#[test]
fn sdf_band_without_exact_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sd.npy");
    let mesh = triceratops();
    let o = run(&["sdf", mesh.to_str().unwrap(), "--band", "2", "-o", out.to_str().unwrap()]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("--band") && stderr.contains("--exact"), "{stderr}");
    assert!(!out.exists());
}
