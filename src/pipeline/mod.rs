//! The front door: every job a front end runs (the command line, `implicitize batch`, the
//! Python package), with its options, their defaults and checks, and its memory budget, each
//! written once here.
//!
//! | job | options | function |
//! |---|---|---|
//! | fit a mesh and write what it made | [`MeshFitOptions`], [`FitOutputs`] | [`fit()`] ([`fit_mesh`], [`fit_file`]) |
//! | a mesh's densities, or its voxel or exact signed distance, on a grid | [`VolumeOptions`] | [`volume`] |
//! | distances from points to a mesh, closest points | [`DistanceOptions`] | [`distance()`] |
//! | points near a mesh and uniform around it, with their distances | [`SampleOptions`] | [`sample()`] |
//! | polygonize a model's zero set | [`PolygonizeOptions`] | [`polygonize`] |
//! | many meshes into one folder | [`crate::batch::BatchOptions`] | [`crate::batch::run`] |
//!
//! A fit's settings as users give them, by name, and their conversion into [`MeshFitOptions`]
//! are [`settings`].
//!
//! The options are `#[non_exhaustive]`: made with `Default::default()` and changed field by
//! field, so a new setting breaks no caller. Each job checks its options and its memory
//! estimate ([`crate::memory`]) against the caller's [`MemoryLimit`] before it allocates its
//! grids, and refuses in one line ([`Error::Memory`]) naming the largest `resolution` that fits.
//!
//! The fit chains the stages one way:
//!
//! ```text
//! mesh ──► Grid::around(bounds, resolution) ──► voxelize ──► Goal (signed distance, rreg)
//!      ──► fit (iterative, paper 5; or naive, 3.2) ──► Model + FitReport ──► files
//! ```
//!
//! [`Prepared`] splits it after the goal, for callers that need the grid before the fit starts
//! or the goal itself; a [`FitObserver`] sees the same points of the chain from [`fit()`].
//!
//! Units and signs are those of the crate: positions in the mesh's own units, errors in voxels
//! of the grid, values positive inside. The same mesh, options and seed give the same model,
//! bit for bit.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::edt;
use crate::error::{Error, Result};
use crate::field::Field;
use crate::fit::{
    self, ErrorMeasure, FitOptions, FitReport, Goal, IterationReport, Termination, Thickness,
};
use crate::geometry::{Aabb, DVec3};
use crate::grid::{Grid, Resolution, Units, Values, Volume};
use crate::memory::{Estimate, MemoryLimit};
use crate::mesh::{self, Mesh};
use crate::mesh_query::{self, MeshQuery, Nearest};
use crate::metrics;
use crate::model::{Model, ModelFormat};
use crate::rbf::{Implicit, Isa};
pub use crate::sample::SampleOptions;
use crate::sample::Samples;
use crate::shape::Shape;
use crate::voxelize::shell::{self, Shell};
use crate::voxelize::{self, Inside, VoxelizeOptions, Voxelized};

pub mod settings;

/// How the constraints of a fit are made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The paper's iterative method (section 5).
    #[default]
    Iterative,
    /// The paper's simple method (section 3.2): mesh vertices as boundary constraints, each
    /// with an exterior constraint out along its normal, solved once.
    Naive,
}

impl Method {
    /// The most constraints a fit by this method uses where `max_constraints` sets no limit:
    /// 50,000 for the iterative fit, 2,000 for the naive one (1,000 mesh vertices, each with an
    /// exterior constraint).
    pub fn default_max_constraints(self) -> usize {
        match self {
            Method::Iterative => fit::MAX_CONSTRAINTS,
            Method::Naive => fit::naive::DEFAULT_CONSTRAINTS,
        }
    }
}

impl std::str::FromStr for Method {
    type Err = Error;

    fn from_str(name: &str) -> Result<Method> {
        match name {
            "iterative" => Ok(Method::Iterative),
            "naive" => Ok(Method::Naive),
            other => Err(Error::invalid(
                "options",
                format!("`method` must be \"iterative\" or \"naive\", not {other:?}"),
            )),
        }
    }
}

/// Everything a fit of a mesh needs besides the mesh. It serializes without the memory limit:
/// what it records is what decides the model (see [`crate::batch`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
#[non_exhaustive]
pub struct MeshFitOptions {
    /// The voxel grid placed around the mesh (default:
    /// [`Resolution::DEFAULT_LONGEST_AXIS`] voxels along its longest axis).
    pub resolution: Resolution,
    /// How the constraints are made.
    pub method: Method,
    /// The fit's thresholds and seed.
    pub fit: FitOptions,
    /// How the mesh is voxelized.
    pub voxelize: VoxelizeOptions,
    /// Fit the mesh's surface thickened to this thickness in all, half on each side (see
    /// [`voxelize::shell`]), instead of the solid its inside makes: for open shells and thin
    /// walls. `None` (default): the solid. Absent from the serialized options when `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shell: Option<Shell>,
    /// Fit the solid an open mesh's winding numbers guess even where more than
    /// [`voxelize::Ambiguity::REFUSED`] of the grid is a guess, which is refused otherwise
    /// (see [`voxelize::Ambiguity::refusal`]); no effect with `shell`. Absent from the
    /// serialized options when `false`.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub solid: bool,
    /// A byte budget: the most accurate model whose binary file has at most this many bytes,
    /// choosing the resolution, the target E and the detail levels (see [`fit()`]); `resolution`
    /// and `fit.target_error` are then the search's. `None` (default): the fit as set. Absent
    /// from the serialized options when `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_bytes: Option<u64>,
    /// The memory the fit may use.
    #[serde(skip)]
    pub memory_limit: MemoryLimit,
}

impl MeshFitOptions {
    /// Checks every setting (see [`FitOptions::check`], [`VoxelizeOptions::check`] and
    /// [`Shell::check`]).
    ///
    /// # Errors
    /// The first setting out of its range, named.
    pub fn check(&self) -> Result<()> {
        self.fit.check()?;
        self.voxelize.check()?;
        if self.max_bytes.is_some() && self.method == Method::Naive {
            return Err(Error::invalid(
                "options",
                "`max_bytes` chooses among iterative fits; it does not apply to `method` naive",
            ));
        }
        self.shell.map_or(Ok(()), Shell::check)
    }
}

/// What a volume job ([`volume`]) needs besides the mesh.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct VolumeOptions {
    /// The voxel grid placed around the mesh.
    pub resolution: Resolution,
    /// How the mesh is voxelized.
    pub voxelize: VoxelizeOptions,
    /// For [`VolumeKind::ExactSignedDistance`] only: measure exactly only the voxels within
    /// this many voxels of the surface (positive), and clamp every value to plus or minus as
    /// many voxels (in mesh units). `None` (default): every voxel exact.
    pub band: Option<f64>,
    /// The memory the job may use.
    pub memory_limit: MemoryLimit,
}

impl VolumeOptions {
    /// Checks the voxelization's options and the band, which only the exact signed distance
    /// takes and which must be a positive number of voxels.
    ///
    /// # Errors
    /// The first setting out of its range, named.
    pub fn check(&self, kind: VolumeKind) -> Result<()> {
        self.voxelize.check()?;
        let Some(band) = self.band else { return Ok(()) };
        if kind != VolumeKind::ExactSignedDistance {
            return Err(Error::invalid(
                "options",
                "`band` applies only to the exact signed distance (`exact`)",
            ));
        }
        if !(band.is_finite() && band > 0.0) {
            return Err(Error::invalid(
                "options",
                format!("`band` must be a positive number of voxels, not {band}"),
            ));
        }
        Ok(())
    }

    /// What the `.json` beside a volume of `kind` made with these options records of its
    /// values besides the grid (see [`Volume::save_npy`]).
    pub fn values(&self, kind: VolumeKind) -> Values {
        let units = match kind {
            VolumeKind::Density => None,
            VolumeKind::SignedDistance => Some(Units::Voxels),
            VolumeKind::ExactSignedDistance => Some(Units::Mesh),
        };
        Values { units, band: self.band }
    }
}

/// Which volume [`volume`] makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VolumeKind {
    /// Densities in `[0, 1]`, 1 inside (paper 4.1).
    Density,
    /// The signed Euclidean distance of the voxelization, in voxels, inside positive (4.2).
    SignedDistance,
    /// The exact distance from each voxel centre to the mesh's triangles, in mesh units,
    /// positive where the voxelization is inside (the sign of [`VolumeKind::SignedDistance`]);
    /// see `mesh_query::grid`.
    ExactSignedDistance,
}

