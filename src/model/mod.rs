//! The model file: a fitted implicit surface, as a compact binary file or as versioned JSON.
//!
//! A model is what the fit produces and what `eval`, polygonization and rendering read. It is
//! written in one of two formats ([`ModelFormat`]): the binary one (`binary.rs`: the numbers
//! on a lattice as entropy-coded integers, no report), which [`Model::save`] writes to any
//! path not ending in `.json`, and JSON. [`Model::load`] reads both, whatever the file's name,
//! and a model read from either evaluates bit for bit as the one written. The JSON file is:
//!
//! ```text
//! {
//!   "format": "implicitize-model",
//!   "version": 1 | 2,                         // 2 when the shape has detail levels
//!   "sign": "inside positive, outside negative",
//!   "bounds": { "min": [x, y, z], "max": [x, y, z] },      // the shape, in the mesh's units
//!   "grid": { "dims": [..], "origin": [..], "voxel_size": h } | null,  // the fit's grid
//!   "shape": {
//!     "type": "rbf",
//!     "kernel": "r2logr" | "r3" | "r",
//!     "dimension": 2 | 3 | 4,
//!     "centres": [[x, y, z], ...],            // the constraint positions, mesh units
//!     "values": [h, ...],                     // the constraint values
//!     "kinds": ["boundary" | "interior" | "exterior", ...],
//!     "normalization": { "translate": [..], "scale": s },
//!     "weights": [d, ...],
//!     "polynomial": [p0, p1, ...],
//!     "residual": r,
//!     "lattice": { "origin": [..], "cell": c, "weight_step": w, "value_step": v }  // optional
//!   },
//!   "report": { ... } | null                  // the fit report, free form
//! }
//! ```
//!
//! A composite of models (constructive solid geometry, [`crate::shape::csg`]) has a `shape` of
//! another type, whose children are shapes themselves, so trees nest:
//!
//! ```text
//!   "shape": {
//!     "type": "csg",
//!     "op": "union" | "intersection" | "difference",
//!     "blend": k,                             // fillet radius in mesh units, 0 for sharp
//!     "children": [
//!       { "scale": s, "bounds": { "min": [..], "max": [..] }, "shape": { "type": "rbf", ... } },
//!       { "scale": s, "bounds": { ... }, "shape": { "type": "csg", ... } },
//!       ...
//!     ]
//!   }
//! ```
//!
//! A shape with detail levels (version 2, [`crate::rbf::MultiScale`]) holds its level 0, an `rbf`
//! shape as above, and its levels, coarsest first:
//!
//! ```text
//!   "shape": {
//!     "type": "levels",
//!     "base": { "kernel": "r2logr", "dimension": 3, "centres": ..., ... },   // as "rbf"
//!     "levels": [
//!       { "radius": rho, "centres": [[x, y, z], ...], "weights": [w, ...],    // mesh units
//!         "lattice": { ... } },                                                  // optional
//!       ...
//!     ]
//!   }
//! ```
//!
//! Its value is level 0's plus `sum_j w_j psi(|x - c_j| / rho)` of each level, `psi` Wendland's
//! C2 function (see `crate::rbf::wendland`). A file is written as version 1 when its shape
//! has no levels, so that builds that only read version 1 still read it; both versions are
//! read, and a version 1 file with levels is refused.
//!
//! Each child's values are divided by its `scale` (its distance scale, see [`crate::shape::csg`])
//! before the operation; the top-level `bounds` hold the composite's inside and `grid` is null.
//! A child keeps only its shape and bounds: its fit grid and report stay in its own file.
//!
//! The function is `f(x) = sum_j d_j phi(|x' - c'_j|) + p0 + sum_a p_a x'_a` with
//! `x' = (x - translate) / scale` and `c'_j` the centres mapped the same way (see
//! [`crate::rbf`]); it is positive inside and negative outside.
//!
//! `shape` is tagged by `type` so that other kinds of shape can be added as further variants in
//! the same versioned format. Numbers are written in the shortest
//! form that reads back to the same f64 (and read with correct rounding), so saving and loading
//! reproduces every weight bit for bit.

mod binary;
mod occupancy;
mod octree;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Location, Result};
use crate::field::Field;
use crate::geometry::{Aabb, DVec3};
use crate::grid::Grid;
use crate::rbf::MultiScale;
use crate::rbf::{
    Constraint, ConstraintKind, DetailLevel, Implicit, Kernel, Lattice, Normalization,
};
use crate::shape::Shape;
use crate::shape::csg::{Child, Composite, Operation};

