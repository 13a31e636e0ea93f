//! The Python extension module `implicitize._implicitize`: the library's front door for
//! Python (PyO3 and the `numpy` crate), wrapped by the pure-Python package `implicitize`
//! (`python/implicitize/__init__.py`), which turns its inputs into the plain forms taken here.
//!
//! Every input is checked here before it reaches the library, so no input panics; errors are
//! `ValueError` (bad input) or `OSError` (a file), with the command-line tool's messages. The
//! heavy work (reading meshes, voxelizing, fitting, evaluating, polygonizing, rendering) runs
//! with the GIL released, so Python threads run it in parallel.

use pyo3::prelude::*;

mod batch;
mod errors;
mod inputs;
mod model;
mod volume;

/// The module's functions and classes.
#[pymodule]
fn _implicitize(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<model::PyModel>()?;
    m.add_function(wrap_pyfunction!(volume::volume, m)?)?;
    m.add_function(wrap_pyfunction!(model::fit, m)?)?;
    m.add_function(wrap_pyfunction!(model::load, m)?)?;
    m.add_function(wrap_pyfunction!(model::csg, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_plan, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_convert, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_failed, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch_manifest, m)?)?;
    Ok(())
}