/// What a distance job ([`distance()`]) needs besides the mesh and the points.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct DistanceOptions {
    /// Sign the distances, positive inside as the voxelizer decides it (default; see
    /// `crate::mesh_query`), or leave them unsigned (and skip that work).
    pub signed: bool,
    /// The memory the job may use.
    pub memory_limit: MemoryLimit,
}

impl Default for DistanceOptions {
    fn default() -> Self {
        DistanceOptions { signed: true, memory_limit: MemoryLimit::default() }
    }
}

/// What a distance job ([`distance()`]) found for each point.
#[derive(Debug, Clone, PartialEq)]
pub struct Distances {
    /// The distance from each point to the mesh, in its units: signed (positive inside) when
    /// [`DistanceOptions::signed`], unsigned otherwise.
    pub values: Vec<f64>,
    /// Each point's closest point of the surface, its triangle and barycentric coordinates.
    pub nearest: Vec<Nearest>,
}

/// What polygonizing a field ([`polygonize`]) needs besides the field.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct PolygonizeOptions {
    /// The grid placed around the field's bounds.
    pub resolution: Resolution,
    /// Evaluate every voxel rather than follow the surface from the field's surface points:
    /// slower, and also finds small detached pieces far from them.
    pub dense: bool,
    /// The memory the job may use.
    pub memory_limit: MemoryLimit,
}

/// The files a fit writes, each atomically ([`crate::output`]); `None` writes nothing.
#[derive(Debug, Clone, Default, PartialEq)]
#[non_exhaustive]
pub struct FitOutputs {
    /// The model file: binary, or JSON with the report embedded without its running times
    /// (see `model_format`).
    pub model: Option<PathBuf>,
    /// The model file's format; None: told by its name ([`ModelFormat::for_path`]).
    pub model_format: Option<ModelFormat>,
    /// The fit report (JSON: the paper's Table 1 and 2 columns, per iteration too).
    pub report: Option<PathBuf>,
    /// The model's zero set polygonized on the fit's grid (OBJ, PLY, STL or OFF).
    pub surface: Option<PathBuf>,
    /// The goal's signed distance volume (NumPy, with its grid in a `.json` beside it): on the
    /// fit's grid, or on the coarser grid of the goal of a fit with detail levels on a large
    /// grid (`fit::detail::goal_grid`).
    pub sdf: Option<PathBuf>,
}

impl FitOutputs {
    /// Checks, before any work, that every file can be written (its folder exists and takes
    /// files) and that the surface has a mesh file's extension.
    ///
    /// # Errors
    /// The first file that cannot be written, named.
    pub fn check(&self) -> Result<()> {
        if let Some(surface) = &self.surface {
            mesh::Format::from_path(surface)?;
        }
        let sdf_grid = self.sdf.as_ref().map(|p| p.with_extension("json"));
        let files = [&self.model, &self.report, &self.surface, &self.sdf, &sdf_grid];
        files.into_iter().flatten().try_for_each(|path| crate::output::check_destination(path))
    }
}

/// A mesh to fit: a file, or a mesh already in memory with the name its errors give it and
/// the size of the file it came from, if any.
#[derive(Debug, Clone, Copy)]
pub enum MeshSource<'a> {
    /// A mesh file (OBJ, PLY, STL or OFF), read by the job.
    File(&'a Path),
    /// A mesh in memory.
    Mesh {
        /// The mesh.
        mesh: &'a Mesh,
        /// Its name in errors, such as `"the mesh"`.
        name: &'a str,
        /// The size of the file it came from, for the report.
        bytes: Option<u64>,
    },
}

impl<'a> MeshSource<'a> {
    /// The mesh, its name and its file's size.
    fn read(self) -> Result<(Cow<'a, Mesh>, String, Option<u64>)> {
        match self {
            MeshSource::File(path) => {
                let (mesh, _) = mesh::read(path)?;
                let bytes = std::fs::metadata(path).ok().map(|m| m.len());
                Ok((Cow::Owned(mesh), path.display().to_string(), bytes))
            }
            MeshSource::Mesh { mesh, name, bytes } => Ok((Cow::Borrowed(mesh), name.into(), bytes)),
        }
    }
}

/// What a caller of [`fit()`] sees of the chain as it runs: the goal once it is made, and each
/// iteration of the iterative method with its model (for progress lines and pictures).
pub trait FitObserver {
    /// The goal is made; the fit starts next.
    fn prepared(&mut self, _prepared: &Prepared<'_>) {}
    /// An iteration ended with `report` and its model.
    fn iteration(&mut self, _report: &IterationReport, _implicit: &Implicit) {}
}

/// Sees nothing.
impl FitObserver for () {}

/// A fitted model and the report of its fit.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The model: the implicit function, the mesh's bounds and the grid it was fitted on. Its
    /// embedded report is set by [`Fitted::finish`].
    pub model: Model,
    /// The fit's figures (the paper's Tables 1 and 2), running times included; the goal's
    /// voxelization and signed distance count as signed distance time, as in Table 2.
    pub report: FitReport,
    /// How the voxelization decided the mesh's inside.
    pub inside: Inside,
    /// The model's zero set polygonized on the fit's grid: what the report's `mesh_distance`
    /// measures and what [`FitOutputs::surface`] writes.
    pub surface: Mesh,
}

/// A mesh voxelized into its goal, ready to be fitted.
#[derive(Debug)]
pub struct Prepared<'a> {
    mesh: &'a Mesh,
    /// The mesh's name in errors.
    source: String,
    bounds: Aabb,
    /// The grid asked for, whose voxels the fit's errors are stated in.
    grid: Grid,
    /// The goal: on `grid`, or, for a fit with detail levels on a large grid, on a coarser one
    /// ([`fit::detail::goal_grid`]).
    goal: Goal,
    inside: Inside,
    /// The mesh's exact distance query.
    query: Arc<MeshQuery>,
    thickness: Thickness,
    options: MeshFitOptions,
    /// The memory the fit's grids leave for its solves.
    limit: u64,
    /// The mesh's area, mesh units squared (both faces of a shell's), which sizes the model's
    /// polygonized surface ([`Estimate::measured_surface`]).
    area: f64,
    goal_seconds: f64,
}

/// The whole chain: reads or takes the mesh, checks the options and the memory budget,
/// voxelizes it into its goal, fits it, embeds the report in the model ([`Fitted::finish`])
/// and writes `outputs`. `observer` sees the goal and each iteration.
///
/// # Errors
/// A file that cannot be written (checked before any work), the mesh's errors, an option out
/// of range, a refusal of the memory budget or of a solid too thin for the grid
/// ([`Error::Thin`]), and what the fit's solve reports.
pub fn fit(
    source: MeshSource<'_>,
    options: &MeshFitOptions,
    outputs: &FitOutputs,
    observer: &mut dyn FitObserver,
) -> Result<Fitted> {
    outputs.check()?;
    options.check()?;
    if options.max_bytes.is_some() && outputs.sdf.is_some() {
        return Err(Error::invalid(
            "options",
            "a byte budget tries several grids: write the signed distance without `max_bytes`",
        ));
    }
    let (mesh, name, bytes) = source.read()?;
    let mut fitted = match options.max_bytes {
        Some(budget) => fit_within_bytes(&mesh, &name, options, budget, observer)?,
        None => {
            let prepared = Prepared::new(&mesh, &name, options)?;
            observer.prepared(&prepared);
            if let Some(path) = &outputs.sdf {
                prepared.goal().sd().save_npy(path, &Values::VOXELS)?;
            }
            prepared.fit(|report, implicit| observer.iteration(report, implicit))?
        }
    };
    fitted.report.mesh_bytes = bytes;
    fitted.finish();
    fitted.write(outputs)?;
    Ok(fitted)
}

/// The smallest resolution a byte budget tries.
const BUDGET_MIN_RESOLUTION: usize = 24;

/// The resolution of the fit with detail levels a byte budget tries first.
const BUDGET_LEVELS_RESOLUTION: usize = 512;

/// The largest resolution a byte budget tries (with detail levels).
const BUDGET_MAX_RESOLUTION: usize = 1024;

