//! The inputs Python hands over, checked and turned into the library's types: meshes (a path,
//! or vertex and face arrays), grid resolutions, points, fit options.

use std::path::PathBuf;

use implicitize::memory::{self, MemoryLimit};
use implicitize::pipeline::settings::{Kind, Setting};
use implicitize::pipeline::{MeshFitOptions, MeshSource};
use implicitize::{DVec3, grid::Resolution, mesh, mesh::Mesh};
use numpy::{PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

use crate::errors::{invalid, to_py};

/// A mesh as the Python package passes it: a file's path, or `(vertices, faces)` arrays
/// (float64 N x 3 and int64 M x 3, which the package makes from any array-like).
#[derive(FromPyObject)]
pub enum MeshArg<'py> {
    /// A mesh file (OBJ, PLY, STL or OFF).
    Path(PathBuf),
    /// Vertices and faces.
    Arrays(PyReadonlyArray2<'py, f64>, PyReadonlyArray2<'py, i64>),
}

/// A mesh ready for the library: read from its file on the worker side of the GIL, or
/// already copied out of its arrays.
pub enum MeshInput {
    /// A file still to be read.
    File(PathBuf),
    /// A mesh from arrays.
    Memory(Mesh),
}

/// The name of meshes given as arrays, in errors.
pub const ARRAYS: &str = "the mesh";

impl MeshArg<'_> {
    /// Checks the arrays and copies them into a mesh; a path is kept to be read later.
    pub fn into_input(self) -> PyResult<MeshInput> {
        match self {
            MeshArg::Path(path) => Ok(MeshInput::File(path)),
            MeshArg::Arrays(vertices, faces) => Ok(MeshInput::Memory(mesh_of(&vertices, &faces)?)),
        }
    }
}

impl MeshInput {
    /// The mesh, the name of its source for errors, and its file's size.
    pub fn read(self) -> implicitize::Result<(Mesh, String, Option<u64>)> {
        match self {
            MeshInput::File(path) => {
                let (mesh, _) = mesh::read(&path)?;
                let bytes = std::fs::metadata(&path).ok().map(|m| m.len());
                Ok((mesh, path.display().to_string(), bytes))
            }
            MeshInput::Memory(mesh) => Ok((mesh, ARRAYS.to_string(), None)),
        }
    }

    /// The library's source of the mesh, for its fit.
    pub fn source(&self) -> MeshSource<'_> {
        match self {
            MeshInput::File(path) => MeshSource::File(path),
            MeshInput::Memory(mesh) => MeshSource::Mesh { mesh, name: ARRAYS, bytes: None },
        }
    }
}

/// Checks that `array` is N x `columns`, naming it `what` in the error.
fn check_columns(what: &str, shape: &[usize], columns: usize) -> PyResult<()> {
    if shape.len() != 2 || shape[1] != columns {
        return Err(invalid(format!(
            "{what}: expected an (N, {columns}) array, got shape {shape:?}"
        )));
    }
    Ok(())
}

/// A mesh from vertex and face arrays: finite vertices, faces indexing them.
fn mesh_of(vertices: &PyReadonlyArray2<f64>, faces: &PyReadonlyArray2<i64>) -> PyResult<Mesh> {
    check_columns("vertices", vertices.shape(), 3)?;
    check_columns("faces", faces.shape(), 3)?;
    let n = vertices.shape()[0];
    if n > u32::MAX as usize {
        return Err(invalid(format!("vertices: more than {} vertices", u32::MAX)));
    }
    let vertices: Vec<DVec3> =
        vertices.as_array().rows().into_iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect();
    if let Some(v) = vertices.iter().position(|p| !p.is_finite()) {
        return Err(invalid(format!("vertices: vertex {v} has a coordinate that is not finite")));
    }
    let faces = faces.as_array();
    let mut triangles = Vec::with_capacity(faces.nrows());
    for (t, row) in faces.rows().into_iter().enumerate() {
        let corner = |c: i64| u32::try_from(c).ok().filter(|&c| (c as usize) < n);
        match (corner(row[0]), corner(row[1]), corner(row[2])) {
            (Some(a), Some(b), Some(c)) => triangles.push([a, b, c]),
            _ => {
                return Err(invalid(format!(
                    "faces: face {t} ({}, {}, {}) refers to a vertex outside 0..{n}",
                    row[0], row[1], row[2]
                )));
            }
        }
    }
    if triangles.is_empty() {
        return Err(invalid(format!("{ARRAYS}: the mesh has no triangles")));
    }
    Ok(Mesh { vertices, triangles })
}

/// The grid resolution: `resolution` voxels along the longest axis, or exact `dims`; the
/// library's default when neither is given.
pub fn resolution(resolution: Option<i64>, dims: Option<Vec<i64>>) -> PyResult<Resolution> {
    let positive = |what: &str, n: i64| {
        usize::try_from(n)
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| invalid(format!("{what} must be a positive number of voxels, not {n}")))
    };
    match (resolution, dims) {
        (Some(_), Some(_)) => Err(invalid("give resolution= or dims=, not both")),
        (None, Some(dims)) => match dims.as_slice() {
            &[x, y, z] => Ok(Resolution::Dims([
                positive("dims", x)?,
                positive("dims", y)?,
                positive("dims", z)?,
            ])),
            _ => Err(invalid(format!("dims: expected 3 sizes (nx, ny, nz), got {}", dims.len()))),
        },
        (Some(r), None) => Ok(Resolution::LongestAxis(positive("resolution", r)?)),
        (None, None) => Ok(Resolution::default()),
    }
}

