//! Batch conversion of many meshes: each mesh's model, report and (optionally) signed distance
//! volume written into one folder, and a manifest of the outcomes, as `implicitize batch` and
//! the Python package's `python -m implicitize.batch` (on Dask) run it.
//!
//! The work is split so that any scheduler can drive it: [`collect_inputs`] expands the
//! command line (mesh files, folders searched for mesh files, `@list.txt` files), [`plan`]
//! names each mesh's outputs, [`convert`] converts one mesh and never fails (a failure is an
//! [`Entry`] with status `failed` and the error's message), [`run`] converts them all in
//! parallel on rayon, and [`write_manifest`] writes `manifest.jsonl`, one line per mesh in
//! input order.
//!
//! # Files
//! For a mesh named `NAME` (its file's stem; `NAME-2`, `NAME-3`... for later meshes of the
//! same stem): `NAME.json` (the model, the file `implicitize fit -o` writes), `NAME.report.json`,
//! with `sdf` also `NAME.sdf.npy` and `NAME.sdf.json` (as `implicitize sdf`), and last
//! `NAME.entry.json`, the mesh's manifest line, which marks its outputs complete.
//!
//! # Resuming
//! Every file is written to a temporary file in the same folder and renamed into place
//! ([`crate::output`]), so a killed run leaves no half-written output under its final name. A
//! rerun skips a mesh whose entry says `ok` and whose outputs are all there (its manifest line
//! is the stored one); failed meshes are tried again. The manifest is rewritten at the end of every run.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::mesh;
use crate::pipeline::{Fitted, MeshFitOptions, Prepared};

/// The extensions of the mesh files a folder is searched for (any case).
pub const MESH_EXTENSIONS: [&str; 4] = ["obj", "ply", "stl", "off"];

/// The manifest's file name in the output folder.
pub const MANIFEST: &str = "manifest.jsonl";

/// What a batch makes of each mesh.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BatchOptions {
    /// The fit (grid, method, thresholds, seed).
    pub fit: MeshFitOptions,
    /// Also write the signed distance volume of the fit's grid.
    pub sdf: bool,
}

/// One mesh to convert: its file and the name of its outputs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Job {
    /// The mesh file, as given or found.
    pub input: PathBuf,
    /// The stem of its output files.
    pub name: String,
}

/// Whether a mesh was converted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Every output was written.
    Ok,
    /// Something failed; [`Entry::error`] says what.
    Failed,
}

/// One line of the manifest: how one mesh's conversion went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// The mesh file.
    pub input: String,
    /// The stem of its output files.
    pub name: String,
    /// `ok` or `failed`.
    pub status: Status,
    /// The error's message, for a failure.
    pub error: Option<String>,
    /// The fit's max error E, in voxels.
    pub max_error_voxels: Option<f32>,
    /// The model's constraints, all kinds.
    pub constraints: Option<usize>,
    /// The conversion's wall time, in seconds (of the run that converted it).
    pub seconds: f64,
    /// Whether every edge of the mesh is shared by exactly two triangles.
    pub watertight: Option<bool>,
    /// The fraction of voxel centres whose inside the winding number decided.
    pub winding_decided: Option<f64>,
    /// The fraction of voxel centres decided by a winding number near 1/2 (see
    /// [`crate::voxelize::Inside`]).
    pub winding_near_half: Option<f64>,
}

/// The mesh files `inputs` name, in order and without repeats: files as they are, folders
/// searched (recursively, in name order) for files with a [`MESH_EXTENSIONS`] extension, and
/// `@LIST` files read for one path a line (relative to the list's folder; blank lines and
/// lines starting with `#` skipped). A file that does not exist is kept: its conversion fails
/// and says so.
///
/// # Errors
/// A list or folder that cannot be read.
pub fn collect_inputs(inputs: &[String]) -> Result<Vec<PathBuf>> {
    let mut found = Vec::new();
    for input in inputs {
        match input.strip_prefix('@') {
            Some(list) => found.extend(read_list(Path::new(list))?),
            None if Path::new(input).is_dir() => search(Path::new(input), &mut found)?,
            None => found.push(PathBuf::from(input)),
        }
    }
    let mut seen = std::collections::HashSet::new();
    found.retain(|p| seen.insert(p.clone()));
    Ok(found)
}

fn read_list(list: &Path) -> Result<Vec<PathBuf>> {
    let text = std::fs::read_to_string(list).map_err(|e| Error::io(list, e))?;
    let base = list.parent().unwrap_or(Path::new(""));
    Ok(text
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty() && !line.starts_with('#'))
        .map(|line| base.join(line))
        .collect())
}

fn search(folder: &Path, found: &mut Vec<PathBuf>) -> Result<()> {
    let io = |e| Error::io(folder, e);
    let mut entries = std::fs::read_dir(folder)
        .map_err(io)?
        .map(|e| e.map(|e| e.path()))
        .collect::<std::io::Result<Vec<_>>>()
        .map_err(io)?;
    entries.sort();
    for path in entries {
        if path.is_dir() {
            search(&path, found)?;
        } else if is_mesh_file(&path) {
            found.push(path);
        }
    }
    Ok(())
}

fn is_mesh_file(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ext.is_some_and(|e| MESH_EXTENSIONS.contains(&e.as_str()))
}

/// Names each input's outputs after its file's stem; a stem met again gets `-2`, `-3`...
pub fn plan(inputs: &[PathBuf]) -> Vec<Job> {
    let mut taken: HashMap<String, usize> = HashMap::new();
    inputs
        .iter()
        .map(|input| {
            let stem =
                input.file_stem().map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
            let mut name = stem.clone();
            while taken.contains_key(&name) {
                let n = taken.entry(stem.clone()).or_insert(1);
                *n += 1;
                name = format!("{stem}-{n}");
            }
            taken.insert(name.clone(), 1);
            Job { input: input.clone(), name }
        })
        .collect()
}