/// The smallest resolution a byte budget fits with detail levels (the fit's own
/// [`crate::fit::LevelOptions::min_axis`] is larger: below it, a fit without budget is the
/// paper's single function). From 128 voxels level 0 has a coarser grid to start on.
const BUDGET_LEVELS_MIN_RESOLUTION: usize = 128;

/// The target E of the fits with detail levels a byte budget tries. For the same bytes, a
/// coarser grid to a target of 1 voxel is nearer the mesh than a finer one to 2 or 4: on the
/// horse, 256 voxels to 1 reach a Chamfer distance of 0.26e-3 of the diagonal in 17.4 KB where
/// 512 voxels to 4 reach 0.47e-3 in 16.8 KB.
const BUDGET_LEVELS_TARGET: f32 = 1.0;

/// The targets E of the fits without detail levels a byte budget tries, one after the other
/// while the budget leaves room for the next.
const BUDGET_TARGETS_WITHOUT_LEVELS: [f32; 3] = [2.0, 1.5, 1.0];

/// About how much a fit without levels grows from one of [`BUDGET_TARGETS_WITHOUT_LEVELS`] to
/// the next (about 1.5 times from 2 to 1.5 on the horse at 380 voxels).
const BUDGET_TARGET_GROWTH: f64 = 1.4;

/// The most accurate fit of `mesh` whose binary model file is at most `budget` bytes (see
/// [`MeshFitOptions::max_bytes`]). A model's size goes with its surface's area in voxels, so
/// resolutions are scaled by the square root of a ratio of bytes (and a margin):
///
/// - the fit at the default resolution and target first; above the budget, fits at smaller
///   resolutions until one is within it (the answer), or the budget is refused;
/// - within it, a fit with detail levels at 512 voxels to [`BUDGET_LEVELS_TARGET`]; within
///   the budget, fits at the larger resolutions (up to [`BUDGET_MAX_RESOLUTION`]) the last
///   one's size suggests, while the budget leaves room and they are within it; above it, fits
///   with levels to the same target at the smaller resolutions the last one's size suggests,
///   until one is within the budget or the resolution is below
///   [`BUDGET_LEVELS_MIN_RESOLUTION`];
/// - if no fit with levels is within the budget, fits without levels at the larger
///   resolution the default fit's size suggests, to the targets of
///   [`BUDGET_TARGETS_WITHOUT_LEVELS`] while the budget leaves room for the next.
///
/// Of the fits within the budget, the one whose surface is nearest the mesh (the mean of its
/// report's two mean distances) is returned, its report's `byte_budget` listing every fit
/// tried. A larger fit that fails (the memory limit, say) is left out.
///
/// # Errors
/// A budget below the smallest model, naming its size; the errors of the first fit.
fn fit_within_bytes(
    mesh: &Mesh,
    name: &str,
    options: &MeshFitOptions,
    budget: u64,
    observer: &mut dyn FitObserver,
) -> Result<Fitted> {
    let mut search =
        BudgetSearch { mesh, name, options, observer, budget, tried: Vec::new(), best: None };
    let default_resolution = Resolution::DEFAULT_LONGEST_AXIS;
    let default_target = FitOptions::default().target_error;
    let first = search.try_fit(default_resolution, default_target, Levels::AsOptions)?;
    if first > budget {
        search.shrink(default_resolution, first, default_target)?;
    } else if !search.grow_with_levels() {
        search.grow_without_levels(first);
    }
    Ok(search.result())
}

/// The resolution a fit of `bytes` at `resolution` suggests for `budget`, with a margin.
fn scaled_resolution(resolution: usize, bytes: u64, budget: u64, margin: f64) -> usize {
    (resolution as f64 * (budget as f64 / bytes as f64).sqrt() * margin) as usize
}

/// The next resolution a search with levels tries above `resolution`, whose fit was `bytes`
/// within `budget`: the one its size suggests (with a margin) if that is a quarter larger or
/// more, capped at [`BUDGET_MAX_RESOLUTION`], which is tried whenever it is larger at all.
fn larger_with_levels(resolution: usize, bytes: u64, budget: u64) -> Option<usize> {
    let suggested = scaled_resolution(resolution, bytes, budget, 0.9);
    let larger = suggested.min(BUDGET_MAX_RESOLUTION);
    (suggested > resolution * 5 / 4 && larger > resolution).then_some(larger)
}

/// Whether a fit of a byte budget search has detail levels.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Levels {
    /// As the fit's options say (levels from their `min_axis` voxels).
    AsOptions,
    /// Levels from [`BUDGET_LEVELS_MIN_RESOLUTION`] voxels.
    FromBudgetMinimum,
    /// None: the paper's single function.
    Off,
}

/// The fits a byte budget has tried, and the best within it so far.
struct BudgetSearch<'a, 'o> {
    mesh: &'a Mesh,
    name: &'a str,
    options: &'a MeshFitOptions,
    observer: &'o mut dyn FitObserver,
    budget: u64,
    tried: Vec<fit::BudgetTrial>,
    best: Option<(usize, Fitted)>,
}

impl BudgetSearch<'_, '_> {
    /// The fit at `resolution` voxels along the longest axis to `target` E, recorded in `tried`
    /// and kept as the best if it is within the budget and nearer the mesh than the best so
    /// far: its binary file's size.
    fn try_fit(&mut self, resolution: usize, target: f32, levels: Levels) -> Result<u64> {
        let mut options = self.options.clone();
        options.max_bytes = None;
        options.resolution = Resolution::LongestAxis(resolution);
        options.fit.target_error = target;
        match levels {
            Levels::AsOptions => {}
            Levels::FromBudgetMinimum => options.fit.levels.min_axis = BUDGET_LEVELS_MIN_RESOLUTION,
            Levels::Off => options.fit.levels.max_levels = 0,
        }
        let prepared = Prepared::new(self.mesh, self.name, &options)?;
        if self.tried.is_empty() {
            self.observer.prepared(&prepared);
        }
        let observer = &mut *self.observer;
        let fitted = prepared.fit(|report, implicit| observer.iteration(report, implicit))?;
        let voxel = fitted.report.voxel_size;
        let mean_distance = fitted
            .report
            .mesh_distance
            .map_or(f64::INFINITY, |d| (d.mesh_to_model.mean + d.model_to_mesh.mean) / 2.0 * voxel);
        let bytes = fitted.model.to_bytes().len() as u64;
        self.tried.push(fit::BudgetTrial {
            resolution,
            target_error_voxels: target,
            levels: fitted.report.levels.as_ref().map_or(0, |l| l.levels.len()),
            bytes,
            mean_distance,
        });
        let nearer =
            self.best.as_ref().is_none_or(|(i, _)| mean_distance < self.tried[*i].mean_distance);
        if bytes <= self.budget && nearer {
            self.best = Some((self.tried.len() - 1, fitted));
        }
        Ok(bytes)
    }

    /// A fit beyond the first: its size, or None when it failed (a larger grid than the
    /// memory limit allows, say), which leaves it out of the search.
    fn try_more(&mut self, resolution: usize, target: f32, levels: Levels) -> Option<u64> {
        self.try_fit(resolution, target, levels).ok()
    }

    /// Fits at resolutions below `resolution`, whose fit was `bytes`, until one is within the
    /// budget or a grid is too coarse to fit the mesh on.
    ///
    /// # Errors
    /// When none is within the budget: the smallest fit's size, named.
    fn shrink(&mut self, mut resolution: usize, mut bytes: u64, target: f32) -> Result<()> {
        while bytes > self.budget && resolution > BUDGET_MIN_RESOLUTION {
            resolution =
                scaled_resolution(resolution, bytes, self.budget, 0.95).max(BUDGET_MIN_RESOLUTION);
            let Some(smaller) = self.try_more(resolution, target, Levels::AsOptions) else { break };
            bytes = smaller;
        }
        if self.best.is_some() {
            return Ok(());
        }
        let smallest = self.tried.iter().min_by_key(|t| t.bytes).expect("one fit at least");
        Err(Error::invalid(
            self.name,
            format!(
                "no model fits in {} bytes: the smallest is {} bytes (at resolution {}); give \
                 `max_bytes` {} or more",
                self.budget, smallest.bytes, smallest.resolution, smallest.bytes
            ),
        ))
    }

