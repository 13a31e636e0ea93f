//! Batch conversion of many meshes: each mesh's model, report and (optionally) signed distance
//! volume written into one folder, and a manifest of the outcomes, as `implicitize batch` and
//! the Python package's `python -m implicitize.batch` (on Dask) run it.
//!
//! The work is split so that any scheduler can drive it: [`plan`] expands the command line
//! (mesh files, folders searched for mesh files, `@list.txt` files) into [`Job`]s and names
//! each mesh's outputs, [`Job::convert`] converts one mesh and never fails (a failure is an
//! [`Entry`] with status `failed` and the error's message), [`run`] converts them all in
//! parallel on rayon, and [`finish`] writes `manifest.jsonl`, one line per mesh in input order,
//! and returns the batch's quality summary.
//!
//! # Files
//! For a mesh named `NAME` (its file's stem; `NAME-2`, `NAME-3`... for later meshes of the
//! same stem): `NAME.imp` (the model, the file `implicitize fit -o` writes), `NAME.report.json`,
//! with `sdf` also `NAME.sdf.npy` and `NAME.sdf.json` (as `implicitize sdf`), with `samples`
//! also `NAME.samples.npz` (as `implicitize sample`), and last
//! `NAME.entry.json`, the mesh's manifest line, which marks its outputs complete.
//!
//! # Resuming
//! Every file is written to a temporary file in the same folder and renamed into place
//! ([`crate::output`]), so a killed run leaves no half-written output under its final name.
//! Each entry records what made it ([`Origin`]): the input's size, modification time and
//! content hash (BLAKE3), the options that decide the outputs and the library's version. A
//! rerun reuses a mesh's outputs only when its stored entry says `ok`, its outputs are all
//! there and its origin is the current one: another resolution, seed or target, a changed or
//! touched mesh, another number of samples, or another version of the library refits it (the number of concurrent jobs
//! and the memory limit decide no output and are not recorded). Failed meshes are tried
//! again. The manifest is rewritten at the end of every run.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, FrontEnd, Result};
use crate::pipeline::{self, FitOutputs, Fitted, MeshFitOptions, MeshSource, SampleOptions};

/// The extensions of the mesh files a folder is searched for (any case).
pub(crate) const MESH_EXTENSIONS: [&str; 4] = ["obj", "ply", "stl", "off"];

/// The manifest's file name in the output folder.
pub const MANIFEST: &str = "manifest.jsonl";

/// What a batch makes of each mesh. It serializes as each entry's [`Origin`] records it
/// (without the memory limit).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
#[non_exhaustive]
pub struct BatchOptions {
    /// The fit (grid, method, thresholds, seed, memory limit of the whole batch).
    pub fit: MeshFitOptions,
    /// Also write the signed distance volume of the fit's grid.
    pub sdf: bool,
    /// Also write this many samples of the mesh's exact signed distance, drawn as
    /// [`SampleOptions`]' defaults say with the fit's seed (absent from the stored options when
    /// `None`, so that runs without samples keep the origins they had).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// Whose user reads the manifest's errors, and so how they name settings.
    #[serde(skip)]
    pub wording: FrontEnd,
}

/// What made a mesh's outputs: its input file as it was and the options, so that a rerun
/// reuses them only when nothing has changed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Origin {
    /// The input file's size in bytes.
    pub bytes: u64,
    /// Its modification time, in nanoseconds since the Unix epoch (0 where the file system
    /// keeps none).
    pub modified_ns: u64,
    /// The BLAKE3 hash of its contents, in hex.
    pub blake3: String,
    /// The [`BatchOptions`] of the run, as JSON.
    pub options: serde_json::Value,
    /// The version of the library that made the outputs.
    pub version: String,
}

