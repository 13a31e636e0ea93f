//! `Model`: a fitted, loaded or combined implicit surface, and the functions that make one
//! (`fit`, `load`, the CSG operations). Its files are the command-line tool's model files, and
//! it pickles as one (bit for bit), with the fit's full report beside it.

use std::path::{Path, PathBuf};

use implicitize::fit::IterationReport;
use implicitize::pipeline::{self, FitObserver, FitOutputs, PolygonizeOptions};
use implicitize::render::{Camera, Coloring, March, march_bounds, render_field};
use implicitize::shape::Shape;
use implicitize::shape::csg::{Child, Composite, Operation};
use implicitize::{DVec3, Field, model::Model, rbf::Implicit};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use rayon::prelude::*;

use crate::errors::{invalid, to_py};
use crate::inputs::{self, MemoryArg, MeshArg};

/// A mesh as Python gets it: vertices (N, 3) and faces (M, 3).
type MeshArrays<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<u32>>);

/// A variational implicit surface: positive inside, negative outside, in the mesh's units.
#[pyclass(frozen, module = "implicitize", name = "Model")]
pub struct PyModel {
    model: Model,
    /// The fit's full report (running times included) as JSON, for a model fitted in this
    /// process; a loaded model's report is the one its file embeds.
    report: Option<String>,
}

impl PyModel {
    /// The points' coordinates as N rows of the model's dimension.
    fn rows(&self, points: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, usize)> {
        inputs::points(points, self.model.dim())
    }

    /// Refuses a model with no surface in 3D (2D curves, 4D space-time functions).
    fn check_3d(&self, what: &str) -> PyResult<()> {
        match self.model.dim() {
            3 => Ok(()),
            dim => Err(invalid(format!("{what} needs a 3D model; this one is {dim}D"))),
        }
    }
}

/// The values of `model` at the points, exactly as `implicitize eval` computes them.
fn values(model: &Model, flat: &[f64]) -> Vec<f64> {
    let dim = model.dim();
    match model.implicit() {
        Some(implicit) => implicit.values_flat(flat),
        None => model.values(
            &flat
                .chunks_exact(dim)
                .map(|p| DVec3::new(p[0], p[1], p.get(2).copied().unwrap_or(0.0)))
                .collect::<Vec<_>>(),
        ),
    }
}

/// The gradients of `model` at the points, `dim` values each.
fn gradients(model: &Model, flat: &[f64]) -> Vec<f64> {
    let dim = model.dim();
    flat.par_chunks_exact(dim)
        .flat_map_iter(|p| match model.implicit() {
            Some(implicit) => implicit.gradient_at(p),
            None => {
                let g = model.gradient(DVec3::new(p[0], p[1], p.get(2).copied().unwrap_or(0.0)));
                g.to_array()[..dim].to_vec()
            }
        })
        .collect()
}

/// Rows of `columns` values as an N x columns array.
fn matrix<'py, T: numpy::Element>(
    py: Python<'py>,
    flat: Vec<T>,
    columns: usize,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let rows = flat.len() / columns.max(1);
    let array = Array2::from_shape_vec((rows, columns), flat)
        .map_err(|e| invalid(format!("an array of {rows} x {columns}: {e}")))?;
    Ok(array.into_pyarray(py))
}