/// The output files of `job` in `out`: model, report, entry, and the volume's two files.
struct Outputs {
    model: PathBuf,
    report: PathBuf,
    sdf: PathBuf,
    entry: PathBuf,
}

impl Outputs {
    fn of(job: &Job, out: &Path) -> Outputs {
        let file = |suffix: &str| out.join(format!("{}{suffix}", job.name));
        Outputs {
            model: file(".json"),
            report: file(".report.json"),
            sdf: file(".sdf.npy"),
            entry: file(".entry.json"),
        }
    }

    /// The stored entry, when it says `ok` and every output it stands for is there.
    fn complete(&self, sdf: bool) -> Option<Entry> {
        let entry: Entry = serde_json::from_slice(&std::fs::read(&self.entry).ok()?).ok()?;
        let there = self.model.is_file()
            && self.report.is_file()
            && (!sdf || (self.sdf.is_file() && self.sdf.with_extension("json").is_file()));
        (entry.status == Status::Ok && there).then_some(entry)
    }
}

/// Converts one mesh into `out` (which must exist), or takes its complete outputs from an
/// earlier run. Never fails: a failure is an entry with its message, and a panic (which no
/// input should cause) is caught and reported as one.
pub fn convert(job: &Job, out: &Path, options: &BatchOptions) -> Entry {
    let outputs = Outputs::of(job, out);
    if let Some(done) = outputs.complete(options.sdf) {
        return done;
    }
    let clock = Instant::now();
    let result = std::panic::catch_unwind(|| fit_and_write(job, &outputs, options))
        .unwrap_or_else(|_| Err(Error::invalid(job.input.display().to_string(), "internal error")));
    let seconds = clock.elapsed().as_secs_f64();
    let mut entry = match result {
        Ok(fitted) => ok_entry(job, &fitted, seconds),
        Err(e) => failed_entry(job, e.to_string(), seconds),
    };
    if entry.status == Status::Ok {
        let line = serde_json::to_string(&entry).expect("an entry always serializes");
        if let Err(e) = crate::output::write_bytes(&outputs.entry, format!("{line}\n").as_bytes()) {
            entry = failed_entry(job, e.to_string(), seconds);
        }
    }
    entry
}

fn ok_entry(job: &Job, fitted: &Fitted, seconds: f64) -> Entry {
    let c = fitted.report.constraints;
    Entry {
        input: job.input.display().to_string(),
        name: job.name.clone(),
        status: Status::Ok,
        error: None,
        max_error_voxels: Some(fitted.report.max_error_voxels),
        constraints: Some(c.boundary + c.interior + c.exterior),
        seconds,
        watertight: Some(fitted.inside.watertight),
        winding_decided: Some(fitted.inside.winding_decided),
        winding_near_half: Some(fitted.inside.winding_near_half),
    }
}

/// The entry of a failed conversion.
pub fn failed_entry(job: &Job, error: String, seconds: f64) -> Entry {
    Entry {
        input: job.input.display().to_string(),
        name: job.name.clone(),
        status: Status::Failed,
        error: Some(error),
        max_error_voxels: None,
        constraints: None,
        seconds,
        watertight: None,
        winding_decided: None,
        winding_near_half: None,
    }
}

/// Reads, voxelizes (writing the signed distance), fits, and writes the model and report.
fn fit_and_write(job: &Job, outputs: &Outputs, options: &BatchOptions) -> Result<Fitted> {
    let (mesh, _) = mesh::read(&job.input)?;
    let prepared = Prepared::new(&mesh, &job.input.display().to_string(), &options.fit)?;
    if options.sdf {
        prepared.goal().sd().save_npy(&outputs.sdf)?;
    }
    let mut fitted = prepared.fit(|_, _| {})?;
    fitted.report.mesh_bytes = std::fs::metadata(&job.input).ok().map(|m| m.len());
    fitted.finish();
    crate::output::write_bytes(&outputs.model, fitted.model.to_json().as_bytes())?;
    let report = serde_json::to_string_pretty(&fitted.report).expect("a report always serializes");
    crate::output::write_bytes(&outputs.report, format!("{report}\n").as_bytes())?;
    Ok(fitted)
}

/// Converts every job in parallel (at most `jobs` at once; rayon's pool of that many threads
/// also runs each fit's own parallel loops), calling `done` as each finishes. The entries come
/// back in the jobs' order.
///
/// # Errors
/// The thread pool cannot be made.
pub fn run(
    jobs: &[Job],
    out: &Path,
    options: &BatchOptions,
    threads: usize,
    done: impl Fn(&Entry) + Sync,
) -> Result<Vec<Entry>> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::invalid("batch", format!("cannot start {threads} threads: {e}")))?;
    Ok(pool.install(|| {
        jobs.par_iter()
            .with_max_len(1)
            .map(|job| {
                let entry = convert(job, out, options);
                done(&entry);
                entry
            })
            .collect()
    }))
}

/// Writes `out/manifest.jsonl`: one JSON line per entry, in order.
///
/// # Errors
/// The file cannot be written.
pub fn write_manifest(out: &Path, entries: &[Entry]) -> Result<()> {
    let text: String = entries
        .iter()
        .map(|e| serde_json::to_string(e).expect("an entry always serializes") + "\n")
        .collect();
    crate::output::write_bytes(&out.join(MANIFEST), text.as_bytes())
}