impl Origin {
    /// The origin of outputs made now from `input` with `options`.
    ///
    /// # Errors
    /// The input cannot be read.
    pub fn of(input: &Path, options: &BatchOptions) -> Result<Origin> {
        let io = |e| Error::io(input, e);
        let metadata = std::fs::metadata(input).map_err(io)?;
        let modified_ns = metadata
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
        let mut hasher = blake3::Hasher::new();
        hasher.update_reader(std::fs::File::open(input).map_err(io)?).map_err(io)?;
        Ok(Origin {
            bytes: metadata.len(),
            modified_ns,
            blake3: hasher.finalize().to_hex().to_string(),
            options: as_stored(options),
            version: env!("CARGO_PKG_VERSION").to_string(),
        })
    }
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
    /// How thick the goal's solid is (see [`crate::fit::Thickness`]).
    #[serde(default)]
    pub thickness: Option<crate::fit::Thickness>,
    /// The fit's warnings (see [`crate::pipeline::Fitted::warnings`]): an open mesh, thin
    /// walls, a target not met, faces inside the mesh's own solid.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// The target E asked for and reached (see [`crate::fit::TargetOutcome`]).
    #[serde(default)]
    pub target: Option<crate::fit::TargetOutcome>,
    /// Why the fit stopped: the paper's loop (level 0), then its detail levels if any.
    #[serde(default)]
    pub stopped: Option<String>,
    /// The model's polygonized surface against the mesh, both ways, with the share of the mesh
    /// inside its own solid (see `crate::metrics::surface::MeshDistances`).
    #[serde(default)]
    pub mesh_distance: Option<crate::metrics::surface::MeshDistances>,
    /// What made the outputs (for a failure, what was tried, when the input could be read).
    pub origin: Option<Origin>,
    /// Whether this run reused the outputs of an earlier one.
    #[serde(default)]
    pub reused: bool,
}

/// The jobs of a batch: the mesh files `inputs` name (files, folders searched for mesh files,
/// `@LIST` files of one path a line; in order, without repeats, a missing file kept so that
/// its conversion says so), each with the name of its outputs: its file's stem, or the stem
/// and `-2`, `-3`... where a stem is met again.
///
/// # Errors
/// A list or folder that cannot be read.
pub fn plan(inputs: &[String]) -> Result<Vec<Job>> {
    Ok(name_jobs(&collect_inputs(inputs)?))
}

/// The mesh files `inputs` name, in order and without repeats: files as they are, folders
/// searched (recursively, in name order) for files with an extension of a mesh (obj, ply, stl or off), and
/// `@LIST` files read for one path a line (relative to the list's folder; blank lines and
/// lines starting with `#` skipped). A file that does not exist is kept: its conversion fails
/// and says so.
///
/// # Errors
/// A list or folder that cannot be read.
fn collect_inputs(inputs: &[String]) -> Result<Vec<PathBuf>> {
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
fn name_jobs(inputs: &[PathBuf]) -> Vec<Job> {
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

/// `options` as JSON, read back as a stored entry's are (numbers as the file spells them), so
/// that the two compare equal.
fn as_stored(options: &BatchOptions) -> serde_json::Value {
    let text = serde_json::to_string(options).expect("options always serialize");
    serde_json::from_str(&text).expect("JSON just written always reads")
}

/// The output files of `job` in `out`: model, report, entry, the volume's two files and the
/// samples.
struct Outputs {
    files: FitOutputs,
    samples: Option<PathBuf>,
    entry: PathBuf,
}

impl Outputs {
    fn of(job: &Job, out: &Path, options: &BatchOptions) -> Outputs {
        let file = |suffix: &str| out.join(format!("{}{suffix}", job.name));
        let files = FitOutputs {
            model: Some(file(".imp")),
            report: Some(file(".report.json")),
            sdf: options.sdf.then(|| file(".sdf.npy")),
            ..FitOutputs::default()
        };
        let samples = options.samples.map(|_| file(".samples.npz"));
        Outputs { files, samples, entry: file(".entry.json") }
    }

    /// The stored entry, when it says `ok`, every output it stands for is there and it was
    /// made from `origin`.
    fn complete(&self, origin: &Origin) -> Option<Entry> {
        let entry: Entry = serde_json::from_slice(&std::fs::read(&self.entry).ok()?).ok()?;
        let sdf_grid = self.files.sdf.as_ref().map(|p| p.with_extension("json"));
        let files =
            [&self.files.model, &self.files.report, &self.files.sdf, &sdf_grid, &self.samples];
        let there = files.into_iter().flatten().all(|p| p.is_file());
        let same = entry.origin.as_ref() == Some(origin);
        (entry.status == Status::Ok && there && same).then_some(Entry { reused: true, ..entry })
    }
}

impl Job {
    /// Converts the job's mesh into `out` (which must exist), or takes its complete outputs
    /// from an earlier run made from the same input and options. Never fails: a failure is an
    /// entry with its message, and a panic (which no input should cause) is caught and
    /// reported as one, with its message.
    pub fn convert(&self, out: &Path, options: &BatchOptions) -> Entry {
        convert(self, out, options)
    }

    /// The entry of the job when its conversion failed (or never finished) with `error`.
    pub fn failed(&self, error: String) -> Entry {
        failed_entry(self, error, None, 0.0)
    }
}

/// [`Job::convert`].
fn convert(job: &Job, out: &Path, options: &BatchOptions) -> Entry {
    let clock = Instant::now();
    let origin = match Origin::of(&job.input, options) {
        Ok(origin) => origin,
        Err(e) => return failed_entry(job, e.worded(options.wording), None, 0.0),
    };
    let outputs = Outputs::of(job, out, options);
    if let Some(done) = outputs.complete(&origin) {
        return done;
    }
    let result =
        std::panic::catch_unwind(|| make(job, &outputs, options)).unwrap_or_else(|panic| {
            Err(Error::invalid(job.input.display().to_string(), panic_message(&panic)))
        });
    let seconds = clock.elapsed().as_secs_f64();
    let mut entry = match result {
        Ok(fitted) => ok_entry(job, &fitted, origin, seconds),
        Err(e) => failed_entry(job, e.worded(options.wording), Some(origin), seconds),
    };
    if entry.status == Status::Ok {
        let line = serde_json::to_string(&entry).expect("an entry always serializes");
        if let Err(e) = crate::output::write_bytes(&outputs.entry, format!("{line}\n").as_bytes()) {
            entry = failed_entry(job, e.to_string(), entry.origin, seconds);
        }
    }
    entry
}

/// Fits the mesh of `job` and writes its outputs: the fit's files, then its samples.
fn make(job: &Job, outputs: &Outputs, options: &BatchOptions) -> Result<Fitted> {
    let (Some(n), Some(path)) = (options.samples, &outputs.samples) else {
        return pipeline::fit(MeshSource::File(&job.input), &options.fit, &outputs.files, &mut ());
    };
    crate::output::check_destination(path)?;
    let (mesh, _) = crate::mesh::read(&job.input)?;
    let name = job.input.display().to_string();
    let bytes = std::fs::metadata(&job.input).ok().map(|m| m.len());
    let source = MeshSource::Mesh { mesh: &mesh, name: &name, bytes };
    let fitted = pipeline::fit(source, &options.fit, &outputs.files, &mut ())?;
    let sampling = SampleOptions {
        seed: options.fit.fit.seed,
        memory_limit: options.fit.memory_limit,
        ..SampleOptions::default()
    };
    pipeline::sample(&mesh, &name, n, &sampling)?.save_npz(path)?;
    Ok(fitted)
}

/// What a caught panic said.
fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    let said = panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into());
    format!("internal error (please report it): {said}")
}

