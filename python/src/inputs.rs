//! The inputs Python hands over, checked and turned into the library's types: meshes (a path,
//! or vertex and face arrays), grid resolutions, points, fit options.

use std::path::PathBuf;

use implicitize::memory::{self, MemoryLimit};
use implicitize::pipeline::{MeshFitOptions, MeshSource};
use implicitize::settings::FitSettings;
use implicitize::{DVec3, Mesh, Resolution, mesh};
use numpy::{PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

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

/// A count Python gives (`max_iterations=`, `max_constraints=`), checked positive.
fn count(what: &str, n: i64) -> PyResult<usize> {
    usize::try_from(n)
        .ok()
        .filter(|&n| n > 0)
        .ok_or_else(|| invalid(format!("{what} must be a positive count, not {n}")))
}

/// The options of a fit, as `implicitize fit` takes them; `None` is the library's default.
pub struct FitArgs {
    /// Voxels along the longest axis (`resolution=`), or
    pub resolution: Option<i64>,
    /// voxels along each axis (`dims=`); the default resolution when neither is given.
    pub dims: Option<Vec<i64>>,
    /// Stop once E is at most this (voxels).
    pub target_error: Option<f64>,
    /// The seed of the random choices.
    pub seed: Option<u64>,
    /// Never more constraints than this.
    pub max_constraints: Option<i64>,
    /// "iterative" or "naive".
    pub method: Option<String>,
    /// Stop after this many iterations.
    pub max_iterations: Option<i64>,
    /// Measure E from points on the surfaces.
    pub subvoxel: bool,
    /// No start at half the resolution.
    pub full_resolution: bool,
    /// At most this many detail levels (0: none).
    pub levels: Option<i64>,
    /// Fit the surface thickened to this (`shell=`): voxels as a number, mesh units as a
    /// string with the suffix `u`.
    pub shell: Option<ShellArg>,
    /// Fit the guessed solid of a mesh open over much of the grid (`solid=`).
    pub solid: bool,
    /// The most accurate model within this many bytes of binary model file (`max_bytes=`).
    pub max_bytes: Option<i64>,
    /// The memory the fit may use.
    pub memory_limit: Option<MemoryArg>,
}

/// A shell's thickness as Python gives it: a number of voxels, or a string as the command
/// line's (`"2"`, `"0.01u"`).
#[derive(FromPyObject)]
pub enum ShellArg {
    /// Voxels.
    Voxels(f64),
    /// `"2"` or `"0.01u"`.
    Text(String),
}

impl ShellArg {
    /// The thickness as the library's settings spell it: `"2"` voxels, `"0.01u"` mesh units.
    fn text(self) -> String {
        match self {
            ShellArg::Voxels(t) => t.to_string(),
            ShellArg::Text(text) => text,
        }
    }
}

impl FitArgs {
    /// The library's settings ([`FitSettings`]) for these keywords, Python's integers checked
    /// for their sign; the library turns them into its options and checks their ranges.
    pub fn options(self) -> PyResult<MeshFitOptions> {
        let mut settings = FitSettings::default();
        match resolution(self.resolution, self.dims)? {
            Resolution::Dims(dims) => settings.dims = Some(dims),
            Resolution::LongestAxis(n) => settings.resolution = Some(n),
        }
        settings.method = self.method;
        settings.target_error = self.target_error;
        settings.seed = self.seed;
        settings.max_iterations =
            self.max_iterations.map(|n| count("max_iterations", n)).transpose()?;
        settings.max_constraints =
            self.max_constraints.map(|n| count("max_constraints", n)).transpose()?;
        settings.subvoxel = self.subvoxel;
        settings.full_resolution = self.full_resolution;
        settings.levels = self
            .levels
            .map(|n| {
                usize::try_from(n)
                    .map_err(|_| invalid(format!("levels must be a count of 0 or more, not {n}")))
            })
            .transpose()?;
        settings.shell = self.shell.map(ShellArg::text);
        settings.solid = self.solid;
        settings.max_bytes = self
            .max_bytes
            .map(|n| {
                u64::try_from(n).ok().filter(|&n| n > 0).ok_or_else(|| {
                    invalid(format!("max_bytes must be a positive number of bytes, not {n}"))
                })
            })
            .transpose()?;
        settings.options("options", memory_limit(self.memory_limit)?).map_err(to_py)
    }
}

/// Reads or takes the mesh, naming its source in errors.
pub fn read(source: MeshInput) -> PyResult<(Mesh, String, Option<u64>)> {
    source.read().map_err(to_py)
}
