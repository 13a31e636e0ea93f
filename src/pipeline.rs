//! The front door: from a mesh (or a mesh file) to a fitted model and its report in one call,
//! and to the mesh's signed distance volume in another.
//!
//! The stages below are each available on their own ([`crate::grid`], [`crate::voxelize`],
//! [`crate::distance`], [`crate::fit`], [`crate::model`]); this module chains them the one way
//! the command-line tool, the tests and the examples all use:
//!
//! ```text
//! mesh ──► Grid::around(bounds, resolution) ──► voxelize ──► Goal (signed distance, rreg)
//!      ──► fit (iterative, paper 5; or naive, 3.2) ──► Model + FitReport
//! ```
//!
//! [`fit_mesh`] and [`fit_file`] do it all; [`Prepared`] splits it after the goal, for callers
//! that need the grid before the fit starts (to draw each iteration) or the goal itself.
//!
//! Units and signs are those of the crate: positions in the mesh's own units, errors in voxels
//! of the grid, values positive inside. The same mesh, options and seed give the same model,
//! bit for bit.

use std::path::Path;
use std::time::Instant;

use crate::distance;
use crate::error::{Error, Result};
use crate::fit::{self, FitOptions, FitReport, Goal, IterationReport};
use crate::geometry::Aabb;
use crate::grid::{Grid, Resolution, Volume};
use crate::mesh::{self, Mesh};
use crate::metrics::RegularityOptions;
use crate::model::Model;
use crate::rbf::{Implicit, Isa};
use crate::voxelize::{self, Ambiguity};

/// How the constraints of a fit are made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Method {
    /// The paper's iterative method (section 5).
    #[default]
    Iterative,
    /// The paper's simple method (section 3.2): mesh vertices as boundary constraints, each
    /// with an exterior constraint out along its normal, solved once.
    Naive,
}

/// Everything a fit of a mesh needs besides the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFitOptions {
    /// The voxel grid placed around the mesh (default: 200 voxels along its longest axis).
    pub resolution: Resolution,
    /// How the constraints are made.
    pub method: Method,
    /// The fit's thresholds and seed.
    pub fit: FitOptions,
    /// How the mesh is voxelized.
    pub voxelize: voxelize::VoxelizeOptions,
}

impl Default for MeshFitOptions {
    fn default() -> Self {
        MeshFitOptions {
            resolution: Resolution::LongestAxis(200),
            method: Method::default(),
            fit: FitOptions::default(),
            voxelize: voxelize::VoxelizeOptions::default(),
        }
    }
}

/// A fitted model and the report of its fit.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The model: the implicit function, the mesh's bounds and the grid it was fitted on. Its
    /// embedded report is set by [`Fitted::save`].
    pub model: Model,
    /// The fit's figures (the paper's Tables 1 and 2), running times included; the goal's
    /// voxelization and signed distance count as signed distance time, as in Table 2.
    pub report: FitReport,
    /// How the voxelization decided the mesh's inside.
    pub inside: voxelize::Inside,
}

/// A mesh voxelized into its goal, ready to be fitted.
#[derive(Debug)]
pub struct Prepared<'a> {
    mesh: &'a Mesh,
    bounds: Aabb,
    goal: Goal,
    inside: voxelize::Inside,
    options: MeshFitOptions,
    goal_seconds: f64,
}

/// Fits `mesh` as `options` say: one call from a mesh to a model and its report.
///
/// # Errors
/// A mesh without triangles or a grid that cannot be placed around it (see [`Grid::around`]),
/// and what the fit's solve reports.
pub fn fit_mesh(mesh: &Mesh, options: &MeshFitOptions) -> Result<Fitted> {
    Prepared::new(mesh, "the mesh", options)?.fit(|_, _| {})
}

/// Reads the mesh file at `path` (OBJ, PLY, STL or OFF) and fits it; the report records the
/// file's size. Every error names the file.
///
/// # Errors
/// As [`mesh::read`] and [`fit_mesh`].
pub fn fit_file(path: &Path, options: &MeshFitOptions) -> Result<Fitted> {
    let (mesh, _) = mesh::read(path)?;
    let mut fitted = Prepared::new(&mesh, &path.display().to_string(), options)?.fit(|_, _| {})?;
    fitted.report.mesh_bytes = std::fs::metadata(path).ok().map(|m| m.len());
    Ok(fitted)
}

/// The grid `resolution` places around `mesh`. `source` names the mesh in errors.
///
/// # Errors
/// A mesh without triangles, and the errors of [`Grid::around`].
pub fn grid_around(mesh: &Mesh, resolution: Resolution, source: &str) -> Result<Grid> {
    let bounds = mesh_bounds(mesh, source)?;
    Grid::around(&bounds, resolution).map_err(naming(source))
}

/// The goal of a fit of `mesh` on the grid `resolution` places around it: the voxelized mesh,
/// its signed distance, boundary voxels and radii of regularity (paper 4). `source` names the
/// mesh in errors.
///
/// # Errors
/// As [`grid_around`] and [`voxelize::voxelize`].
pub fn goal_of_mesh(
    mesh: &Mesh,
    resolution: Resolution,
    options: &voxelize::VoxelizeOptions,
    regularity: &RegularityOptions,
    source: &str,
) -> Result<Goal> {
    let grid = grid_around(mesh, resolution, source)?;
    let density = voxelize::voxelize(mesh, &grid, options).map_err(naming(source))?;
    Ok(Goal::from_density(density, regularity))
}