    /// Fits with detail levels (see [`fit_within_bytes`]): whether one was within the budget.
    fn grow_with_levels(&mut self) -> bool {
        let resolution = BUDGET_LEVELS_RESOLUTION;
        match self.try_more(resolution, BUDGET_LEVELS_TARGET, Levels::FromBudgetMinimum) {
            Some(bytes) if bytes <= self.budget => {
                self.levels_larger(resolution, bytes);
                true
            }
            Some(bytes) => self.levels_smaller(resolution, bytes),
            None => false,
        }
    }

    /// Fits with levels at resolutions above `resolution`, whose fit was `bytes` within the
    /// budget, while the budget leaves room and they are within it. Finer grids grow by less
    /// than their area (level 0 keeps a goal of at most `max_goal_axis` voxels), so each larger
    /// fit is scaled from the last.
    fn levels_larger(&mut self, mut resolution: usize, mut bytes: u64) {
        while let Some(larger) = larger_with_levels(resolution, bytes, self.budget) {
            match self.try_more(larger, BUDGET_LEVELS_TARGET, Levels::FromBudgetMinimum) {
                Some(larger_bytes) if larger_bytes <= self.budget => {
                    (resolution, bytes) = (larger, larger_bytes);
                }
                _ => return,
            }
        }
    }

    /// Fits with levels at resolutions below `resolution`, whose fit was `bytes` above the
    /// budget, until one is within it (true) or the resolution is below
    /// [`BUDGET_LEVELS_MIN_RESOLUTION`].
    fn levels_smaller(&mut self, mut resolution: usize, mut bytes: u64) -> bool {
        while bytes > self.budget {
            resolution = scaled_resolution(resolution, bytes, self.budget, 0.95);
            if resolution < BUDGET_LEVELS_MIN_RESOLUTION {
                return false;
            }
            let Some(smaller) =
                self.try_more(resolution, BUDGET_LEVELS_TARGET, Levels::FromBudgetMinimum)
            else {
                return false;
            };
            bytes = smaller;
        }
        true
    }

    /// Fits without detail levels larger than the default one, whose fit was `first` bytes
    /// (see [`fit_within_bytes`]).
    fn grow_without_levels(&mut self, first: u64) {
        let default_resolution = Resolution::DEFAULT_LONGEST_AXIS;
        let larger = scaled_resolution(default_resolution, first, self.budget, 0.9)
            .min(self.options.fit.levels.min_axis.saturating_sub(1));
        if larger > default_resolution * 11 / 10 {
            for target in BUDGET_TARGETS_WITHOUT_LEVELS {
                match self.try_more(larger, target, Levels::Off) {
                    Some(bytes) if bytes as f64 * BUDGET_TARGET_GROWTH <= self.budget as f64 => {}
                    _ => break,
                }
            }
        }
    }

    /// The best fit, its report's `byte_budget` saying what was tried.
    fn result(self) -> Fitted {
        let (chosen, mut fitted) = self.best.expect("a search that did not fail has a best fit");
        fitted.report.byte_budget =
            Some(fit::ByteBudget { max_bytes: self.budget, tried: self.tried, chosen });
        fitted
    }
}

/// Fits `mesh` as `options` say and writes nothing: [`fit()`] on a mesh in memory.
///
/// # Errors
/// As [`fit()`].
pub fn fit_mesh(mesh: &Mesh, options: &MeshFitOptions) -> Result<Fitted> {
    let source = MeshSource::Mesh { mesh, name: "the mesh", bytes: None };
    fit(source, options, &FitOutputs::default(), &mut ())
}

/// Reads the mesh file at `path` (OBJ, PLY, STL or OFF) and fits it, writing nothing: [`fit()`]
/// on a file. Every error names the file.
///
/// # Errors
/// As [`fit()`].
pub fn fit_file(path: &Path, options: &MeshFitOptions) -> Result<Fitted> {
    fit(MeshSource::File(path), options, &FitOutputs::default(), &mut ())
}

/// The grid `resolution` places around `bounds`, once `estimate` of the work on it fits in
/// `limit` bytes; a refusal names the largest resolution that fits.
fn checked_grid(
    bounds: &Aabb,
    resolution: Resolution,
    limit: u64,
    estimate: impl Fn(&Grid) -> Estimate,
) -> Result<Grid> {
    let grid = Grid::around(bounds, resolution)?;
    estimate(&grid).check_grid(limit, |n| {
        let grid = Grid::around(bounds, Resolution::LongestAxis(n)).ok()?;
        Some(estimate(&grid).bytes)
    })?;
    Ok(grid)
}

/// The densities, the voxel signed distance or the exact signed distance of `mesh` (`kind`) on
/// the grid `options.resolution` places around it, and how its inside was decided. `source`
/// names the mesh in errors. The voxel signed distance is in voxels (paper 4.2), the exact one
/// in mesh units (computed in f64, stored as f32), both inside positive with the same sign.
///
/// # Errors
/// An option out of range, a mesh without triangles (or, for the exact distance, with an index
/// out of range or a non-finite coordinate), a grid that cannot be placed or does not fit in
/// the memory limit, and the errors of [`voxelize::voxelize`].
pub fn volume(
    mesh: &Mesh,
    source: &str,
    kind: VolumeKind,
    options: &VolumeOptions,
) -> Result<(Volume<f32>, Inside)> {
    options.check(kind).map_err(|e| e.in_context(source))?;
    let bounds = mesh_bounds(mesh, source)?;
    let limit = options.memory_limit.bytes();
    let triangles = mesh.triangles.len();
    let estimate = |g: &Grid| match kind {
        VolumeKind::ExactSignedDistance => Estimate::exact_volume(g.dims, triangles),
        _ => Estimate::volume(g.dims, triangles),
    };
    let grid = checked_grid(&bounds, options.resolution, limit, estimate)
        .map_err(|e| e.in_context(source))?;
    let voxelized =
        voxelize::voxelize(mesh, &grid, &options.voxelize).map_err(|e| e.in_context(source))?;
    let volume = match kind {
        VolumeKind::Density => voxelized.density,
        VolumeKind::SignedDistance => {
            let inside = edt::inside(&voxelized.density);
            drop(voxelized.density);
            edt::signed_distance(&inside)
        }
        VolumeKind::ExactSignedDistance => {
            let query = MeshQuery::new(mesh).map_err(|e| e.in_context(source))?;
            mesh_query::grid::signed_distance(&query, voxelized.density, options.band)
        }
    };
    Ok((volume, voxelized.inside))
}

/// The exact distance from each of `points` to `mesh`'s triangles and the closest points (see
/// `crate::mesh_query`), signed (inside as the voxelizer decides it) unless `options` says not to.
/// `source` names the mesh in errors.
///
/// # Errors
/// A mesh without triangles, with an index out of range or a non-finite coordinate; a
/// non-finite point; an estimate that does not fit in the memory limit.
pub fn distance(
    mesh: &Mesh,
    source: &str,
    points: &[DVec3],
    options: &DistanceOptions,
) -> Result<Distances> {
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(Error::invalid(
            source,
            format!("point {i} has a non-finite coordinate: {}", points[i]),
        ));
    }
    Estimate::distance(mesh.triangles.len(), points.len(), options.signed)
        .check(options.memory_limit.bytes(), || None)
        .map_err(|e| e.in_context(source))?;
    let query = MeshQuery::new(mesh).map_err(|e| e.in_context(source))?;
    let nearest = query.nearest_all(points);
    let values = if options.signed {
        let inside = query.inside(points);
        nearest
            .iter()
            .zip(inside)
            .map(|(n, inside)| mesh_query::signed(n.distance, inside))
            .collect()
    } else {
        nearest.iter().map(|n| n.distance).collect()
    };
    Ok(Distances { values, nearest })
}