/// The `format` field of every model file.
pub const FORMAT: &str = "implicitize-model";

/// The newest version of the format, which this crate writes for shapes with detail levels;
/// shapes without are written as version 1. Both are read.
pub const VERSION: u32 = 2;

/// The version of the format before detail levels.
const VERSION_WITHOUT_LEVELS: u32 = 1;

/// The `sign` field: the sign convention of every value the model gives.
pub(crate) const SIGN: &str = "inside positive, outside negative";

pub use binary::{MAGIC as BINARY_MAGIC, VERSION as BINARY_VERSION};

/// The two formats of a model file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelFormat {
    /// The compact binary file (see the module doc): what the fit writes by default.
    Binary,
    /// Versioned JSON, with the fit report embedded.
    Json,
}

impl ModelFormat {
    /// The format a file named `path` is written in: JSON for a name ending in `.json` (in any
    /// case), binary for any other.
    pub fn for_path(path: &Path) -> ModelFormat {
        let json = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
        if json { ModelFormat::Json } else { ModelFormat::Binary }
    }
}

/// A fitted shape with its bounds, the grid it was fitted on and the fit report.
#[derive(Debug, Clone)]
pub struct Model {
    shape: Shape,
    bounds: Aabb,
    grid: Option<Grid>,
    report: Option<serde_json::Value>,
}

impl Model {
    /// A model of `implicit`, whose shape lies in `bounds` (mesh units), fitted on `grid`.
    pub fn from_implicit(implicit: Implicit, bounds: Aabb, grid: Option<Grid>) -> Model {
        Model { shape: Shape::Rbf(implicit), bounds, grid, report: None }
    }

    /// A model of `levels`, a function with detail levels, whose shape lies in `bounds` (mesh
    /// units), fitted on `grid` (the grid asked for, whose voxels its errors are stated in).
    pub fn from_levels(levels: MultiScale, bounds: Aabb, grid: Option<Grid>) -> Model {
        Model { shape: Shape::Levels(levels), bounds, grid, report: None }
    }

    /// A model of `shape` (a variational implicit function, with or without detail levels),
    /// whose shape lies in `bounds`, fitted on `grid`.
    pub(crate) fn from_shape(shape: Shape, bounds: Aabb, grid: Option<Grid>) -> Model {
        Model { shape, bounds, grid, report: None }
    }

    /// A model of `composite`, whose bounds are [`Composite::bounds`]; it has no grid.
    ///
    /// # Errors
    /// An intersection of shapes whose bounds do not overlap.
    pub fn from_composite(composite: Composite) -> Result<Model> {
        let bounds = composite.bounds()?;
        Ok(Model { shape: Shape::Csg(composite), bounds, grid: None, report: None })
    }

    /// The shape.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// The variational implicit function, when the shape is one.
    pub fn implicit(&self) -> Option<&Implicit> {
        self.shape.implicit()
    }

    /// The number of coordinates the model reads: 2, 3 or 4 (space-time).
    pub fn dim(&self) -> usize {
        self.shape.dim()
    }

    /// The bounds of the shape in the mesh's units, for polygonizing and rendering.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The grid the model was fitted on, if any.
    pub fn grid(&self) -> Option<&Grid> {
        self.grid.as_ref()
    }

    /// The fit report, if any.
    pub fn report(&self) -> Option<&serde_json::Value> {
        self.report.as_ref()
    }

    /// Attaches the fit report.
    pub fn set_report(&mut self, report: serde_json::Value) {
        self.report = Some(report);
    }

    /// The model file's contents: pretty-printed JSON ending in a newline, exactly what
    /// [`Model::save`] writes.
    pub fn to_json(&self) -> String {
        let file = ModelFile {
            format: FORMAT.into(),
            version: if self.shape.has_levels() { VERSION } else { VERSION_WITHOUT_LEVELS },
            sign: SIGN.into(),
            bounds: BoundsFile::of(&self.bounds),
            grid: self.grid,
            shape: ShapeFile::of(&self.shape),
            report: self.report.clone(),
        };
        serde_json::to_string_pretty(&file)
            .expect("finite numbers and string keys always serialize")
            + "\n"
    }

