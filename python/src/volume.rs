//! `voxelize` and `signed_distance`: a mesh's volumes on a grid, the same numbers as the
//! command-line tool's `.npy` files (`implicitize voxelize`, `implicitize sdf [--exact]`).

use implicitize::pipeline::{self, VolumeKind, VolumeOptions};
use numpy::{IntoPyArray, PyArray3, ndarray::Array3};
use pyo3::prelude::*;

use crate::errors::{invalid, to_py};
use crate::inputs::{self, MemoryArg, MeshArg};

/// A volume as the Python package's `Volume` takes it: the float32 values indexed `[i, j, k]`
/// in C order, the centre of voxel (0, 0, 0) and the voxel's side, in mesh units.
type VolumeParts<'py> = (Bound<'py, PyArray3<f32>>, (f64, f64, f64), f64);

/// The densities (`kind` "density", in [0, 1], 1 inside), the voxel signed distance (`kind`
/// "signed_distance", voxels, inside positive) or the exact one (`kind`
/// "exact_signed_distance", mesh units, clamped to `band` voxels when given) of `mesh` on the
/// grid `resolution` or `dims` place around it, within `memory_limit`.
#[pyfunction]
#[pyo3(signature = (mesh, kind, resolution=None, dims=None, memory_limit=None, band=None))]
pub fn volume<'py>(
    py: Python<'py>,
    mesh: MeshArg<'py>,
    kind: &str,
    resolution: Option<i64>,
    dims: Option<Vec<i64>>,
    memory_limit: Option<MemoryArg>,
    band: Option<f64>,
) -> PyResult<VolumeParts<'py>> {
    let mut options = VolumeOptions::default();
    options.resolution = inputs::resolution(resolution, dims)?;
    options.memory_limit = inputs::memory_limit(memory_limit)?;
    options.band = band;
    let kind = match kind {
        "density" => VolumeKind::Density,
        "signed_distance" => VolumeKind::SignedDistance,
        "exact_signed_distance" => VolumeKind::ExactSignedDistance,
        other => return Err(invalid(format!("unknown volume kind {other:?}"))),
    };
    let input = mesh.into_input()?;
    let volume = py.detach(|| {
        let (mesh, name, _) = inputs::read(input)?;
        let (volume, _) = pipeline::volume(&mesh, &name, kind, &options).map_err(to_py)?;
        Ok::<_, PyErr>(volume)
    })?;
    let grid = volume.grid;
    let values = Array3::from_shape_vec(grid.dims, volume.data)
        .map_err(|e| invalid(format!("volume of {:?} voxels: {e}", grid.dims)))?;
    let [x, y, z] = grid.origin;
    Ok((values.into_pyarray(py), (x, y, z), grid.voxel_size))
}