/// `n` points near `mesh`'s surface and uniform around it, with the exact signed distance at
/// each (inside positive, mesh units), drawn as DeepSDF draws them and as `options` say:
/// `round(uniform n)` points uniform in the mesh's box grown by 10% of its size on every side,
/// the rest split evenly among the standard deviations of `near_surface`, each a point uniform
/// on a triangle chosen by area plus Gaussian noise of that deviation times the box's
/// diagonal. The same mesh, `n` and options give the same samples bit for bit on any number of
/// threads. `source` names the mesh in errors.
///
/// # Errors
/// An option out of range or `n` of 0; a mesh without triangles, with an index out of range
/// or a non-finite coordinate, or without area to draw near points from; an estimate that does
/// not fit in the memory limit.
pub fn sample(mesh: &Mesh, source: &str, n: usize, options: &SampleOptions) -> Result<Samples> {
    options.check()?;
    if n == 0 {
        return Err(Error::invalid("options", "the number of points must be at least 1, not 0"));
    }
    Estimate::sample(mesh.triangles.len(), n)
        .check(options.memory_limit.bytes(), || None)
        .map_err(|e| e.in_context(source))?;
    let query = MeshQuery::new(mesh).map_err(|e| e.in_context(source))?;
    crate::sample::sample(mesh, &query, source, n, options)
}

/// The zero set of `field` (inside positive) polygonized on the grid `options.resolution`
/// places around `bounds` (see [`crate::polygonize::polygonize_field`] and
/// [`crate::polygonize::polygonize_field_dense`]). `source` names the field in errors.
///
/// # Errors
/// A grid that cannot be placed or does not fit in the memory limit.
pub fn polygonize<F: Field + ?Sized>(
    field: &F,
    bounds: &Aabb,
    source: &str,
    options: &PolygonizeOptions,
) -> Result<Mesh> {
    let limit = options.memory_limit.bytes();
    let grid = checked_grid(bounds, options.resolution, limit, |g| {
        Estimate::polygonize(g.dims, options.dense)
    })
    .map_err(|e| e.in_context(source))?;
    Ok(if options.dense {
        crate::polygonize::polygonize_field_dense(field, &grid)
    } else {
        crate::polygonize::polygonize_field(field, &grid)
    })
}

/// `bounds` grown by half of `shell` on every side, for the grid `resolution` places around
/// them: the thickened surface's bounds.
///
/// # Errors
/// A grid that cannot be placed ([`Grid::around`]).
fn shell_bounds(bounds: &Aabb, shell: Shell, resolution: Resolution) -> Result<Aabb> {
    let voxel_size = Grid::around(bounds, resolution)?.voxel_size;
    let half = DVec3::splat(shell.in_mesh_units(voxel_size) / 2.0);
    Ok(Aabb { min: bounds.min - half, max: bounds.max + half })
}

/// The area of `mesh`'s triangles (those whose indices are in range), mesh units squared.
fn mesh_area(mesh: &Mesh) -> f64 {
    let vertex = |i: u32| mesh.vertices.get(i as usize).copied();
    mesh.triangles
        .iter()
        .filter_map(|&[a, b, c]| {
            let (a, b, c) = (vertex(a)?, vertex(b)?, vertex(c)?);
            Some((b - a).cross(c - a).length() / 2.0)
        })
        .filter(|area| area.is_finite())
        .sum()
}

/// The goal's surface points a surface of `area` (mesh units squared) gives on `grid`, before
/// it is voxelized: about one a voxel of area (measured: 0.87 to 0.90 of `area` in voxels on
/// the paper's models at 512).
fn surface_points(area: f64, grid: &Grid) -> usize {
    area_in_voxels(area, grid).ceil() as usize
}

/// `area` (mesh units squared) in faces of `grid`'s voxels.
fn area_in_voxels(area: f64, grid: &Grid) -> f64 {
    area / (grid.voxel_size * grid.voxel_size)
}

fn mesh_bounds(mesh: &Mesh, source: &str) -> Result<Aabb> {
    mesh.bounds().ok_or_else(|| Error::invalid(source, "the mesh has no triangles"))
}

impl MeshFitOptions {
    /// Whether the fit on `grid` has detail levels ([`fit::detail::applies`]).
    fn has_levels(&self, grid: &Grid) -> bool {
        self.method == Method::Iterative && fit::detail::applies(grid, &self.fit)
    }
}