fn ok_entry(job: &Job, fitted: &Fitted, origin: Origin, seconds: f64) -> Entry {
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
        thickness: fitted.report.thickness,
        warnings: fitted.warnings(),
        target: fitted.report.target,
        stopped: Some(stopped(&fitted.report)),
        mesh_distance: fitted.report.mesh_distance,
        origin: Some(origin),
        reused: false,
    }
}

/// Why the fit of `report` stopped, in words: its loop's termination (the paper's loop's, where
/// detail levels replaced it, then level 0's), then its levels'.
fn stopped(report: &crate::fit::FitReport) -> String {
    let stalled = report.paper_loop.as_ref().map(|first| {
        let far = first.mesh_p999_voxels.map(|far| {
            format!(", 0.1% of the mesh's points farther than {far:.2} voxels from its model")
        });
        format!("the paper's loop: {}{}; level 0: ", first.termination, far.unwrap_or_default())
    });
    let levels = report.levels.as_ref().map(|l| format!("; detail levels: {}", l.stopped));
    format!("{}{}{}", stalled.unwrap_or_default(), report.termination, levels.unwrap_or_default())
}

impl Entry {
    /// How far apart the model and the mesh are at worst, in voxels: the larger of the two
    /// 99.9th percentiles, the mesh's taken over the faces that bound its solid where some lie
    /// inside it, the model's to the surface of the solid an open mesh's winding number
    /// defines; `None` for a failure.
    pub fn worst_p999(&self) -> Option<f64> {
        let d = self.mesh_distance?;
        Some(d.judged_to_model().p99_9.max(d.judged_from_model().p99_9))
    }
}

/// The entry of a failed conversion, with what was tried when known.
fn failed_entry(job: &Job, error: String, origin: Option<Origin>, seconds: f64) -> Entry {
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
        thickness: None,
        warnings: Vec::new(),
        target: None,
        stopped: None,
        mesh_distance: None,
        origin,
        reused: false,
    }
}