/// The signed Euclidean distance of `mesh`'s voxelization on the grid `resolution` places
/// around it, in voxels, inside positive (paper 4.2). `source` names the mesh in errors.
///
/// # Errors
/// As [`grid_around`] and [`voxelize::voxelize`].
pub fn signed_distance_of_mesh(
    mesh: &Mesh,
    resolution: Resolution,
    options: &voxelize::VoxelizeOptions,
    source: &str,
) -> Result<Volume<f32>> {
    signed_distance_reporting(mesh, resolution, options, source).map(|(volume, _)| volume)
}

/// [`signed_distance_of_mesh`], and how much of the grid has no trustworthy inside.
///
/// # Errors
/// As [`signed_distance_of_mesh`].
pub fn signed_distance_reporting(
    mesh: &Mesh,
    resolution: Resolution,
    options: &voxelize::VoxelizeOptions,
    source: &str,
) -> Result<(Volume<f32>, Ambiguity)> {
    let grid = grid_around(mesh, resolution, source)?;
    let (density, ambiguity) =
        voxelize::voxelize_reporting(mesh, &grid, options).map_err(naming(source))?;
    let inside = distance::inside(&density);
    drop(density);
    Ok((distance::signed_distance(&inside), ambiguity))
}

fn mesh_bounds(mesh: &Mesh, source: &str) -> Result<Aabb> {
    mesh.bounds().ok_or_else(|| Error::invalid(source, "the mesh has no triangles"))
}

/// Puts the mesh's name in front of a stage's error that does not name it yet.
fn naming(source: &str) -> impl Fn(Error) -> Error + '_ {
    move |e| match e {
        Error::Invalid { context, message } if context != source => {
            Error::invalid(source, format!("{context}: {message}"))
        }
        other => other,
    }
}

impl<'a> Prepared<'a> {
    /// Places the grid around `mesh`, voxelizes it and computes the goal (signed distance,
    /// boundary voxels, radii of regularity). `source` names the mesh in errors.
    ///
    /// # Errors
    /// An `IMPLICITIZE_ISA` this CPU cannot run ([`Isa::from_env`]), and the errors of
    /// [`grid_around`] and [`voxelize::voxelize`].
    pub fn new(mesh: &'a Mesh, source: &str, options: &MeshFitOptions) -> Result<Prepared<'a>> {
        Isa::from_env()?;
        let bounds = mesh_bounds(mesh, source)?;
        let clock = Instant::now();
        let grid = Grid::around(&bounds, options.resolution).map_err(naming(source))?;
        let (density, inside) = voxelize::voxelize_with_inside(mesh, &grid, &options.voxelize)
            .map_err(naming(source))?;
        let goal = Goal::from_density(density, &options.fit.regularity);
        let goal_seconds = clock.elapsed().as_secs_f64();
        Ok(Prepared { mesh, bounds, goal, inside, options: options.clone(), goal_seconds })
    }

    /// How the voxelization decided the mesh's inside.
    pub fn inside(&self) -> voxelize::Inside {
        self.inside
    }

    /// How much of the grid has a winding number near one half (no trustworthy inside).
    pub fn ambiguity(&self) -> Ambiguity {
        self.inside.ambiguity
    }

    /// The grid the mesh was voxelized on.
    pub fn grid(&self) -> &Grid {
        self.goal.grid()
    }

    /// The mesh's bounds, mesh units.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The goal: the voxelized mesh, its signed distance and radii of regularity.
    pub fn goal(&self) -> &Goal {
        &self.goal
    }

    /// Runs the fit. `on_iteration` is called after each iteration of the iterative method
    /// with its figures and its model (for progress lines and pictures); the naive method
    /// solves once and does not call it.
    ///
    /// # Errors
    /// What the fit's solve reports (see [`fit::fit`]).
    pub fn fit(self, on_iteration: impl FnMut(&IterationReport, &Implicit)) -> Result<Fitted> {
        let fitted = match self.options.method {
            Method::Iterative => fit::fit(&self.goal, &self.options.fit, on_iteration)?,
            Method::Naive => fit::naive::fit(self.mesh, &self.goal, &self.options.fit)?,
        };
        let mut report = fitted.report;
        report.timings_s.signed_distance += self.goal_seconds;
        report.timings_s.total += self.goal_seconds;
        report.winding_near_half = Some(self.inside.winding_near_half);
        let model = Model::from_implicit(fitted.implicit, self.bounds, Some(*self.goal.grid()));
        Ok(Fitted { model, report, inside: self.inside })
    }
}

impl Fitted {
    /// Embeds the report in the model as the model file keeps it, and records the file's size
    /// in the report (`model_bytes`: the size without the embedded report).
    ///
    /// The embedded report leaves out the running times, so that the same mesh, options and
    /// seed give the same model file byte for byte; [`Fitted::report`] keeps them.
    pub fn finish(&mut self) {
        self.report.model_bytes = Some(self.model.to_json().len() as u64);
        self.model.set_report(without_timings(&self.report));
    }

    /// Writes the model file with its report embedded ([`Fitted::finish`]).
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn save(&mut self, path: &Path) -> Result<()> {
        self.finish();
        self.model.save(path)
    }
}

/// The report as the model file keeps it: without the running times.
fn without_timings(report: &FitReport) -> serde_json::Value {
    let mut report = serde_json::to_value(report).expect("a report always serializes");
    if let Some(fields) = report.as_object_mut() {
        fields.remove("timings_s");
        if let Some(serde_json::Value::Array(iterations)) = fields.get_mut("per_iteration") {
            for iteration in iterations.iter_mut().filter_map(|i| i.as_object_mut()) {
                iteration.remove("timings_s");
            }
        }
    }
    report
}