    /// The binary model file's contents, exactly what [`Model::save`] writes to a path not
    /// ending in `.json` (no report: see the module doc).
    pub fn to_bytes(&self) -> Vec<u8> {
        binary::encode(&self.shape, &self.bounds, self.grid.as_ref())
    }

    /// For a model with detail levels, the binary file's size with level 0 alone and then with
    /// each level added in turn (the differences are what each level costs); None otherwise.
    pub(crate) fn binary_bytes_by_level(&self) -> Option<Vec<u64>> {
        let Shape::Levels(multi) = &self.shape else { return None };
        let size = |levels: usize| {
            let levels = multi.levels()[..levels].to_vec();
            let prefix = MultiScale::new("", multi.base().clone(), levels).ok()?;
            Some(binary::encode(&Shape::Levels(prefix), &self.bounds, self.grid.as_ref()).len()
                as u64)
        };
        (0..=multi.levels().len()).map(size).collect()
    }

    /// The file's contents in `format`.
    pub fn to_format(&self, format: ModelFormat) -> Vec<u8> {
        match format {
            ModelFormat::Binary => self.to_bytes(),
            ModelFormat::Json => self.to_json().into_bytes(),
        }
    }

    /// Writes the model to `path`, atomically ([`crate::output`]): as JSON when the name ends
    /// in `.json`, in the binary format otherwise ([`ModelFormat::for_path`]).
    pub fn save(&self, path: &Path) -> Result<()> {
        self.save_as(path, ModelFormat::for_path(path))
    }

    /// Writes the model to `path` in `format`, atomically, whatever the file's name.
    pub fn save_as(&self, path: &Path, format: ModelFormat) -> Result<()> {
        crate::output::write_bytes(path, &self.to_format(format))
    }

    /// Reads a model from `path`, binary or JSON (told by its first bytes, not its name). A
    /// file that is neither, not a model, of another version, damaged, or whose parts do not
    /// fit together gives an error naming the file.
    pub fn load(path: &Path) -> Result<Model> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Model::from_file_bytes(&bytes, path)
    }

    /// Reads a model from the contents of a model file in either format; `path` names it in
    /// errors. The checks are those of [`Model::load`].
    pub fn from_file_bytes(bytes: &[u8], path: &Path) -> Result<Model> {
        if bytes.starts_with(binary::MAGIC) {
            let (shape, bounds, grid) = binary::decode(bytes, path)?;
            Ok(Model { shape, bounds, grid, report: None })
        } else if bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{') {
            Model::from_json(bytes, path)
        } else {
            Err(Error::parse(
                path,
                None,
                "not a model file: it begins neither with IMPZ (the binary model) nor with `{` \
                 (a JSON model)",
            ))
        }
    }

    /// Reads a model from the contents of a model file; `path` names it in errors (the file
    /// it came from, or a description). The checks are those of [`Model::load`].
    pub fn from_json(bytes: &[u8], path: &Path) -> Result<Model> {
        let json_error = |e: serde_json::Error| {
            let at = (e.line() > 0).then_some(Location::Line(e.line()));
            Error::parse(path, at, format!("not a valid model file: {e}"))
        };
        let header: Header = serde_json::from_slice(bytes).map_err(json_error)?;
        if header.format.as_deref() != Some(FORMAT) {
            return Err(Error::parse(
                path,
                None,
                format!("not an implicitize model (\"format\" is not \"{FORMAT}\")"),
            ));
        }
        let version = header.version.filter(|&v| (1..=u64::from(VERSION)).contains(&v));
        if version.is_none() {
            return Err(Error::parse(
                path,
                None,
                format!(
                    "model format version {} is not supported; this build reads versions 1 to \
                     {VERSION}",
                    header.version.map_or("(missing)".into(), |v| v.to_string())
                ),
            ));
        }
        let file: ModelFile = serde_json::from_slice(bytes).map_err(json_error)?;
        if file.sign != SIGN {
            return Err(Error::parse(
                path,
                None,
                format!("unknown sign convention {:?}, expected {SIGN:?}", file.sign),
            ));
        }
        let context = path.display().to_string();
        let shape = file.shape.into_shape(&context)?;
        if shape.has_levels() && file.version == VERSION_WITHOUT_LEVELS {
            return Err(Error::parse(
                path,
                None,
                format!("detail levels in a version {VERSION_WITHOUT_LEVELS} model file"),
            ));
        }
        let bounds = file.bounds.into_aabb(&context)?;
        Ok(Model { shape, bounds, grid: file.grid, report: file.report })
    }
}

