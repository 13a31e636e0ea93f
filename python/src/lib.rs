//! The Python extension module `implicitize._implicitize`: the library's front door for
//! Python (PyO3 and the `numpy` crate), wrapped by the pure-Python package `implicitize`
//! (`python/implicitize/__init__.py`), which turns its inputs into the plain forms taken here.
//!
//! Every input is checked here before it reaches the library, so no input panics; errors are
//! `ValueError` (bad input) or `OSError` (a file), with the command-line tool's messages. The
//! heavy work (reading meshes, voxelizing, measuring distances, sampling, fitting, evaluating,
//! polygonizing, rendering) runs with the GIL released, so Python threads run it in parallel.

use implicitize::fit::FitOptions;
use implicitize::grid::Resolution;
use implicitize::pipeline::settings::Kind;
use implicitize::pipeline::{Method, SampleOptions};
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod batch;
mod errors;

// The same allocator and setup as the command line's, for the same reason (crates/
// implicitize-cli's main.rs): a fit allocates and frees volumes of tens of megabytes every
// iteration, which the system allocator hands back to the kernel and faults in again. It serves
// the library's allocations only; Python's objects stay with Python's allocator. The module
// turns transparent huge pages off for the process when it is imported
// (`memory::refuse_huge_pages`), without which mimalloc was no faster here.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;
mod inputs;
mod model;
mod sample;
mod volume;

/// The module's functions and classes.
#[pymodule]
fn _implicitize(m: &Bound<'_, PyModule>) -> PyResult<()> {
    implicitize::memory::refuse_huge_pages();
    m.add_class::<model::PyModel>()?;
    m.add_function(wrap_pyfunction!(volume::volume, m)?)?;
    m.add_function(wrap_pyfunction!(sample::distance, m)?)?;
    m.add_function(wrap_pyfunction!(sample::sample, m)?)?;
    m.add_function(wrap_pyfunction!(model::fit, m)?)?;
    m.add_function(wrap_pyfunction!(model::load, m)?)?;
    m.add_function(wrap_pyfunction!(model::csg, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_plan, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_convert, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_failed, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_manifest, m)?)?;
    m.add_function(wrap_pyfunction!(defaults, m)?)?;
    m.add_function(wrap_pyfunction!(fit_settings, m)?)?;
    m.add_function(wrap_pyfunction!(available_memory, m)?)?;
    m.add_function(wrap_pyfunction!(parse_size, m)?)?;
    Ok(())
}

/// The library's defaults of the settings Python's keywords leave at `None`, so that the
/// package's docstrings and the batch's `--help` show the library's numbers.
#[pyfunction]
fn defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let fit = FitOptions::default();
    let defaults = PyDict::new(py);
    defaults.set_item("resolution", Resolution::DEFAULT_LONGEST_AXIS)?;
    defaults.set_item("target_error", fit.target_error)?;
    defaults.set_item("seed", fit.seed)?;
    defaults.set_item("max_iterations", fit.max_iterations)?;
    defaults.set_item("levels", fit.levels.max_levels)?;
    defaults.set_item("levels_min_axis", fit.levels.min_axis)?;
    defaults.set_item("levels_max_goal_axis", fit.levels.max_goal_axis)?;
    defaults.set_item("max_constraints", Method::Iterative.default_max_constraints())?;
    defaults.set_item("naive_max_constraints", Method::Naive.default_max_constraints())?;
    defaults.set_item("method", "iterative")?;
    let sample = SampleOptions::default();
    defaults.set_item("near_surface", sample.near_surface)?;
    defaults.set_item("uniform", sample.uniform)?;
    Ok(defaults)
}

/// Every setting of a fit (`implicitize::pipeline::settings::FitSettings::table`), as dicts: its name (the
/// keyword), kind (`count`, `number`, `counts3`, `switch`, `choice` with its `choices`,
/// `text`), value name, unit, default as text (`None` where nothing given means something
/// else), the setting it excludes, and its help.
#[pyfunction]
fn fit_settings(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    implicitize::pipeline::settings::FitSettings::table()
        .into_iter()
        .map(|setting| {
            let dict = PyDict::new(py);
            let (kind, choices) = match setting.kind {
                Kind::Count => ("count", None),
                Kind::Number => ("number", None),
                Kind::Counts3 => ("counts3", None),
                Kind::Switch => ("switch", None),
                Kind::Choice(words) => ("choice", Some(words.to_vec())),
                Kind::Text => ("text", None),
            };
            dict.set_item("name", setting.name)?;
            dict.set_item("kind", kind)?;
            dict.set_item("choices", choices)?;
            dict.set_item("value_name", setting.value_name)?;
            dict.set_item("unit", setting.unit)?;
            dict.set_item("default", setting.default)?;
            dict.set_item("excludes", setting.excludes)?;
            dict.set_item("help", setting.help)?;
            Ok(dict)
        })
        .collect()
}

/// The memory this process can still get, in bytes (the machine's available memory within
/// `ulimit -v`), or `None` where it cannot be read: the default `memory_limit`.
#[pyfunction]
fn available_memory() -> Option<u64> {
    implicitize::memory::available()
}

/// A memory size such as `"2G"` or `"512M"` (powers of 1024) in bytes, as `memory_limit=`
/// reads it.
#[pyfunction]
fn parse_size(text: &str) -> PyResult<u64> {
    implicitize::memory::parse_size(text).map_err(errors::to_py)
}