impl<'a> Prepared<'a> {
    /// Places the grid around `mesh`, checks the fit's memory estimate on it, voxelizes the
    /// mesh, measures how thick the solid is ([`Thickness`], with the mesh's exact distance
    /// query) and computes the goal (signed distance, boundary voxels, radii of regularity), to
    /// which a fit with detail levels adds points on the mesh ([`Goal::with_mesh_points`]) and
    /// the sub-voxel measure ([`ErrorMeasure::SubVoxel`]) adds that query
    /// ([`Goal::with_mesh`]). `source` names the mesh in errors.
    ///
    /// # Errors
    /// An `IMPLICITIZE_ISA` this CPU cannot run ([`Isa::from_env`]), an option out of range, a
    /// grid that cannot be placed or does not fit in the memory limit, the errors of
    /// [`voxelize::voxelize`] and `MeshQuery::new`, and a solid too thin for the grid
    /// ([`Error::Thin`], see [`Thickness::refusal`]), refused before its goal is made.
    pub fn new(mesh: &'a Mesh, source: &str, options: &MeshFitOptions) -> Result<Prepared<'a>> {
        Isa::from_env()?;
        options.check()?;
        let mesh_bounds = mesh_bounds(mesh, source)?;
        let bounds = match options.shell {
            Some(shell) => shell_bounds(&mesh_bounds, shell, options.resolution)
                .map_err(|e| e.in_context(source))?,
            None => mesh_bounds,
        };
        let limit = options.memory_limit.bytes();
        let triangles = mesh.triangles.len();
        let clock = Instant::now();
        // A shell's surface is the mesh's two faces.
        let faces = if options.shell.is_some() { 2.0 } else { 1.0 };
        let area = faces * mesh_area(mesh);
        let goal_grid = |g: &Grid| match options.shell {
            None if options.has_levels(g) => fit::detail::goal_grid(g, &options.fit),
            _ => *g,
        };
        let estimate = |g: &Grid, goal: &Grid| {
            let fit = if options.has_levels(g) {
                Estimate::levels(goal.dims, g.dims, triangles, surface_points(area, g))
            } else {
                Estimate::fit(g.dims, triangles)
            };
            let fit = fit.followed_by(&Estimate::measured_surface(area_in_voxels(area, g)));
            if options.shell.is_some() {
                fit.plus(&Estimate::shell(g.dims, triangles))
            } else {
                fit
            }
        };
        let grid = checked_grid(&bounds, options.resolution, limit, |g| estimate(g, &goal_grid(g)))
            .map_err(|e| e.in_context(source))?;
        let query = Arc::new(MeshQuery::new(mesh).map_err(|e| e.in_context(source))?);
        let volumes = |goal_grid: &Grid| -> Result<(Voxelized, Volume<f32>, Thickness)> {
            let voxelized = voxelize::voxelize(mesh, goal_grid, &options.voxelize)
                .map_err(|e| e.in_context(source))?;

            let sd = edt::signed_distance(&edt::inside(&voxelized.density));
            let thickness = Thickness::measure(&sd, mesh, &query, options.fit.seed);
            Ok((voxelized, sd, thickness))
        };
        let mut goal_grid = goal_grid(&grid);
        if options.shell.is_none() && !options.solid {
            let ambiguity =
                voxelize::ambiguity_of(mesh, &goal_grid).map_err(|e| e.in_context(source))?;
            if let Some(refusal) = ambiguity.refusal(source) {
                return Err(refusal);
            }
        }
        let (mut voxelized, mut sd, mut thickness) = volumes(&goal_grid)?;
        let longest = |g: &Grid| g.dims.into_iter().max().unwrap_or(0);
        if goal_grid != grid
            && (!thickness.is_held() || thickness.warning(longest(&goal_grid)).is_some())
        {
            // Walls the coarser goal loses or thins are voxelized on the grid asked for.
            drop((voxelized, sd));
            estimate(&grid, &grid).check(limit, || None).map_err(|e| e.in_context(source))?;
            goal_grid = grid;
            (voxelized, sd, thickness) = volumes(&goal_grid)?;
        }
        let longest_axis = longest(&goal_grid);
        let goal = match options.shell {
            Some(shell) => {
                drop((sd, voxelized.density));
                let density = shell::densities(&query, &grid, shell.in_mesh_units(grid.voxel_size));
                Goal::from_density(density, &options.fit.regularity)
            }
            None => {
                if let Some(refusal) = thickness.refusal(source, longest_axis) {
                    return Err(refusal);
                }
                let mut goal =
                    Goal::from_signed_distance(voxelized.density, sd, &options.fit.regularity);
                if options.has_levels(&grid) {
                    let inside = &voxelized.inside;
                    goal = with_mesh_points(goal, mesh, &query, &grid, &options.fit, inside);
                }
                match options.fit.error_measure {
                    ErrorMeasure::SubVoxel => goal.with_mesh(query.clone()),
                    ErrorMeasure::Voxel => goal,
                }
            }
        };
        let goal_seconds = clock.elapsed().as_secs_f64();
        let inside = voxelized.inside;
        let options = options.clone();
        let source = source.to_string();
        Ok(Prepared {
            mesh,
            source,
            bounds,
            grid,
            goal,
            inside,
            query,
            thickness,
            options,
            limit,
            area,
            goal_seconds,
        })
    }

    /// How the voxelization decided the mesh's inside.
    pub fn inside(&self) -> Inside {
        self.inside
    }

    /// How thick the goal's solid is, and whether the grid holds it.
    pub fn thickness(&self) -> Thickness {
        self.thickness
    }

    /// What a user should know before the fit, one line each (no file name, settings
    /// backquoted as in errors): a mesh open enough that its inside is a guess, and for a solid
    /// (no `shell`), walls the fit may not hold.
    pub fn warnings(&self) -> Vec<String> {
        warnings(&self.inside, Some(&self.thickness), self.options.shell, self.goal.grid().dims)
    }

    /// The grid asked for, whose voxels the fit's errors are stated in: the grid the mesh was
    /// voxelized on, unless a fit with detail levels voxelizes its goal on a coarser one
    /// (`fit::detail::goal_grid`; [`Prepared::goal`] has its grid).
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The mesh's bounds, mesh units.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The goal: the voxelized mesh, its signed distance and radii of regularity.
    pub fn goal(&self) -> &Goal {
        &self.goal
    }

    /// The goal, for callers that stop before the fit (pictures of the goal).
    pub fn into_goal(self) -> Goal {
        self.goal
    }

    /// Runs the fit. `on_iteration` is called after each iteration of the iterative method
    /// with its figures and its model (for progress lines and pictures); the naive method
    /// solves once and does not call it.
    ///
    /// The constraints are capped where their solve would pass the memory limit: a fit that
    /// reaches that cap ends there ([`Termination::MemoryLimit`]) with its best model.
    ///
    /// The model's zero set is then polygonized on the fit's grid ([`Fitted::surface`]) and
    /// measured against the mesh both ways, exactly (`crate::metrics::surface`): the
    /// report's `mesh_distance`. That runs once the fit's iteration volumes and solve are
    /// freed, and has no estimate of its own: the polygonization and the two distance
    /// hierarchies (about 260 bytes a triangle of either surface).
    ///
    /// # Errors
    /// What the fit's solve reports (see [`fit::fit`]); a goal whose constraints cannot make a
    /// first model is refused as too thin ([`Error::Thin`], naming the thickness measured).
    pub fn fit(mut self, on_iteration: impl FnMut(&IterationReport, &Implicit)) -> Result<Fitted> {
        let longest_axis = self.goal.grid().dims.into_iter().max().unwrap_or(0);
        let thin = |e: Error| match e {
            Error::Thin { .. } => Error::Thin {
                context: self.source.clone(),
                message: self.thickness.why(longest_axis),
            },
            other => other,
        };
        // The surface the model is measured against: the mesh, or a shell's thickened surface
        // polygonized from the goal's densities (which a fit with levels may free).
        let thickened =
            self.options.shell.map(|_| crate::polygonize::polygonize(self.goal.density(), 0.5));
        // An open mesh's solid is the one its winding number defines: the model is measured
        // against that solid's surface too (the goal's densities polygonized at 1/2).
        let open_solid = (self.options.shell.is_none() && self.inside.winding_near_half > 0.0)
            .then(|| crate::polygonize::polygonize(self.goal.density(), 0.5));
        let mut options = self.options.fit.clone();
        let requested = match self.options.method {
            Method::Iterative => options.constraint_limit(),
            Method::Naive => {
                options.max_constraints.unwrap_or(Method::Naive.default_max_constraints())
            }
        };
        let allowed = self.constraints_within_memory(requested);
        options.max_constraints = Some(allowed);
        let (shape, mut report) = match (self.options.method, self.options.shell) {
            (Method::Iterative, Some(shell)) if options.levels.max_levels > 0 => {
                self.levels_estimate().check(self.limit, || None)?;
                let voxel = self.goal.grid().voxel_size;
                let half = shell.in_mesh_units(voxel) / voxel / 2.0;
                // The middle of the wall, about as many points as one of its faces has.
                let n = self.goal.surface().len() / 2;
                let mid = metrics::surface::sample(self.mesh, n, options.seed).unwrap_or_default();
                let fitted = fit::detail::fit_shell(&self.goal, &mid, half, &options)?;
                (fitted.shape, fitted.report)
            }
            (Method::Iterative, _) if fit::detail::applies(&self.grid, &options) => {
                self.levels_estimate().check(self.limit, || None)?;
                let mut on_iteration = on_iteration;
                let fitted =
                    fit::detail::fit(&mut self.goal, &self.grid, &options, &mut on_iteration)
                        .map_err(thin)?;
                (fitted.shape, fitted.report)
            }
            (Method::Iterative, _) => {
                let mut on_iteration = on_iteration;
                // A loop that needs many constraints hands over to detail levels.
                let loop_limit = fit::detail::loop_limit(&self.grid, &self.options.fit, allowed);
                let mut loop_options = options.clone();
                loop_options.max_constraints = loop_limit.or(options.max_constraints);
                loop_options.hand_over = loop_limit
                    .map(|limit| fit::HandOver::new(&options.levels, limit, options.target_error));
                let mut fitted =
                    fit::fit(&self.goal, &loop_options, &mut on_iteration).map_err(thin)?;
                if let Some(limit) = loop_limit
                    && fitted.report.termination == (Termination::ConstraintLimit { limit })
                {
                    fitted.report.termination = Termination::LoopLimit { constraints: limit };
                }
                let stalled = fit::detail::stalled(&fitted.report, &self.grid, &options);
                // Where the loop met its target: points on the mesh where the goal agrees with
                // it, and how far they lie from its model (voxels), if farther than the target
                // allows.
                let on_mesh = fit::detail::checks_mesh(&fitted.report, &self.grid, &options)
                    .then(|| agreeing_points(&self.goal, self.mesh, &self.grid, &options));
                let slack = options.levels.mesh_slack;
                let far = on_mesh
                    .as_ref()
                    .and_then(|on| fit::detail::mesh_distance(on, &fitted.implicit, &self.grid))
                    .filter(|&far| far > f64::from(options.target_error) + slack);
                if stalled || far.is_some() {
                    // Detail levels go on where the paper's loop stalled (the better of the two,
                    // by E, or the one that meets the target) or left the mesh's points farther
                    // than the target allows (the levels' fit, where it meets the target and
                    // brings them nearer).
                    self.goal = with_mesh_points(
                        self.goal,
                        self.mesh,
                        &self.query,
                        &self.grid,
                        &options,
                        &self.inside,
                    );
                    let levelled = fit::detail::after_stall(&options);
                    self.levels_estimate().check(self.limit, || None)?;
                    let mut again =
                        fit::detail::fit(&mut self.goal, &self.grid, &levelled, &mut on_iteration)
                            .map_err(thin)?;
                    // Level 0 stops where the loop would have handed over (`after_stall`).
                    let limit = levelled.levels.loop_constraints;
                    if levelled.max_constraints == Some(limit)
                        && again.report.termination == (Termination::ConstraintLimit { limit })
                    {
                        again.report.termination = Termination::LoopLimit { constraints: limit };
                    }
                    let measure = options.error_measure;
                    let target = options.target_error;
                    let met = |r: &FitReport| r.target_outcome(measure, target).met;
                    let better = match far {
                        Some(far) => {
                            met(&again.report)
                                && on_mesh
                                    .as_ref()
                                    .and_then(|on| {
                                        fit::detail::mesh_distance(on, &again.shape, &self.grid)
                                    })
                                    .is_some_and(|levelled| levelled < far)
                        }
                        None => {
                            again.report.error_by(measure) < fitted.report.error_by(measure)
                                || (met(&again.report) && !met(&fitted.report))
                        }
                    };
                    if better {
                        let mut report = again.report;
                        report.timings_s.add(&fitted.report.timings_s);
                        report.paper_loop = Some(fit::PaperLoop {
                            termination: fitted.report.termination,
                            iterations: fitted.report.iterations,
                            max_error_voxels: fitted.report.max_error_voxels,
                            mesh_p999_voxels: far,
                        });
                        (again.shape, report)
                    } else {
                        (Shape::Rbf(fitted.implicit), fitted.report)
                    }
                } else {
                    (Shape::Rbf(fitted.implicit), fitted.report)
                }
            }
            (Method::Naive, _) => {
                let fitted = fit::naive::fit(self.mesh, &self.goal, &options)?;
                (Shape::Rbf(fitted.implicit), fitted.report)
            }
        };
        if allowed < requested
            && report.termination == (Termination::ConstraintLimit { limit: allowed })
        {
            report.termination = Termination::MemoryLimit { constraints: allowed };
        }
        report.timings_s.signed_distance += self.goal_seconds;
        report.timings_s.total += self.goal_seconds;
        report.winding_near_half = Some(self.inside.winding_near_half);
        report.target = Some(report.target_outcome(options.error_measure, options.target_error));
        let goal_scale = self.goal.grid().voxel_size / self.grid.voxel_size;
        report.thickness = Some(self.thickness.in_smaller_voxels(goal_scale));
        let grid = self.grid;
        // The goal's volumes are freed before the model is polygonized and measured.
        drop(self.goal);
        let model = Model::from_shape(shape, self.bounds, Some(grid));
        let surface = crate::polygonize::polygonize_field(&model, &grid);
        let (voxel, seed, solid) = (grid.voxel_size, options.seed, open_solid.as_ref());
        report.mesh_distance = match &thickened {
            None => metrics::surface::between(&self.query, &surface, solid, voxel, seed),
            Some(thickened) => {
                let query =
                    MeshQuery::new(thickened).map_err(|e| e.in_context("the thickened surface"))?;
                metrics::surface::between(&query, &surface, None, voxel, seed)
            }
        }
        .map_err(|e| e.in_context("the model's polygonized surface"))?;
        report.shell_voxels =
            self.options.shell.map(|s| s.in_mesh_units(grid.voxel_size) / grid.voxel_size);
        Ok(Fitted { model, report, inside: self.inside, surface })
    }

    /// The memory a fit with detail levels holds at the goal's surface points (see
    /// [`Estimate::levels`]; the check before the goal estimated them from the mesh's area),
    /// or its model's surface after it ([`Estimate::measured_surface`]).
    fn levels_estimate(&self) -> Estimate {
        let points = self.goal.mesh_points().map_or(0, <[_]>::len).max(self.goal.surface().len());
        let goal_dims = self.goal.grid().dims;
        let surface = Estimate::measured_surface(area_in_voxels(self.area, &self.grid));
        Estimate::levels(goal_dims, self.grid.dims, self.mesh.triangles.len(), points)
            .followed_by(&surface)
    }

    /// The most constraints, up to `requested`, whose solve fits in the memory limit beside the
    /// fit's grids (never fewer than a dense solve's, which the grid's check made room for).
    fn constraints_within_memory(&self, requested: usize) -> usize {
        let dims = self.goal.grid().dims;
        let triangles = self.mesh.triangles.len();
        let floor = requested.min(crate::rbf::DIRECT_MAX);
        crate::memory::largest_fitting(floor..=requested, self.limit, |n| {
            Some(Estimate::fit_solving(dims, triangles, n).bytes)
        })
        .unwrap_or(floor)
    }
}

/// Points drawn on `mesh` where `goal` agrees with it, as many as [`with_mesh_points`] draws,
/// without the slits' walls: where a fit that met its target is checked against the mesh
/// ([`fit::detail::mesh_distance`]).
fn agreeing_points(goal: &Goal, mesh: &Mesh, grid: &Grid, fit: &FitOptions) -> Vec<DVec3> {
    let (n, agreement) = mesh_points_of(goal, grid);
    let points = metrics::surface::sample(mesh, n, fit.seed).unwrap_or_default();
    goal.agreeing(points, agreement)
}

/// How many points the levels draw on the mesh for `goal` in a fit on `grid` (as many as
/// `grid` has surface voxels), and how near the goal's surface they must lie to be kept
/// ([`fit::MESH_AGREEMENT`] voxels of `grid`), in voxels of the goal.
fn mesh_points_of(goal: &Goal, grid: &Grid) -> (usize, f32) {
    let scale = goal.grid().voxel_size / grid.voxel_size;
    let n = (goal.surface().len() as f64 * scale * scale).round() as usize;
    (n, fit::MESH_AGREEMENT * scale as f32)
}

/// `goal` with points on `mesh` for its detail levels ([`Goal::with_mesh_samples`]): as many as
/// `grid`, the grid asked for, has surface voxels, kept where they agree with the goal within
/// [`fit::MESH_AGREEMENT`] of `grid`'s voxels, once the slits narrower than a voxel are carved.
/// Slits are looked for only where the mesh's inside (decided as `inside`) is nowhere a guess:
/// near an open mesh's holes the two sides of a face can differ by a guess, not by a gap.
fn with_mesh_points(
    goal: Goal,
    mesh: &Mesh,
    query: &MeshQuery,
    grid: &Grid,
    fit: &FitOptions,
    inside: &Inside,
) -> Goal {
    let (n, agreement) = mesh_points_of(&goal, grid);
    if inside.winding_near_half > 0.0 {
        return match metrics::surface::sample(mesh, n, fit.seed) {
            Some(points) => goal.with_mesh_points(points, agreement),
            None => goal,
        };
    }
    // More points find a slit's walls than the levels fit: the first `n` of them are those of
    // `n` points drawn alone.
    match metrics::surface::sample_with_normals(mesh, n * fit::WALL_SAMPLES, fit.seed) {
        Some(samples) => goal.with_mesh_samples(
            samples,
            n,
            agreement,
            query,
            fit::WALL_STEP * grid.voxel_size,
            &fit.regularity,
        ),
        None => goal,
    }
}

/// Warnings (one line each, no file name, settings backquoted as in errors, see
/// [`crate::error::worded`]) about a fit on a grid of `dims` whose inside was decided as
/// `inside`: a mesh open enough that its inside is a guess
/// ([`crate::voxelize::Ambiguity::warning`]), and for a solid (no `shell`), walls the fit may
/// not hold ([`Thickness::warning`]).
pub(crate) fn warnings(
    inside: &Inside,
    thickness: Option<&Thickness>,
    shell: Option<Shell>,
    dims: [usize; 3],
) -> Vec<String> {
    let longest_axis = dims.into_iter().max().unwrap_or(0);
    let thin = thickness.filter(|_| shell.is_none()).and_then(|t| t.warning(longest_axis));
    inside.ambiguity.warning().into_iter().chain(thin).collect()
}

/// What a fit's outcome warns of, one line each (no file name): a target not met
/// (`above_target`), faces inside the mesh's own solid (`interior_surface`). The warnings
/// known before the fit are [`Prepared::warnings`]; [`Fitted::warnings`] gives both.
pub fn outcome_warnings(report: &FitReport) -> Vec<String> {
    above_target(report).into_iter().chain(interior_surface(report)).collect()
}

/// A warning (one line, no file name) when a fit ended above its target: the E reached and the
/// target, why it stopped, and where the mesh lies farthest from the model; for a fit of the
/// paper's loop that stopped improving, that a grid from [`fit::LevelOptions::min_axis`] voxels adds
/// detail levels where it stalls.
pub(crate) fn above_target(report: &FitReport) -> Option<String> {
    let target = report.target.filter(|t| !t.met)?;
    let (error, stopped) = match &report.levels {
        Some(levels) => (
            "the largest error at the goal's surface points",
            format!("its detail levels stopped: {}", levels.stopped),
        ),
        None => ("E", loop_stop(report)),
    };
    let farthest = report.mesh_distance.map(|d| {
        let [x, y, z] = d.mesh_to_model.farthest;
        format!(
            "; the mesh lies farthest from the model ({:.1} voxels) at ({x:.4}, {y:.4}, {z:.4})",
            d.mesh_to_model.max
        )
    });
    let stalled = report.levels.is_none()
        && matches!(
            report.termination,
            Termination::NoImprovement { .. } | Termination::NoCandidate
        );
    let finer = stalled.then(|| {
        format!(
            "; at `resolution={}` or finer, detail levels correct what the paper's loop misses",
            fit::LevelOptions::default().min_axis
        )
    });
    Some(format!(
        "the fit ended above its target: {error} {:.2} voxels for a target of {:.2}; {stopped}{}{}",
        target.reached_voxels,
        target.target_voxels,
        farthest.unwrap_or_default(),
        finer.unwrap_or_default()
    ))
}

/// Why the paper's loop of `report` stopped, for [`above_target`]: a loop that reached its
/// target ended above it only by the rounding of its numbers to the model file's lattice,
/// which says so with the E before it.
fn loop_stop(report: &FitReport) -> String {
    let best = report.best_iteration.checked_sub(1).and_then(|i| report.per_iteration.get(i));
    match (report.termination, best) {
        (Termination::TargetError { measure, .. }, Some(best)) => format!(
            "it reached {:.2} voxels, and rounding the model's numbers to the lattice of its \
             file moved its surface (the nearest of the precisions tried is kept)",
            match measure {
                ErrorMeasure::Voxel => best.max_error_voxels,
                ErrorMeasure::SubVoxel => best.max_error_subvoxel_voxels,
            }
        ),
        _ => format!("it stopped: {}", report.termination),
    }
}

/// A warning (one line, no file name) when more than
/// `INTERIOR_NOTABLE` of the mesh's surface lies inside its own solid
/// ([`metrics::surface::interior`]): faces no solid's surface holds, which the model leaves
/// out; with how close the rest of the mesh is to the model.
pub(crate) fn interior_surface(report: &FitReport) -> Option<String> {
    let d = report.mesh_distance?;
    let rest = d.bounding_to_model?;
    let solid = d.solid_to_model.map(|solid| {
        format!(", the surface of the solid its winding number defines within {:.2}", solid.p99_9)
    });
    Some(format!(
        "{:.1}% of the mesh's surface lies inside its own solid (faces with the solid on both \
         sides, such as overlapping parts), which no solid's surface holds; the rest of the mesh \
         lies within {:.2} voxels of the model (99.9%){}",
        100.0 * d.interior,
        rest.p99_9,
        solid.unwrap_or_default()
    ))
}

impl Fitted {
    /// What a user should know of this fit: the warnings known before it
    /// ([`Prepared::warnings`]) and those of its outcome ([`outcome_warnings`]).
    pub fn warnings(&self) -> Vec<String> {
        let shell = self.report.shell_voxels.map(Shell::Voxels);
        let mut warnings =
            warnings(&self.inside, self.report.thickness.as_ref(), shell, self.report.dims);
        warnings.extend(outcome_warnings(&self.report));
        warnings
    }