/// A model as a CSG child: its shape and bounds, divided by its distance scale; its fit grid
/// and report stay in its own file.
impl From<Model> for Child {
    fn from(model: Model) -> Child {
        Child::new(model.shape, model.bounds)
    }
}

impl Field for Model {
    /// The shape's value: positive inside, negative outside.
    fn value(&self, p: DVec3) -> f64 {
        self.shape.field().value(p)
    }

    /// The shape's gradient, pointing inside.
    fn gradient(&self, p: DVec3) -> DVec3 {
        self.shape.field().gradient(p)
    }

    /// The shape's values at many points, vectorized and in parallel.
    fn values(&self, points: &[DVec3]) -> Vec<f64> {
        self.shape.field().values(points)
    }

    /// The shape's points on its surface.
    fn surface_points(&self) -> Vec<DVec3> {
        self.shape.field().surface_points()
    }

    /// The shape's batch size for fast summation.
    fn fast_batch(&self) -> Option<usize> {
        self.shape.field().fast_batch()
    }
}

/// The fields read first, to tell a wrong file or version from a damaged one.
#[derive(Deserialize)]
struct Header {
    format: Option<String>,
    version: Option<u64>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    format: String,
    version: u32,
    sign: String,
    bounds: BoundsFile,
    grid: Option<Grid>,
    shape: ShapeFile,
    report: Option<serde_json::Value>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BoundsFile {
    min: [f64; 3],
    max: [f64; 3],
}

impl BoundsFile {
    fn of(bounds: &Aabb) -> BoundsFile {
        BoundsFile { min: bounds.min.to_array(), max: bounds.max.to_array() }
    }

    fn into_aabb(self, context: &str) -> Result<Aabb> {
        let [min, max] = [self.min, self.max].map(DVec3::from_array);
        if !(min.is_finite() && max.is_finite() && min.cmple(max).all()) {
            return Err(Error::invalid(context, "the bounds are not finite with min <= max"));
        }
        Ok(Aabb { min, max })
    }
}

#[derive(Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
enum ShapeFile {
    Rbf(RbfFile),
    Csg(CsgFile),
    Levels(LevelsFile),
}

impl ShapeFile {
    fn of(shape: &Shape) -> ShapeFile {
        match shape {
            Shape::Rbf(implicit) => ShapeFile::Rbf(RbfFile::of(implicit)),
            Shape::Csg(composite) => ShapeFile::Csg(CsgFile::of(composite)),
            Shape::Levels(levels) => ShapeFile::Levels(LevelsFile::of(levels)),
        }
    }

