//! The batch conversion's steps for Python's schedulers (`python -m implicitize.batch` on Dask):
//! the inputs expanded and named, one mesh converted (on a worker), the manifest written; the
//! same files and manifest lines as `implicitize batch` (the library's `batch` module).

use std::path::{Path, PathBuf};

use implicitize::batch::{self, BatchOptions, Entry, Job};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{invalid, to_py};
use crate::inputs::{MemoryArg, fit_options};

/// The mesh files `inputs` name (files, folders, `@LIST` files), each with the name of its
/// outputs: `[(input, name), ...]` in order.
#[pyfunction]
pub fn batch_plan(inputs: Vec<String>) -> PyResult<Vec<(String, String)>> {
    let jobs = batch::plan(&inputs).map_err(to_py)?;
    Ok(jobs.into_iter().map(|j| (j.input.display().to_string(), j.name)).collect())
}

/// Converts one mesh into `out_dir` (or takes its complete outputs from an earlier run) and
/// returns its manifest line (JSON). Never raises for a bad mesh: its line says `failed`.
/// The options are `fit`'s keywords (every `None` the library's default), `sdf` and `samples` (the
/// number of samples of the mesh's signed distance to write, if any); a bad option raises
/// `ValueError`. `memory_limit` is this mesh's. The GIL is released meanwhile.
#[pyfunction]
#[pyo3(signature = (input, name, out_dir, sdf=false, samples=None, memory_limit=None,
                    **settings))]
#[allow(clippy::too_many_arguments)]
pub fn batch_convert(
    py: Python<'_>,
    input: PathBuf,
    name: String,
    out_dir: PathBuf,
    sdf: bool,
    samples: Option<i64>,
    memory_limit: Option<MemoryArg>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let samples = samples
        .map(|n| {
            usize::try_from(n)
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| invalid(format!("samples must be a positive count, not {n}")))
        })
        .transpose()?;
    let fit = fit_options("batch_convert", settings, memory_limit)?;
    let mut options = BatchOptions::default();
    options.fit = fit;
    options.sdf = sdf;
    options.samples = samples;
    options.wording = implicitize::FrontEnd::Python;
    let job = Job { input, name };
    let entry = py.detach(|| {
        std::fs::create_dir_all(&out_dir)
            .map(|()| job.convert(&out_dir, &options))
            .unwrap_or_else(|e| job.failed(format!("{}: {e}", out_dir.display())))
    });
    line(&entry)
}

/// The manifest line of a mesh whose conversion never finished (its workers kept dying).
#[pyfunction]
pub fn batch_failed(input: PathBuf, name: String, error: String) -> PyResult<String> {
    line(&Job { input, name }.failed(error))
}

/// Writes `out_dir/manifest.jsonl` from the lines, in order (atomically); returns the batch's
/// quality summary (`implicitize::batch::finish`), one line each.
#[pyfunction]
pub fn batch_manifest(out_dir: PathBuf, lines: Vec<String>) -> PyResult<Vec<String>> {
    let entries = lines
        .iter()
        .map(|l| serde_json::from_str::<Entry>(l).map_err(|e| invalid(format!("{l}: {e}"))))
        .collect::<PyResult<Vec<_>>>()?;
    batch::finish(Path::new(&out_dir), &entries).map_err(to_py)
}

fn line(entry: &Entry) -> PyResult<String> {
    serde_json::to_string(entry).map_err(|e| invalid(format!("a manifest line: {e}")))
}