    /// Embeds the report in the model as the JSON model file keeps it, and records the size of
    /// the binary model file in the report (`model_bytes`, and for detail levels what each
    /// level adds to it).
    ///
    /// The embedded report leaves out the running times, so that the same mesh, options and
    /// seed give the same model file byte for byte; [`Fitted::report`] keeps them.
    pub fn finish(&mut self) {
        self.report.model_bytes = Some(self.model.to_bytes().len() as u64);
        if let (Some(levels), Some(sizes)) =
            (&mut self.report.levels, self.model.binary_bytes_by_level())
        {
            levels.base_bytes = sizes[0] as usize;
            for (level, pair) in levels.levels.iter_mut().zip(sizes.windows(2)) {
                level.bytes = (pair[1] - pair[0]) as usize;
            }
        }
        self.model.set_report(without_timings(&self.report));
    }

    /// Writes the model, the report and the surface ([`Fitted::surface`]) `outputs` name (not the signed distance,
    /// which only [`fit()`] has), each atomically.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn write(&self, outputs: &FitOutputs) -> Result<()> {
        if let Some(path) = &outputs.model {
            let format = outputs.model_format.unwrap_or_else(|| ModelFormat::for_path(path));
            self.model.save_as(path, format)?;
        }
        if let Some(path) = &outputs.report {
            let report =
                serde_json::to_string_pretty(&self.report).expect("a report always serializes");
            crate::output::write_bytes(path, format!("{report}\n").as_bytes())?;
        }
        if let Some(path) = &outputs.surface {
            mesh::write(path, &self.surface)?;
        }
        Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::DVec3;