    /// The shape; `context` names where it is (file and place in the tree) for errors.
    fn into_shape(self, context: &str) -> Result<Shape> {
        Ok(match self {
            ShapeFile::Rbf(rbf) => Shape::Rbf(rbf.into_implicit(context)?),
            ShapeFile::Csg(csg) => Shape::Csg(csg.into_composite(context)?),
            ShapeFile::Levels(levels) => Shape::Levels(levels.into_levels(context)?),
        })
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LevelsFile {
    base: RbfFile,
    levels: Vec<LevelFile>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LevelFile {
    radius: f64,
    centres: Vec<[f64; 3]>,
    weights: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lattice: Option<LatticeFile>,
}

/// A compact function's lattice ([`Lattice`]), kept in JSON so that a model read from JSON
/// writes the binary file as compactly as the fit's.
#[derive(Serialize, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct LatticeFile {
    origin: [f64; 3],
    cell: f64,
    weight_step: f64,
    value_step: f64,
}

impl LatticeFile {
    fn of(lattice: Option<&Lattice>) -> Option<LatticeFile> {
        lattice.map(|l| LatticeFile {
            origin: l.origin.to_array(),
            cell: l.cell,
            weight_step: l.weight_step,
            value_step: l.value_step,
        })
    }

    fn into_lattice(self, context: &str) -> Result<Lattice> {
        let lattice = Lattice {
            origin: DVec3::from_array(self.origin),
            cell: self.cell,
            weight_step: self.weight_step,
            value_step: self.value_step,
        };
        if !lattice.is_valid() {
            return Err(Error::invalid(context, "a lattice step is not finite and positive"));
        }
        Ok(lattice)
    }
}

impl LevelsFile {
    fn of(levels: &MultiScale) -> LevelsFile {
        LevelsFile {
            base: RbfFile::of(levels.base()),
            levels: levels
                .levels()
                .iter()
                .map(|l| LevelFile {
                    radius: l.radius(),
                    centres: l.centres().iter().map(|c| c.to_array()).collect(),
                    weights: l.weights().to_vec(),
                    lattice: LatticeFile::of(l.lattice()),
                })
                .collect(),
        }
    }

    fn into_levels(self, context: &str) -> Result<MultiScale> {
        let base = self.base.into_implicit(&format!("{context}: level 0"))?;
        let levels = self
            .levels
            .into_iter()
            .enumerate()
            .map(|(i, l)| {
                let here = format!("{context}: level {}", i + 1);
                let centres = l.centres.into_iter().map(DVec3::from_array).collect();
                let level = DetailLevel::new(&here, l.radius, centres, l.weights)?;
                Ok(match l.lattice {
                    Some(lattice) => level.on_lattice(lattice.into_lattice(&here)?),
                    None => level,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        MultiScale::new(context, base, levels)
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CsgFile {
    op: Operation,
    blend: f64,
    children: Vec<ChildFile>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ChildFile {
    scale: f64,
    bounds: BoundsFile,
    shape: ShapeFile,
}

impl CsgFile {
    fn of(composite: &Composite) -> CsgFile {
        CsgFile {
            op: composite.operation(),
            blend: composite.blend(),
            children: composite
                .children()
                .iter()
                .map(|c| ChildFile {
                    scale: c.scale(),
                    bounds: BoundsFile::of(&c.bounds()),
                    shape: ShapeFile::of(c.shape()),
                })
                .collect(),
        }
    }

    fn into_composite(self, context: &str) -> Result<Composite> {
        let children = self
            .children
            .into_iter()
            .enumerate()
            .map(|(i, child)| {
                let here = format!("{context}: csg child {}", i + 1);
                let shape = child.shape.into_shape(&here)?;
                let bounds = child.bounds.into_aabb(&here)?;
                Child::with_scale(&here, shape, bounds, child.scale)
            })
            .collect::<Result<Vec<_>>>()?;
        Composite::new(context, self.op, self.blend, children)
    }
}

#[derive(Serialize, Deserialize)]
struct RbfFile {
    kernel: Kernel,
    dimension: usize,
    centres: Vec<Vec<f64>>,
    values: Vec<f64>,
    kinds: Vec<ConstraintKind>,
    normalization: Normalization,
    weights: Vec<f64>,
    polynomial: Vec<f64>,
    residual: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lattice: Option<LatticeFile>,
}

impl RbfFile {
    fn of(implicit: &Implicit) -> RbfFile {
        let constraints = implicit.constraints();
        RbfFile {
            kernel: implicit.kernel(),
            dimension: implicit.dim(),
            centres: constraints.iter().map(|c| c.position().to_vec()).collect(),
            values: constraints.iter().map(|c| c.value()).collect(),
            kinds: constraints.iter().map(|c| c.kind()).collect(),
            normalization: implicit.normalization().clone(),
            weights: implicit.weights().to_vec(),
            polynomial: implicit.polynomial().to_vec(),
            residual: implicit.residual(),
            lattice: LatticeFile::of(implicit.lattice()),
        }
    }

    fn into_implicit(self, context: &str) -> Result<Implicit> {
        let n = self.centres.len();
        if self.values.len() != n || self.kinds.len() != n {
            return Err(Error::invalid(
                context,
                format!(
                    "{n} centres but {} values and {} kinds",
                    self.values.len(),
                    self.kinds.len()
                ),
            ));
        }
        if let Some(i) = (0..n).find(|&i| ConstraintKind::of_value(self.values[i]) != self.kinds[i])
        {
            return Err(Error::invalid(
                context,
                format!(
                    "centre {} has value {} but kind {:?}",
                    i + 1,
                    self.values[i],
                    self.kinds[i]
                ),
            ));
        }
        let constraints =
            self.centres.iter().zip(&self.values).map(|(c, &v)| Constraint::new(c, v)).collect();
        let lattice = self.lattice.map(|l| l.into_lattice(context)).transpose()?;
        let implicit = Implicit::from_parts(
            context,
            self.dimension,
            self.kernel,
            constraints,
            self.normalization,
            self.weights,
            self.polynomial,
            self.residual,
        )?;
        Ok(match lattice {
            Some(lattice) => implicit.on_lattice(lattice),
            None => implicit,
        })
    }
}
