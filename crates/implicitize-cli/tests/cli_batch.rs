//! `implicitize batch` through the binary: a folder of good, broken and unreadable meshes, the
//! manifest that lists every one, outputs equal to `fit` and `sdf`, and reruns that reuse
//! exactly the meshes whose input and options are unchanged.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use implicitize_test_support::data::triceratops;

fn run(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_implicitize")).args(args).output().unwrap()
}

fn p(s: &str) -> &Path {
    Path::new(s)
}

/// A folder with two good meshes (one in a subfolder), a broken OBJ, an empty STL, an
/// unreadable mesh (a link to nothing) and a file that is not a mesh.
fn library(dir: &Path) -> PathBuf {
    let lib = dir.join("library");
    std::fs::create_dir_all(lib.join("more")).unwrap();
    std::fs::copy(triceratops(), lib.join("good.obj")).unwrap();
    std::fs::copy(triceratops(), lib.join("more/other.obj")).unwrap();
    std::fs::write(lib.join("broken.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    std::fs::write(lib.join("empty.stl"), "solid nothing\nendsolid nothing\n").unwrap();
    std::os::unix::fs::symlink(dir.join("nowhere.ply"), lib.join("unreadable.ply")).unwrap();
    std::fs::write(lib.join("notes.txt"), "not a mesh").unwrap();
    lib
}

fn manifest(out: &Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap();
    text.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

fn batch(lib: &Path, out: &Path) -> Output {
    let args = [p("batch"), lib, p("-o"), out, p("--resolution"), p("40"), p("--sdf"), p("--jobs")];
    run(&[&args[..], &[p("2"), p("--quiet")]].concat())
}

#[test]
fn a_folder_with_bad_meshes_is_converted_and_every_mesh_listed() {
    let dir = tempfile::tempdir().unwrap();
    let (lib, out) = (library(dir.path()), dir.path().join("out"));
    let o = batch(&lib, &out);
    assert_eq!(o.status.code(), Some(1), "failures make the exit status 1");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("3 of 5 meshes failed"), "{stderr}");
    let entries = manifest(&out);
    let names: Vec<&str> = entries.iter().map(|e| e["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["broken", "empty", "good", "other", "unreadable"]);
    for e in &entries {
        let (input, status) = (e["input"].as_str().unwrap(), e["status"].as_str().unwrap());
        if input.ends_with(".obj") && !input.ends_with("broken.obj") {
            assert_eq!(status, "ok", "{e}");
            assert!(e["max_error_voxels"].as_f64().unwrap() <= 2.0);
            assert!(e["constraints"].as_u64().unwrap() > 0);
            assert_eq!(e["watertight"], true);
            assert_eq!(e["winding_near_half"], 0.0);
        } else {
            assert_eq!(status, "failed", "{e}");
            let error = e["error"].as_str().unwrap();
            assert!(error.starts_with(input), "the error names the file: {error}");
        }
    }
    let error = |name: &str| entries.iter().find(|e| e["name"] == name).unwrap()["error"].clone();
    assert!(error("broken").as_str().unwrap().contains("(line 4): vertex index 9 out of range"));
    assert!(
        error("empty").as_str().unwrap().contains("the file has no faces"),
        "{}",
        error("empty")
    );
    assert!(error("unreadable").as_str().unwrap().contains("No such file"));
}

#[test]
fn outputs_equal_fit_and_sdf_and_a_rerun_skips_them() {
    let dir = tempfile::tempdir().unwrap();
    let (lib, out) = (library(dir.path()), dir.path().join("out"));
    batch(&lib, &out);
    let good = lib.join("good.obj");
    let (model, sdf) = (dir.path().join("fit.imp"), dir.path().join("sdf.npy"));
    let r = p("--resolution");
    assert!(run(&[p("fit"), &good, r, p("40"), p("-o"), &model]).status.success());
    assert!(run(&[p("sdf"), &good, r, p("40"), p("-o"), &sdf]).status.success());
    let read = |path: PathBuf| std::fs::read(path).unwrap();
    assert_eq!(read(out.join("good.imp")), read(model.clone()));
    assert_eq!(read(out.join("good.sdf.npy")), read(sdf.clone()));
    assert_eq!(read(out.join("good.sdf.json")), read(sdf.with_extension("json")));

    let before = manifest(&out);
    let modified = std::fs::metadata(out.join("good.imp")).unwrap().modified().unwrap();
    std::fs::write(lib.join("broken.obj"), std::fs::read(triceratops()).unwrap()).unwrap();
    let o = batch(&lib, &out);
    assert_eq!(o.status.code(), Some(1), "empty and unreadable still fail");
    let mut after = manifest(&out);
    assert_eq!(after[2]["reused"], true, "good.obj was skipped");
    after[2]["reused"] = false.into();
    assert_eq!(after[2], before[2], "good.obj's line is the stored one");
    assert_eq!(std::fs::metadata(out.join("good.imp")).unwrap().modified().unwrap(), modified);
    assert_eq!(after[0]["status"], "ok", "the repaired mesh is converted on the rerun");
    let stray: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(stray.is_empty(), "no temporary file is left: {stray:?}");
}

#[test]
fn lists_name_meshes_relative_to_themselves() {
    let dir = tempfile::tempdir().unwrap();
    let lib = library(dir.path());
    let list = lib.join("list.txt");
    std::fs::write(&list, "# two meshes\ngood.obj\n\nmore/other.obj\ngood.obj\n").unwrap();
    let out = dir.path().join("out");
    let at = PathBuf::from(format!("@{}", list.display()));
    let o = run(&[p("batch"), &at, p("-o"), &out, p("--resolution"), p("32"), p("--quiet")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let entries = manifest(&out);
    assert_eq!(entries.len(), 2, "a repeated input is converted once");
    assert!(entries.iter().all(|e| e["status"] == "ok"));
}

/// Runs a batch of `lib` into `out` at `resolution`; the entries, and the count of reused
/// meshes the summary line gives.
fn batch_at(lib: &Path, out: &Path, resolution: &str) -> (Vec<serde_json::Value>, usize) {
    let args = [p("batch"), lib, p("-o"), out, p("--resolution"), p(resolution)];
    let o = run(&[&args[..], &[p("--jobs"), p("2")]].concat());
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{stderr}");
    let summary = stderr.lines().find(|l| l.contains("meshes converted")).expect(&stderr);
    let reused = summary.split('(').nth(1).and_then(|t| t.split(' ').next()).unwrap();
    (manifest(out), reused.parse().unwrap())
}

#[test]
fn a_rerun_refits_what_another_resolution_or_a_touched_mesh_changes_and_reuses_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let lib = dir.path().join("lib");
    std::fs::create_dir(&lib).unwrap();
    for name in ["a.obj", "b.obj", "c.obj"] {
        std::fs::copy(triceratops(), lib.join(name)).unwrap();
    }
    let out = dir.path().join("out");
    let (first, reused) = batch_at(&lib, &out, "32");
    assert_eq!(reused, 0);
    assert!(first.iter().all(|e| e["status"] == "ok" && e["reused"] == false), "{first:?}");
    let origin = &first[0]["origin"];
    assert_eq!(origin["bytes"], std::fs::metadata(triceratops()).unwrap().len());
    assert_eq!(origin["options"]["fit"]["resolution"]["longest_axis"], 32);
    assert_eq!(origin["blake3"].as_str().unwrap().len(), 64);

    let model_at_32 = std::fs::read(out.join("a.imp")).unwrap();
    let (same, reused) = batch_at(&lib, &out, "32");
    assert_eq!(reused, 3, "an unchanged folder reuses every mesh");
    assert!(same.iter().all(|e| e["reused"] == true));

    let (other, reused) = batch_at(&lib, &out, "36");
    assert_eq!(reused, 0, "another resolution refits every mesh");
    assert!(
        other.iter().all(|e| e["origin"]["options"]["fit"]["resolution"]["longest_axis"] == 36)
    );
    assert_ne!(std::fs::read(out.join("a.imp")).unwrap(), model_at_32, "a.imp was refitted");

    // Touching b.obj (same contents, a newer modification time) refits b only.
    let b = std::fs::File::options().write(true).open(lib.join("b.obj")).unwrap();
    let later = std::fs::metadata(lib.join("b.obj")).unwrap().modified().unwrap()
        + std::time::Duration::from_secs(2);
    b.set_modified(later).unwrap();
    let (touched, reused) = batch_at(&lib, &out, "36");
    assert_eq!(reused, 2, "only the touched mesh is refitted");
    let refitted: Vec<&str> = touched
        .iter()
        .filter(|e| e["reused"] == false)
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(refitted, ["b"]);
}

/// The points of a batch's `NAME.samples.npz`: the rows of its `points.npy`, found by the
/// `.npy` magic after the entry's name.
fn sample_count(npz: &Path) -> u64 {
    let bytes = std::fs::read(npz).unwrap();
    let start = bytes.windows(10).position(|w| w == b"points.npy").unwrap() + 10;
    let npy = npyz::NpyFile::new(&bytes[start..]).unwrap();
    npy.shape()[0]
}

/// Runs a batch of `lib` into `out` with `extra` options; the summary's count of reused meshes.
fn batch_with(lib: &Path, out: &Path, extra: &[&str]) -> usize {
    let args = [p("batch"), lib, p("-o"), out, p("--resolution"), p("32"), p("--jobs"), p("1")];
    let extra: Vec<&Path> = extra.iter().map(|e| p(e)).collect();
    let o = run(&[&args[..], &extra].concat());
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{stderr}");
    let summary = stderr.lines().find(|l| l.contains("meshes converted")).expect(&stderr);
    summary.split('(').nth(1).and_then(|t| t.split(' ').next()).unwrap().parse().unwrap()
}

#[test]
fn samples_are_written_beside_the_model_and_another_count_redoes_them() {
    let dir = tempfile::tempdir().unwrap();
    let lib = dir.path().join("lib");
    std::fs::create_dir(&lib).unwrap();
    std::fs::copy(triceratops(), lib.join("t.obj")).unwrap();
    let out = dir.path().join("out");
    assert_eq!(batch_with(&lib, &out, &["--samples", "500"]), 0);
    assert_eq!(sample_count(&out.join("t.samples.npz")), 500);
    assert_eq!(manifest(&out)[0]["origin"]["options"]["samples"], 500);
    assert_eq!(batch_with(&lib, &out, &["--samples", "500"]), 1, "the same count is reused");
    assert_eq!(batch_with(&lib, &out, &["--samples", "700"]), 0, "another count is redone");
    assert_eq!(sample_count(&out.join("t.samples.npz")), 700);
    std::fs::remove_file(out.join("t.samples.npz")).unwrap();
    assert_eq!(batch_with(&lib, &out, &["--samples", "700"]), 0, "a missing file is redone");
    assert_eq!(sample_count(&out.join("t.samples.npz")), 700);
    let o = run(&[p("batch"), &lib, p("-o"), &out, p("--samples"), p("0")]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--samples 0"));
}