/// Converts every job in parallel (at most `threads` at once; rayon's pool of that many threads
/// also runs each fit's own parallel loops), calling `done` as each finishes. The entries come
/// back in the jobs' order. The memory limit of `options` is the whole batch's: each job
/// running at once gets its share.
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
    let mut options = options.clone();
    options.fit.memory_limit = options.fit.memory_limit.share(threads.min(jobs.len()));
    Ok(pool.install(|| {
        jobs.par_iter()
            .with_max_len(1)
            .map(|job| {
                let entry = convert(job, out, &options);
                done(&entry);
                entry
            })
            .collect()
    }))
}

/// The meshes a batch's summary names, at most.
pub(crate) const WORST_SHOWN: usize = 5;

/// Ends a batch: writes `out/`[`MANIFEST`] (one JSON line per entry, in order) and returns the
/// batch's quality summary, one line each: how many fits ended above their target, and the
/// `WORST_SHOWN` models farthest from their meshes ([`Entry::worst_p999`]), worst first, with
/// their E and why they stopped (no line when no mesh was fitted).
///
/// # Errors
/// The manifest cannot be written.
pub fn finish(out: &Path, entries: &[Entry]) -> Result<Vec<String>> {
    write_manifest(out, entries)?;
    Ok(summary(entries))
}

/// The quality summary of [`finish`].
fn summary(entries: &[Entry]) -> Vec<String> {
    let mut fitted: Vec<(&Entry, f64)> =
        entries.iter().filter_map(|e| Some((e, e.worst_p999()?))).collect();
    if fitted.is_empty() {
        return Vec::new();
    }
    let mut lines = Vec::new();
    let above = entries.iter().filter(|e| e.target.is_some_and(|t| !t.met)).count();
    if above > 0 {
        lines.push(format!("{above} of {} fits ended above their target", fitted.len()));
    }
    fitted.sort_by(|a, b| b.1.total_cmp(&a.1));
    lines.push("farthest from their meshes (the larger 99.9th percentile of the two ways):".into());
    for (entry, p999) in fitted.into_iter().take(WORST_SHOWN) {
        let target = entry.target.map_or(String::new(), |t| {
            let met = if t.met { "met" } else { "not met" };
            format!(", target {:.2} {met}", t.target_voxels)
        });
        lines.push(format!(
            "  {}: {p999:.2} voxels, E {:.2}{target}; stopped: {}",
            entry.input,
            entry.max_error_voxels.unwrap_or(f32::NAN),
            entry.stopped.as_deref().unwrap_or("unknown")
        ));
    }
    lines
}

/// Writes `out/manifest.jsonl`: one JSON line per entry, in order.
fn write_manifest(out: &Path, entries: &[Entry]) -> Result<()> {
    let text: String = entries
        .iter()
        .map(|e| serde_json::to_string(e).expect("an entry always serializes") + "\n")
        .collect();
    crate::output::write_bytes(&out.join(MANIFEST), text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_keeps_its_message() {
        let caught = std::panic::catch_unwind(|| panic!("the {} went wrong", "solve")).unwrap_err();
        let message = panic_message(caught.as_ref());
        assert!(message.ends_with("the solve went wrong"), "{message}");
        let caught = std::panic::catch_unwind(|| std::panic::panic_any(7)).unwrap_err();
        assert!(panic_message(caught.as_ref()).ends_with("no message"));
    }

    #[test]
    fn an_origin_changes_with_the_options_and_the_contents() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = dir.path().join("m.obj");
        std::fs::write(&mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let options = BatchOptions::default();
        let first = Origin::of(&mesh, &options).unwrap();
        assert_eq!(Origin::of(&mesh, &options).unwrap(), first);
        let mut finer = options.clone();
        finer.fit.resolution = crate::grid::Resolution::LongestAxis(300);
        assert_ne!(Origin::of(&mesh, &finer).unwrap().options, first.options);
        assert!(first.options.get("samples").is_none(), "no samples, no entry: older origins hold");
        let mut sampled = options.clone();
        sampled.samples = Some(1000);
        assert_eq!(Origin::of(&mesh, &sampled).unwrap().options["samples"], 1000);
        let mut other_limit = options.clone();
        other_limit.fit.memory_limit = crate::memory::MemoryLimit::Bytes(1 << 30);
        assert_eq!(Origin::of(&mesh, &other_limit).unwrap(), first, "the limit decides nothing");
        std::fs::write(&mesh, "v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert_ne!(Origin::of(&mesh, &options).unwrap().blake3, first.blake3);
    }
}
