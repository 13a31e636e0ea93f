//! `distance` and `sample`: a mesh's exact distance at points, and samples of its signed
//! distance near the surface and around it, the same numbers as `implicitize distance` and
//! `implicitize sample` write.

use implicitize::DVec3;
use implicitize::pipeline::{self, DistanceOptions, SampleOptions};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::errors::{invalid, to_py};
use crate::inputs::{self, MemoryArg, MeshArg};

/// An N x `columns` array of `flat`'s values.
fn matrix<T: numpy::Element>(
    py: Python<'_>,
    flat: Vec<T>,
    columns: usize,
) -> PyResult<Bound<'_, PyArray2<T>>> {
    let rows = flat.len() / columns;
    let array = Array2::from_shape_vec((rows, columns), flat)
        .map_err(|e| invalid(format!("an array of {rows} x {columns}: {e}")))?;
    Ok(array.into_pyarray(py))
}

/// The distances from `points` (N x 3) to `mesh`: signed by the winding number (positive
/// inside) unless `signed` is false; with `closest`, also each point's closest point of the
/// surface (N x 3). Mesh units, float64.
#[pyfunction]
#[pyo3(signature = (mesh, points, signed=true, closest=false, memory_limit=None))]
#[allow(clippy::type_complexity)]
pub fn distance<'py>(
    py: Python<'py>,
    mesh: MeshArg<'py>,
    points: &Bound<'py, PyAny>,
    signed: bool,
    closest: bool,
    memory_limit: Option<MemoryArg>,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Option<Bound<'py, PyArray2<f64>>>)> {
    let mut options = DistanceOptions::default();
    options.signed = signed;
    options.memory_limit = inputs::memory_limit(memory_limit)?;
    let (flat, _) = inputs::points(points, 3)?;
    let input = mesh.into_input()?;
    let found = py.detach(|| {
        let points: Vec<DVec3> = flat.chunks_exact(3).map(DVec3::from_slice).collect();
        let (mesh, name, _) = inputs::read(input)?;
        pipeline::distance(&mesh, &name, &points, &options).map_err(to_py)
    })?;
    let nearest = closest
        .then(|| matrix(py, found.nearest.iter().flat_map(|n| n.point.to_array()).collect(), 3))
        .transpose()?;
    Ok((Array1::from(found.values).into_pyarray(py), nearest))
}

/// `points` (N x 3), `sdf` (N) and DeepSDF's `pos` and `neg` (rows x, y, z, sdf, float32,
/// negative inside).
type SampleArrays<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray2<f32>>,
);

/// `n` samples of `mesh`'s signed distance, drawn as the library's `SampleOptions` say with
/// what is given set on its defaults.
#[pyfunction]
#[pyo3(signature = (mesh, n, near_surface=None, uniform=None, seed=None, memory_limit=None))]
pub fn sample<'py>(
    py: Python<'py>,
    mesh: MeshArg<'py>,
    n: i64,
    near_surface: Option<Vec<f64>>,
    uniform: Option<f64>,
    seed: Option<u64>,
    memory_limit: Option<MemoryArg>,
) -> PyResult<SampleArrays<'py>> {
    let n = usize::try_from(n)
        .map_err(|_| invalid(format!("n must be a positive number of points, not {n}")))?;
    let mut options = SampleOptions::default();
    if let Some(sigmas) = near_surface {
        options.near_surface = sigmas;
    }
    if let Some(fraction) = uniform {
        options.uniform = fraction;
    }
    if let Some(seed) = seed {
        options.seed = seed;
    }
    options.memory_limit = inputs::memory_limit(memory_limit)?;
    options.check().map_err(to_py)?;
    let input = mesh.into_input()?;
    let samples = py.detach(|| {
        let (mesh, name, _) = inputs::read(input)?;
        pipeline::sample(&mesh, &name, n, &options).map_err(to_py)
    })?;
    let (pos, neg) = samples.deepsdf();
    let flat: Vec<f64> = samples.points.iter().flat_map(|p| p.to_array()).collect();
    Ok((
        matrix(py, flat, 3)?,
        Array1::from(samples.sdf).into_pyarray(py),
        matrix(py, pos.into_iter().flatten().collect(), 4)?,
        matrix(py, neg.into_iter().flatten().collect(), 4)?,
    ))
}