#[pymethods]
impl PyModel {
    /// The model's values at `points`, an (N, 3) array (N x 2 for a 2D model): float64,
    /// positive inside, negative outside; the same numbers as `implicitize eval`.
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (flat, _) = self.rows(points)?;
        let values = py.detach(|| values(&self.model, &flat));
        Ok(Array1::from(values).into_pyarray(py))
    }

    /// The gradients at `points`, (N, 3) float64 (N x 2 for a 2D model); they point inside.
    fn gradient<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (flat, _) = self.rows(points)?;
        let gradients = py.detach(|| gradients(&self.model, &flat));
        matrix(py, gradients, self.model.dim())
    }

    /// The number of coordinates the model reads: 3 (2 for a curve, 4 for a morph).
    #[getter]
    fn dim(&self) -> usize {
        self.model.dim()
    }

    /// The shape's bounds in mesh units: ((xmin, ymin, zmin), (xmax, ymax, zmax)).
    #[getter]
    fn bounds(&self) -> ((f64, f64, f64), (f64, f64, f64)) {
        let b = self.model.bounds();
        (b.min.into(), b.max.into())
    }

    /// The fit report as a dict (the CLI's report.json), or None for a model without one.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let json = match (&self.report, self.model.report()) {
            (Some(json), _) => json.clone(),
            (None, Some(embedded)) => embedded.to_string(),
            (None, None) => return Ok(None),
        };
        Ok(Some(py.import("json")?.call_method1("loads", (json,))?))
    }

    /// Writes the model file, as `implicitize fit -o` does.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| self.model.save(&path)).map_err(to_py)
    }

    /// The zero set polygonized on a grid of `resolution` voxels along the longest axis of
    /// the bounds (as `implicitize mesh`; `None`, the library's default): (vertices float64
    /// (N, 3), faces uint32 (M, 3)).
    #[pyo3(signature = (resolution=None, dense=false, memory_limit=None))]
    fn to_mesh<'py>(
        &self,
        py: Python<'py>,
        resolution: Option<i64>,
        dense: bool,
        memory_limit: Option<MemoryArg>,
    ) -> PyResult<MeshArrays<'py>> {
        self.check_3d("to_mesh")?;
        let mut options = PolygonizeOptions::default();
        options.resolution = inputs::resolution(resolution, None)?;
        options.dense = dense;
        options.memory_limit = inputs::memory_limit(memory_limit)?;
        let surface = py
            .detach(|| {
                pipeline::polygonize(&self.model, &self.model.bounds(), "the model", &options)
            })
            .map_err(to_py)?;
        let vertices = surface.vertices.iter().flat_map(|v| v.to_array()).collect();
        let faces = surface.triangles.iter().flatten().copied().collect();
        Ok((matrix(py, vertices, 3)?, matrix(py, faces, 3)?))
    }

    /// A picture of the surface from its function (as `implicitize render MODEL`): an RGB
    /// array (height, width, 3) of uint8 on a white background.
    #[pyo3(signature = (size=None, view=None, color="plain"))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        size: Option<(i64, i64)>,
        view: Option<(f64, f64)>,
        color: &str,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        self.check_3d("render")?;
        let [w, h] = Camera::DEFAULT_SIZE.map(|s| s as i64);
        let size = size.unwrap_or((w, h));
        let view = view.unwrap_or(Camera::DEFAULT_VIEW.into());
        let side = |s: i64| usize::try_from(s).ok().filter(|s| (1..=Camera::MAX_SIDE).contains(s));
        let (Some(width), Some(height)) = (side(size.0), side(size.1)) else {
            return Err(invalid(format!(
                "size ({}, {}): each side must be 1 to {} pixels",
                size.0,
                size.1,
                Camera::MAX_SIDE
            )));
        };
        if !(view.0.is_finite() && view.1.is_finite()) {
            return Err(invalid("view: the azimuth and elevation must be finite degrees"));
        }
        let coloring = match color {
            "plain" => Coloring::Plain,
            "normals" => Coloring::Normals,
            other => {
                return Err(invalid(format!("color must be 'plain' or 'normals', not {other:?}")));
            }
        };
        let camera =
            Camera::framing(&self.model.bounds(), view.0, view.1, width, height).map_err(to_py)?;
        let image = py
            .detach(|| {
                let march = march_bounds(&self.model);
                render_field(&self.model, &march, &camera, coloring, March::default())
            })
            .map_err(to_py)?;
        let rgb = image
            .rgba
            .chunks_exact(4)
            .flat_map(|p| if p[3] == 0 { [255; 3] } else { [p[0], p[1], p[2]] })
            .collect();
        let array = Array3::from_shape_vec((height, width, 3), rgb)
            .map_err(|e| invalid(format!("a picture of {width} x {height}: {e}")))?;
        Ok(array.into_pyarray(py))
    }

    /// The model file's contents and the fit's full report (or None), for pickling.
    fn _state<'py>(&self, py: Python<'py>) -> (Bound<'py, PyBytes>, Option<String>) {
        (PyBytes::new(py, self.model.to_json().as_bytes()), self.report.clone())
    }

    /// The model back from [`PyModel::_state`].
    #[staticmethod]
    fn _from_state(json: &[u8], report: Option<String>) -> PyResult<PyModel> {
        let model = Model::from_json(json, Path::new("pickled model")).map_err(to_py)?;
        Ok(PyModel { model, report })
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let rebuild = py.import("implicitize")?.getattr("_model_from_state")?;
        Ok((rebuild, self._state(py).into_pyobject(py)?.into_any()))
    }

    fn __repr__(&self) -> String {
        let kind = match self.model.shape() {
            Shape::Rbf(implicit) => format!("{} constraints", implicit.constraints().len()),
            Shape::Levels(levels) => format!(
                "{} constraints and {} detail levels of {} centres",
                levels.base().constraints().len(),
                levels.levels().len(),
                levels.centre_count() - levels.base().len()
            ),
            _ => "a composite".into(),
        };
        format!("<implicitize.Model {}D, {kind}>", self.model.dim())
    }
}