    /// A unit cube of 12 triangles.
    fn cube() -> Mesh {
        let vertices = (0..8)
            .map(|c| DVec3::new(f64::from(c & 1), f64::from(c >> 1 & 1), f64::from(c >> 2 & 1)))
            .collect();
        let quads =
            [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let triangles =
            quads.iter().flat_map(|[a, b, c, d]| [[*a, *b, *c], [*a, *c, *d]]).collect();
        Mesh { vertices, triangles }
    }

    /// A search with levels grows while the budget suggests a quarter more resolution, and
    /// reaches the largest grid when the suggestion passes it, however near it is.
    #[test]
    fn a_budget_search_with_levels_grows_to_the_largest_grid() {
        // The triceratops at 512 voxels was 30,367 bytes: 100 KB suggests 836 voxels.
        assert_eq!(larger_with_levels(512, 30_367, 100_000), Some(836));
        // At 836 voxels, 42,798 bytes: more than 1,024 suggested, so 1,024 (a fifth more).
        assert_eq!(larger_with_levels(836, 42_798, 100_000), Some(BUDGET_MAX_RESOLUTION));
        assert_eq!(larger_with_levels(BUDGET_MAX_RESOLUTION, 66_396, 500_000), None);
        // The bunny at 512 voxels, 79,946 bytes: 100 KB suggests less than a quarter more.
        assert_eq!(larger_with_levels(512, 79_946, 100_000), None);
    }

    #[test]
    fn the_constraints_are_capped_where_their_solve_would_pass_the_memory_limit() {
        let mesh = cube();
        let options =
            MeshFitOptions { resolution: Resolution::LongestAxis(16), ..Default::default() };
        let cap = |limit: MemoryLimit| {
            let mut options = options.clone();
            options.memory_limit = limit;
            let prepared = Prepared::new(&mesh, "cube", &options).unwrap();
            (prepared.constraints_within_memory(fit::MAX_CONSTRAINTS), *prepared.grid())
        };
        let (unlimited, grid) = cap(MemoryLimit::Bytes(u64::MAX));
        assert_eq!(unlimited, fit::MAX_CONSTRAINTS);
        let estimate = |n: usize| Estimate::fit_solving(grid.dims, 12, n).bytes;
        let limit = Estimate::fit(grid.dims, 12).bytes + (300 << 20);
        let (capped, _) = cap(MemoryLimit::Bytes(limit));
        assert!((crate::rbf::DIRECT_MAX..fit::MAX_CONSTRAINTS).contains(&capped), "{capped}");
        assert!(estimate(capped) <= limit && estimate(capped + 1) > limit);
        let tight = Estimate::fit(grid.dims, 12).bytes;
        assert_eq!(cap(MemoryLimit::Bytes(tight)).0, crate::rbf::DIRECT_MAX, "a dense solve fits");
    }

    #[test]
    fn a_grid_beyond_the_limit_is_refused_naming_the_largest_resolution() {
        let mesh = cube();
        let mut options = MeshFitOptions {
            resolution: Resolution::LongestAxis(1000),
            memory_limit: MemoryLimit::Bytes(256 << 20),
            ..Default::default()
        };
        let error = Prepared::new(&mesh, "cube.obj", &options).unwrap_err();
        assert!(matches!(error, Error::Memory { .. }));
        let message = error.worded(crate::error::FrontEnd::Cli);
        assert!(message.starts_with("cube.obj: a grid of 1000 x 1000 x 1000 voxels: needs"));
        let largest: usize = message.rsplit("--resolution ").next().unwrap().parse().unwrap();
        options.resolution = Resolution::LongestAxis(largest);
        assert!(Prepared::new(&mesh, "cube.obj", &options).is_ok());
        options.resolution = Resolution::LongestAxis(largest + 1);
        assert!(matches!(Prepared::new(&mesh, "cube.obj", &options), Err(Error::Memory { .. })));
    }
}