/// `points` as an N x `dim` float64 array, copied row by row into one flat vector; every
/// coordinate must be finite.
pub fn points(points: &Bound<'_, PyAny>, dim: usize) -> PyResult<(Vec<f64>, usize)> {
    let py = points.py();
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let array = py.import("numpy")?.call_method("asarray", (points,), Some(&kwargs))?;
    let array = array
        .cast_into::<numpy::PyArray2<f64>>()
        .map_err(|_| invalid(format!("points: expected an (N, {dim}) array of numbers")))?;
    let array = array.readonly();
    check_columns("points", array.shape(), dim)?;
    let flat: Vec<f64> = array.as_array().iter().copied().collect();
    if let Some(i) = flat.iter().position(|x| !x.is_finite()) {
        return Err(invalid(format!(
            "points: point {} has a coordinate that is not finite",
            i / dim
        )));
    }
    Ok((flat, array.shape()[0]))
}

/// A memory limit as Python gives it: bytes (an int) or a size such as `"2G"`; `None` is what
/// the machine has available.
#[derive(FromPyObject)]
pub enum MemoryArg {
    /// Bytes.
    Bytes(i64),
    /// A size with an optional unit (K, M, G, T: powers of 1024).
    Size(String),
}

/// The library's memory limit for `memory_limit=`.
pub fn memory_limit(limit: Option<MemoryArg>) -> PyResult<MemoryLimit> {
    match limit {
        None => Ok(MemoryLimit::Available),
        Some(MemoryArg::Bytes(n)) => {
            u64::try_from(n).ok().filter(|&n| n > 0).map(MemoryLimit::Bytes).ok_or_else(|| {
                invalid(format!("memory_limit must be a positive number of bytes, not {n}"))
            })
        }
        Some(MemoryArg::Size(text)) => {
            memory::parse_size(&text).map(MemoryLimit::Bytes).map_err(to_py)
        }
    }
}

/// The fit's settings from Python's keywords (`settings`, by name; `None` is not given),
/// each read as the library's table says ([`Kind`]) and checked there; the options they make,
/// under the memory limit `memory`. A keyword that is no setting is a `TypeError` naming it, as Python's
/// own are.
pub fn fit_options(
    function: &str,
    settings: Option<&Bound<'_, PyDict>>,
    memory: Option<MemoryArg>,
) -> PyResult<MeshFitOptions> {
    let table = implicitize::pipeline::settings::FitSettings::table();
    let mut values = serde_json::Map::new();
    for (key, value) in settings.into_iter().flat_map(|d| d.iter()) {
        let name: String = key.extract()?;
        let Some(setting) = table.iter().find(|s| s.name == name) else {
            return Err(PyTypeError::new_err(format!(
                "{function}() got an unexpected keyword argument '{name}'"
            )));
        };
        if !value.is_none() {
            values.insert(name, setting_value(setting, &value)?);
        }
    }
    let settings = implicitize::pipeline::settings::FitSettings::from_values(values, "options")
        .map_err(to_py)?;
    settings.options("options", memory_limit(memory)?).map_err(to_py)
}

/// `value` as the library reads the setting: by its kind.
fn setting_value(setting: &Setting, value: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use serde_json::Value;
    let name = setting.name;
    let shown = || value.repr().map_or_else(|_| "?".into(), |r| r.to_string());
    let wrong = || invalid(format!("{name} must be {}, not {}", setting.kind.words(), shown()));
    let number = |x: f64| serde_json::Number::from_f64(x).map(Value::Number);
    let whole = |v: &Bound<'_, PyAny>| {
        (!v.is_instance_of::<PyBool>())
            .then(|| v.extract::<i64>().ok())
            .flatten()
            .and_then(|n| u64::try_from(n).ok())
    };
    match setting.kind {
        Kind::Switch => Ok(Value::Bool(value.is_truthy()?)),
        Kind::Count => whole(value).map(Value::from).ok_or_else(wrong),
        Kind::Number => value
            .extract::<f64>()
            .ok()
            .and_then(number)
            .ok_or_else(|| invalid(format!("{name} must be a finite number, not {}", shown()))),
        Kind::Counts3 => {
            let items: Vec<Bound<'_, PyAny>> =
                value.try_iter().map_err(|_| wrong())?.collect::<PyResult<_>>()?;
            let counts: Option<Vec<u64>> = items.iter().map(whole).collect();
            counts.filter(|c| c.len() == 3).map(Value::from).ok_or_else(wrong)
        }
        Kind::Choice(_) => value.extract::<String>().map(Value::String).map_err(|_| wrong()),
        Kind::Text => match value.extract::<String>() {
            Ok(text) => Ok(Value::String(text)),
            Err(_) => value.extract::<f64>().ok().and_then(number).ok_or_else(wrong),
        },
    }
}

/// Reads or takes the mesh, naming its source in errors.
pub fn read(source: MeshInput) -> PyResult<(Mesh, String, Option<u64>)> {
    source.read().map_err(to_py)
}