/// Prints each iteration's line on stderr, when asked.
struct Progress(bool);

impl FitObserver for Progress {
    fn iteration(&mut self, report: &IterationReport, _: &Implicit) {
        if self.0 {
            eprintln!("{}", report.line());
        }
    }
}

/// Fits `mesh` (paper 5, or 3.2 with method "naive") as `implicitize fit` does, with the
/// fit's settings as keywords (`implicitize::pipeline::settings::FitSettings::table`; a `None` is the
/// library's default).
#[pyfunction]
#[pyo3(signature = (mesh, progress=false, memory_limit=None, **settings))]
pub fn fit(
    py: Python<'_>,
    mesh: MeshArg<'_>,
    progress: bool,
    memory_limit: Option<MemoryArg>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyModel> {
    let options = inputs::fit_options("fit", settings, memory_limit)?;
    let input = mesh.into_input()?;
    let (model, warnings) = py.detach(|| {
        let outputs = FitOutputs::default();
        let fitted = pipeline::fit(input.source(), &options, &outputs, &mut Progress(progress))
            .map_err(to_py)?;
        let report = serde_json::to_string(&fitted.report)
            .map_err(|e| invalid(format!("the fit report: {e}")))?;
        let warnings = fitted.warnings();
        PyResult::Ok((PyModel { model: fitted.model, report: Some(report) }, warnings))
    })?;
    for warning in warnings {
        crate::errors::warn(py, &warning)?;
    }
    Ok(model)
}

/// Reads a model file (from `implicitize fit`, `solve`, `csg` or `Model.save`).
#[pyfunction]
pub fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyModel> {
    let model = py.detach(|| Model::load(&path)).map_err(to_py)?;
    Ok(PyModel { model, report: None })
}

/// The composite `op` ("union", "intersection" or "difference") of `a` and `b`, sharp or with
/// a fillet of about `blend` mesh units, as `implicitize csg` makes it.
#[pyfunction]
pub fn csg(op: &str, a: &PyModel, b: &PyModel, blend: f64) -> PyResult<PyModel> {
    let operation = match op {
        "union" => Operation::Union,
        "intersection" => Operation::Intersection,
        "difference" => Operation::Difference,
        other => return Err(invalid(format!("unknown operation {other:?}"))),
    };
    let children = vec![Child::from(a.model.clone()), Child::from(b.model.clone())];
    let composite = Composite::new(op, operation, blend, children).map_err(to_py)?;
    let model = Model::from_composite(composite).map_err(to_py)?;
    Ok(PyModel { model, report: None })
}
