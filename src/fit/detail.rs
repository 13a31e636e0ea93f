//! Detail levels over the paper's fit (see [`crate::rbf::MultiScale`]): level 0 is the iterative fit of
//! paper 5 on the goal at a fraction of the resolution, each further level a sum of Wendland
//! functions fitted to what the levels below leave on the full grid.
//!
//! ```text
//! level 0 = the loop of paper 5 on the pyramid's coarsest goal (coarse.rs), to its own target
//! points  = points on the mesh where the goal agrees with it (Goal::with_mesh_points), as
//!           many as the goal has surface points, and the goal's surface points (one per
//!           boundary voxel) farther than a voxel from them; goal value 0
//!           (with the walls of slits narrower than a voxel, once the goal is carved: slit.rs)
//! band    = the voxels whose goal signed distance is between 1.5 and level 0's E + 2 voxels,
//!           and the voxels opened in the slits' gaps
//! for k = 1, 2, ... while (max |r| > target or a band voxel has the wrong side)
//!                   and k <= max_levels and rho_k >= min_radius
//!                   (down to min_radius / 2 while an opened voxel is inside: gap_level):
//!     r       = 0 - F at the points; sd_goal - F at the band voxels on the wrong side (voxels)
//!     rho_k   = first_radius voxels of level 0 / 2^(k-1)
//!     centres = points and wrong-side voxels where |r| is largest, greedily, each at least
//!               spacing x rho_k from the others, among those within rho_k of one whose |r| is
//!               above hot_fraction x target
//!     g_k     = the Wendland interpolant of r at its centres (a sparse SPD solve)
//! ```
//!
//! The residual is taken at points on the mesh's triangles, or at the goal's surface points,
//! where the goal's signed distance is 0 to sub-voxel precision ([`Goal::surface`]): the
//! value there is how far the model's zero set lies from that point, in voxels, where the
//! model's slope is one (level 0 interpolates signed
//! distances, so its slope near the surface is close to one). Away from the surface only the
//! side matters: a band voxel joins the data only where the model has the wrong side, so that
//! spurious pieces of level 0's surface within the band are removed without asking the model
//! to be a distance function there. As in the paper, centres go where the error is worst and
//! are pruned by spacing (Ohtake, Belyaev and Seidel 2003 space theirs a fraction of the
//! support apart). The report's E is then measured on the goal's grid, both ways, as for any fit.
//!
//! Level 0 fits on the coarsest goal of the pyramid (512 voxels: 131), where each iteration costs
//! a sixty-fourth of one on the full grid; `first_radius` (4 of its voxels, 16 of a 512 grid) is
//! about twice the spacing of its constraints, the scale of what it can miss.
//!
//! Above [`LevelOptions::max_goal_axis`] (512 voxels) the goal itself is voxelized at half the
//! resolution ([`goal_grid`]; 1024 voxels: 515), and the pyramid and level 0 below it: the goal's
//! volumes and the measure's, 13 bytes a voxel, are what a grid of 1024 cannot hold, and the
//! levels need of the goal only its inside, its band and its E. They reach the grid asked for
//! through the mesh's points, as many as that grid has surface voxels; the residuals, the
//! target, the supports and the report are in voxels of that grid.

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use super::report::{
    FitReport, GridLevel, IterationReport, LevelReport, LevelsReport, LevelsStop, Termination,
    Timings,
};
use super::{FitOptions, Goal, Log, coarse, compact};
use crate::error::Result;
use crate::field::Field;
use crate::geometry::{Cells, DVec3};
use crate::grid::Grid;
use crate::rbf::MultiScale;
use crate::rbf::{self, DetailLevel, Implicit, Kernel};
use crate::shape::Shape;

/// The settings of detail levels, part of [`FitOptions`].
#[derive(Debug, Clone, PartialEq, Serialize)]
#[non_exhaustive]
pub struct LevelOptions {
    /// At most this many detail levels; 0 turns them off (the paper's single function on the
    /// full grid).
    pub max_levels: usize,
    /// A 3D grid with at least this many voxels along its longest axis is fitted with levels:
    /// level 0 on the pyramid's coarsest goal, the levels on the full grid. Smaller grids are
    /// fitted as the paper fits them, so the defaults (200 voxels) are unchanged.
    pub min_axis: usize,
    /// The goal of a fit with levels has at most this many voxels along its longest axis
    /// (see `goal_grid`): on a longer grid it is voxelized at half the resolution (a quarter
    /// from four times as long), and the levels reach the grid asked for through points on the
    /// mesh. `usize::MAX` voxelizes every goal on the grid asked for.
    pub max_goal_axis: usize,
    /// Level 0's target E, in voxels of its own grid (the fit's default target).
    pub base_target_error: f32,
    /// The first level's support radius, in voxels of level 0's grid.
    pub first_radius: f64,
    /// No level whose support radius would be below this, in voxels of the full grid.
    pub min_radius: f64,
    /// On a grid below `min_axis` whose fit could go on with levels (`after_stall`), the
    /// paper's loop stops at this many constraints above its target and the fit goes on with
    /// levels, unless a constraint limit is set (`FitOptions::max_constraints`): the paper's
    /// models reach their target with fewer than 800, and a loop past this many needs thousands
    /// of them, each iteration a pass over the whole grid.
    pub loop_constraints: usize,
    /// On a grid below `min_axis` whose fit could go on with levels (`after_stall`), a fit of
    /// the paper's loop that met its target is fitted again with levels when the points on the
    /// mesh where the goal agrees with it lie farther than the target plus this many voxels
    /// from its zero set at the 99.9th percentile (`mesh_distance`): sharp corners and thin
    /// spikes that the goal's voxels round off, which E on the voxels does not see.
    pub mesh_slack: f64,
    /// The paper's loop that would hand over at `loop_constraints` forecasts from this share
    /// of them on how many it needs for its target (its lowest E so far times its constraints
    /// over the target: E falls about as one over the constraints), and hands over at once
    /// where that is more than `forecast_margin` times `loop_constraints`. Below this share its
    /// E falls too unevenly to forecast (it halves or doubles from one iteration to the next).
    pub forecast_from: f64,
    /// See `forecast_from`: the forecast is a rough one, and a loop on course to meet its target
    /// near `loop_constraints` goes on. `f64::INFINITY` turns the forecast off.
    pub forecast_margin: f64,
    /// Centres of a level are at least this fraction of its support radius apart.
    pub spacing: f64,
    /// A point's error is worth correcting above this fraction of the target.
    pub hot_fraction: f64,
}

impl Default for LevelOptions {
    fn default() -> Self {
        LevelOptions {
            max_levels: 5,
            min_axis: 384,
            max_goal_axis: 512,
            loop_constraints: 1_000,
            forecast_from: 0.3,
            forecast_margin: 1.5,
            mesh_slack: 0.5,
            base_target_error: 2.0,
            first_radius: 4.0,
            min_radius: 1.5,
            spacing: 0.4,
            hot_fraction: 0.5,
        }
    }
}

/// A multi-scale fit: its shape (level 0 alone when it met the target) and report.
#[derive(Debug, Clone)]
pub struct LevelledFit {
    /// [`Shape::Levels`], or [`Shape::Rbf`] when level 0 alone met the target.
    pub shape: Shape,
    /// The fit's report, its E measured on the goal's grid; `levels` is set.
    pub report: FitReport,
}

/// Whether an iterative fit on `grid` with `options` has detail levels: levels on, a 3D grid of
/// at least [`LevelOptions::min_axis`] voxels, and a pyramid below it.
pub fn applies(grid: &Grid, options: &FitOptions) -> bool {
    let longest = grid.dims.iter().copied().max().unwrap_or(0);
    options.levels.max_levels > 0
        && !grid.is_2d()
        && longest >= options.levels.min_axis
        && coarse::CoarseStart::wanted(grid, options)
}

/// Whether a fit of the paper's loop that ended with `report` stalled above its target (no
/// improvement, no candidate, or [`LevelOptions::loop_constraints`] reached: see
/// [`loop_limit`]) on a grid where detail levels could go on: levels on, and a pyramid below
/// the grid (see `after_stall`).
pub fn stalled(report: &FitReport, grid: &Grid, options: &FitOptions) -> bool {
    let stalled = matches!(
        report.termination,
        Termination::NoImprovement { .. }
            | Termination::NoCandidate
            | Termination::LoopLimit { .. }
            | Termination::LoopForecast { .. }
    );
    stalled
        && report.error_by(options.error_measure) > options.target_error
        && applies(grid, &after_stall(options))
}

/// The constraints at which the paper's loop on `grid` hands over to detail levels
/// ([`LevelOptions::loop_constraints`]), where it does: no constraint limit set, levels could
/// go on (`after_stall`), and fewer constraints than `allowed` (the most whose solve fits in
/// memory).
pub fn loop_limit(grid: &Grid, options: &FitOptions, allowed: usize) -> Option<usize> {
    let limit = options.levels.loop_constraints;
    (options.max_constraints.is_none() && limit < allowed && applies(grid, &after_stall(options)))
        .then_some(limit)
}

/// Whether a fit of the paper's loop on `grid` that ended with `report` and met its target
/// could be checked against the mesh's points and go on with levels where it is farther from
/// them than the target allows ([`LevelOptions::mesh_slack`]): levels could go on
/// (`after_stall`) and the grid has none of its own.
pub(crate) fn checks_mesh(report: &FitReport, grid: &Grid, options: &FitOptions) -> bool {
    let met = report.error_by(options.error_measure) <= options.target_error;
    met && !applies(grid, options) && applies(grid, &after_stall(options))
}

/// The 99.9th percentile of how far the zero set of `field` lies from `points` (mesh units:
/// points on the mesh where the goal agrees with it, [`Goal::agreeing`]), in voxels of `grid`,
/// to first order: the value over the gradient's length (the value alone, as the levels'
/// residual, misses a rounded-off sharp corner, where the slope is steeper than one). Points
/// whose value is within half a voxel keep the value alone, their gradients unevaluated:
/// they would need a slope below a fifth to lie beyond a target of 2 and half a voxel more.
/// `None` without points.
pub fn mesh_distance(points: &[DVec3], field: &impl Field, grid: &Grid) -> Option<f64> {
    if points.is_empty() {
        return None;
    }
    let voxel = grid.voxel_size;
    let mut distances: Vec<f64> = field
        .values(points)
        .into_par_iter()
        .zip(points)
        .map(|(value, &p)| {
            let near = (value / voxel).abs();
            if near <= NEAR {
                return near;
            }
            near / field.gradient(p).length().max(f64::MIN_POSITIVE)
        })
        .collect();
    Some(crate::metrics::percentile(&mut distances, 0.999))
}

/// The value, in voxels, within which [`mesh_distance`] takes the value for the distance.
const NEAR: f64 = 0.5;

/// The options of the fit with detail levels that follows a fit of the paper's loop that
/// [`stalled`] on a grid below [`LevelOptions::min_axis`]: levels from any grid with a pyramid,
/// and a level 0 of at most [`LevelOptions::loop_constraints`] constraints (the levels go on
/// from there, where the loop would need thousands).
pub(crate) fn after_stall(options: &FitOptions) -> FitOptions {
    let mut options = options.clone();
    options.levels.min_axis = 0;
    let limit = options.constraint_limit().min(options.levels.loop_constraints);
    options.max_constraints = Some(limit);
    options.hand_over = Some(super::HandOver::new(&options.levels, limit, options.target_error));
    options
}

/// Level 0 on the pyramid's coarsest goal, then detail levels on `grid`, the grid asked for,
/// whose voxels the errors are stated in; `goal` is on `grid` or on a coarser grid of
/// [`goal_grid`] (see the module doc). `on_iteration` sees level 0's iterations, their errors in
/// voxels of `grid`. The goal's densities are freed once level 0 is fitted
/// (`Goal::free_densities`).
///
/// # Errors
/// What level 0's solves report.
pub fn fit(
    goal: &mut Goal,
    grid: &Grid,
    options: &FitOptions,
    on_iteration: &mut impl FnMut(&IterationReport, &Implicit),
) -> Result<LevelledFit> {
    let started = Instant::now();
    let mut log = Log { per_iteration: Vec::new(), totals: Timings::default() };
    let goal_level = level_of(goal.grid(), grid);
    let (stage, base_grid) = fit_base(goal, goal_level, options, &mut log, on_iteration)?;
    goal.free_densities();
    let base_lattice_grid =
        Grid { dims: base_grid.0, origin: grid.origin, voxel_size: base_grid.1 };
    let implicit = compact::implicit(stage.implicit, &base_lattice_grid, &options.precision)?;
    let voxel = grid.voxel_size;
    let base_e = f64::from(stage.metrics.max_error_subvoxel) * base_grid.1 / voxel;
    let first_radius = options.levels.first_radius * base_grid.1;
    let band = (base_e + 2.0).clamp(3.0, first_radius / voxel);
    let points = data_points(goal);
    let targets = vec![0.0; points.len()];
    let base = Base {
        implicit,
        dims: base_grid.0,
        best_iteration: stage.best_iteration,
        termination: stage.termination,
    };
    let interior = points.len();
    let data = Data { points, targets, first_radius, band, interior };
    add_levels(goal, grid, base, data, options, log, started)
}

/// The grid of the goal of a fit on `grid` ([`LevelOptions::max_goal_axis`]): `grid` itself up
/// to that length along its longest axis or where the fit has no levels; beyond it, a grid of
/// half the resolution over the same box, or of a quarter from twice that length.
///
/// Volumes grow as the cube of the resolution and the surface's points as its square: at 1024
/// voxels the goal's volumes and the measure's (13 bytes a voxel) are what a fit cannot hold,
/// while the levels fit points sampled on the mesh, as many as `grid` has surface voxels, and
/// reach its detail through them. The coarser goal remains the judge of the inside (which of
/// the mesh's points count, which side the band's voxels must have) and of E. Its voxels are
/// exactly 2 (or 4) of `grid`'s, centred on the same box, with `GOAL_PADDING` voxels more on
/// each side.
pub fn goal_grid(grid: &Grid, options: &FitOptions) -> Grid {
    let longest = grid.dims.iter().copied().max().unwrap_or(0);
    let max = options.levels.max_goal_axis;
    if !applies(grid, options) || longest <= max {
        return *grid;
    }
    let factor = if longest <= max.saturating_mul(2) { 2 } else { 4 };
    let voxel_size = grid.voxel_size * factor as f64;
    let dims = grid.dims.map(|n| (n - 1).div_ceil(factor) + 1 + 2 * GOAL_PADDING);
    let span = |dims: [usize; 3], h: f64| {
        DVec3::new(dims[0] as f64 - 1.0, dims[1] as f64 - 1.0, dims[2] as f64 - 1.0) * h
    };
    let centre = DVec3::from_array(grid.origin) + span(grid.dims, grid.voxel_size) * 0.5;
    let origin = centre - span(dims, voxel_size) * 0.5;
    Grid { dims, origin: origin.to_array(), voxel_size }
}

/// Voxels of a coarser goal's grid added on every side ([`goal_grid`]), so that it keeps the
/// margin of the grid asked for.
pub(crate) const GOAL_PADDING: usize = 1;

/// Where a goal on `goal_grid` stands in the pyramid of a fit on `grid`: the same grid, half its
/// resolution or a quarter (by the ratio of their voxels).
fn level_of(goal_grid: &Grid, grid: &Grid) -> GridLevel {
    let ratio = goal_grid.voxel_size / grid.voxel_size;
    if ratio > 3.0 {
        GridLevel::Quarter
    } else if ratio > 1.5 {
        GridLevel::Half
    } else {
        GridLevel::Full
    }
}

/// A shell's fit ([`crate::voxelize::shell`]): detail levels over a constant level 0. The
/// paper's loop cannot hold a wall a few voxels thick (no interior constraint fits between its
/// faces, so its function stays negative there), so level 0 is the constant `-half_voxels`
/// voxels, outside everywhere, and the levels, the first with a support of `first_radius x
/// (half_voxels + 1)` voxels, fit the thickened surface's points (goal value 0) and
/// `mid_surface`, points on the mesh (mesh units) at the middle of the wall, whose goal value
/// is `half_voxels`, the wall's half thickness; band voxels on the wrong side as for solids.
///
/// # Errors
/// What the levels' solves report.
pub fn fit_shell(
    goal: &Goal,
    mid_surface: &[DVec3],
    half_voxels: f64,
    options: &FitOptions,
) -> Result<LevelledFit> {
    let started = Instant::now();
    let log = Log { per_iteration: Vec::new(), totals: Timings::default() };
    let grid = *goal.grid();
    let voxel = grid.voxel_size;
    let implicit =
        compact::implicit(constant(&grid, -half_voxels * voxel)?, &grid, &options.precision)?;
    let mut points: Vec<DVec3> = goal.surface().par_iter().map(|&p| grid.to_world(p)).collect();
    let mut targets = vec![0.0; points.len()];
    let interior = points.len();
    points.extend_from_slice(mid_surface);
    targets.resize(points.len(), half_voxels);
    let first_radius = options.levels.first_radius * (half_voxels + 1.0) * voxel;
    let base = Base {
        implicit,
        dims: grid.dims,
        best_iteration: 0,
        termination: Termination::TargetError {
            target: options.target_error,
            measure: options.error_measure,
        },
    };
    let data = Data { points, targets, first_radius, band: first_radius / voxel, interior };
    add_levels(goal, &grid, base, data, options, log, started)
}

/// The constant `value` on `grid`, as a thin-plate function: the interpolant of the same value
/// at four corners of the grid's box is the constant polynomial, its weights zero.
fn constant(grid: &Grid, value: f64) -> Result<Implicit> {
    let lo = grid.to_world(DVec3::ZERO);
    let size = grid.to_world(DVec3::new(
        grid.dims[0] as f64 - 1.0,
        grid.dims[1] as f64 - 1.0,
        grid.dims[2] as f64 - 1.0,
    )) - lo;
    let corners = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z].map(|c| lo + c * size);
    let constraints: Vec<rbf::Constraint> =
        corners.iter().map(|c| rbf::Constraint::new(&c.to_array(), value)).collect();
    Implicit::solve(3, Kernel::default(), &constraints)
}

/// Level 0 of a multi-scale fit, and how its own fit ended.
struct Base {
    implicit: Implicit,
    /// The grid level 0 was fitted on.
    dims: [usize; 3],
    best_iteration: usize,
    termination: Termination,
}

/// What the levels fit: `points` (mesh units) whose model value should be `targets` (voxels),
/// from a first support radius (mesh units); the side of the model is checked at the goal's
/// voxels between [`SURFACE_BAND`] and `band` voxels from its surface, and at the points from
/// `interior` on (a shell's mid-surface), which must be inside.
struct Data {
    points: Vec<DVec3>,
    targets: Vec<f64>,
    first_radius: f64,
    band: f64,
    interior: usize,
}

/// Detail levels over `base`, fitted to `data` and the band's wrong sides, halving the support
/// until the residual is within the target in voxels of `grid` (see the module doc); then the
/// measure on the goal's grid and the report, in voxels of `grid`.
fn add_levels(
    goal: &Goal,
    grid: &Grid,
    base: Base,
    data: Data,
    options: &FitOptions,
    mut log: Log,
    started: Instant,
) -> Result<LevelledFit> {
    let clock = Instant::now();
    let voxel = grid.voxel_size;
    // The goal's voxels in voxels of `grid`.
    let goal_scale = goal.grid().voxel_size / voxel;
    let Data { points, targets, first_radius, band, interior } = data;
    let mut residual: Vec<f64> = base
        .implicit
        .values(&points)
        .into_iter()
        .zip(&targets)
        .map(|(v, t)| t - v / voxel)
        .collect();
    // An interior point is outside while its residual is its whole target or more.
    let outside = |residual: &[f64]| {
        residual[interior..].iter().zip(&targets[interior..]).any(|(r, t)| r >= t)
    };
    let mut off = OffSurface::new(goal, &base.implicit, band / goal_scale);
    let (base_max, base_p999) = error_figures(&residual);
    let mut levels = Vec::new();
    let mut reports = Vec::new();
    let target = f64::from(options.target_error);
    let mut stopped = LevelsStop::LevelLimit;
    for k in 0..=options.levels.max_levels {
        let radius = first_radius / f64::from(1u32 << k.min(30));
        let wrong = off.wrong_sides();
        let (max, p999) = error_figures(&residual);
        // Met, but for slits' gaps still closed: levels go on for the gaps alone, down to half
        // the least radius (see `gap_level`).
        let closed_gaps = wrong.iter().filter(|w| w.2).count();
        let met = max <= target && wrong.len() == closed_gaps && !outside(&residual);
        let least = options.levels.min_radius * voxel;
        let gap_radius = radius >= least / 2.0;
        if met && (closed_gaps == 0 || !gap_radius) {
            stopped = LevelsStop::TargetMet;
            break;
        }
        if k == options.levels.max_levels {
            break;
        }
        let gaps_only = met || radius < least;
        if gaps_only && !(closed_gaps > 0 && gap_radius) {
            stopped = LevelsStop::SmallestRadius;
            break;
        }
        let level_clock = Instant::now();
        let (candidates, errors, chosen) = if gaps_only {
            gap_level(&points, &residual, &wrong, &off.gaps(), radius, goal_scale, &options.levels)
        } else {
            let mut candidates = points.clone();
            candidates.extend(wrong.iter().map(|w| w.0));
            let mut errors = residual.clone();
            errors.extend(wrong.iter().map(|w| w.1 * goal_scale));
            let chosen = choose_centres(&candidates, &errors, radius, target, &options.levels);
            (candidates, errors, chosen)
        };
        if chosen.is_empty() {
            stopped = LevelsStop::NoCentre;
            break;
        }
        let lattice = compact::level_lattice(radius, grid, &options.precision);
        let (centres, chosen) = match &lattice {
            Some(lattice) => compact::snap_centres(&candidates, &chosen, lattice),
            None => (chosen.iter().map(|&i| candidates[i]).collect(), chosen),
        };
        let values: Vec<f64> = chosen.iter().map(|&i| errors[i] * voxel).collect();
        let (level, solve) = DetailLevel::interpolate(radius, centres, &values)?;
        let level = match lattice {
            Some(lattice) => {
                compact::round_level(level, lattice, options.precision.level_prune_steps)?
            }
            None => level,
        };
        if level.centres().is_empty() {
            // Every weight pruned: this radius adds nothing, the next (half) may.
            continue;
        }
        residual.par_iter_mut().zip(&points).for_each(|(r, &p)| *r -= level.value(p) / voxel);
        off.add(&level);
        let (max_error_voxels, p999_error_voxels) = error_figures(&residual);
        reports.push(LevelReport {
            radius_voxels: radius / voxel,
            centres: level.centres().len(),
            bytes: 0,
            matrix_entries: solve.entries,
            solve_iterations: solve.iterations,
            solve_residual: solve.residual,
            max_error_before_voxels: max,
            p999_error_before_voxels: p999,
            max_error_voxels,
            p999_error_voxels,
            wrong_side_voxels: wrong.len(),
            seconds: level_clock.elapsed().as_secs_f64(),
        });
        levels.push(level);
    }
    log.totals.misc += clock.elapsed().as_secs_f64();
    // The measure below evaluates the model over the goal's grid: the levels' data goes first.
    let data_points = points.len();
    let closed_gaps = off.wrong_sides().iter().filter(|w| w.2).count();
    drop((off, points, residual, targets));
    let base_implicit = base.implicit;
    let shape = if levels.is_empty() {
        Shape::Rbf(base_implicit.clone())
    } else {
        Shape::Levels(MultiScale::new("the fit", base_implicit.clone(), levels)?)
    };
    let clock = Instant::now();
    let metrics = super::measure_field(goal, &shape, options).in_smaller_voxels(goal_scale as f32);
    log.totals.implicit_evaluation += clock.elapsed().as_secs_f64();
    log.totals.total = started.elapsed().as_secs_f64();
    let levels_report = LevelsReport {
        base_dims: base.dims,
        band_voxels: band,
        max_error_subvoxel_voxels: metrics.max_error_subvoxel,
        rms_error_subvoxel_voxels: metrics.rms_error_subvoxel,
        base_centres: base_implicit.len(),
        base_bytes: 0,
        base_max_error_voxels: base_max,
        base_p999_error_voxels: base_p999,
        points: data_points,
        slits: goal.slits().map(|slits| slits.report(closed_gaps)),
        levels: reports,
        stopped,
    };
    let mut report = super::report_of(grid, &metrics, base.best_iteration, base.termination, log);
    report.levels = Some(levels_report);
    Ok(LevelledFit { shape, report })
}

/// The points the levels fit, mesh units: the points on the mesh where the goal agrees with it
/// ([`Goal::mesh_points`], with the walls of the slits it was carved for), and the goal's
/// surface points farther than a voxel from all of them, where the voxelization closed a hole
/// or filled a slit and the goal's surface holds; without points on the mesh, the goal's
/// surface points.
fn data_points(goal: &Goal) -> Vec<DVec3> {
    let grid = goal.grid();
    let on_goal = goal.surface().par_iter().map(|&p| grid.to_world(p));
    let Some(on_mesh) = goal.mesh_points() else {
        return on_goal.collect();
    };
    let near_mesh = PointSet::new(grid.voxel_size, on_mesh);
    let away: Vec<DVec3> = on_goal.filter(|&p| !near_mesh.any_within(p)).collect();
    let mut points = on_mesh.to_vec();
    points.extend(away);
    points
}

/// What a level below [`LevelOptions::min_radius`] fits, down to half of it, while slits'
/// gaps (`fit/slit.rs`) have voxels on the wrong side: the gaps' voxels (`gaps`, with the
/// correction to the goal's signed distance) and the points within `radius` of one on the
/// wrong side, the points at their residuals, so that the level leaves its neighbourhood where
/// it should be. Its centres are the gaps' voxels first, then the points, greatest `|error|`
/// first within each, spaced as [`choose_centres`] spaces them. Returns the candidates, their
/// errors and the chosen ones.
fn gap_level(
    points: &[DVec3],
    residual: &[f64],
    wrong: &[(DVec3, f64, bool)],
    gaps: &[(DVec3, f64)],
    radius: f64,
    goal_scale: f64,
    options: &LevelOptions,
) -> (Vec<DVec3>, Vec<f64>, Vec<usize>) {
    let wrong_gaps: Vec<DVec3> = wrong.iter().filter(|w| w.2).map(|w| w.0).collect();
    let near_gap = PointSet::new(radius, &wrong_gaps);
    let (mut candidates, mut errors): (Vec<DVec3>, Vec<f64>) = gaps
        .iter()
        .filter(|(p, _)| near_gap.any_within(*p))
        .map(|&(p, correction)| (p, correction * goal_scale))
        .unzip();
    let gaps = candidates.len();
    let near_gap = PointSet::new(radius, &candidates);
    let (near, near_errors): (Vec<DVec3>, Vec<f64>) = points
        .par_iter()
        .zip(residual)
        .filter(|(p, _)| near_gap.any_within(**p))
        .map(|(&p, &r)| (p, r))
        .unzip();
    candidates.extend(near);
    errors.extend(near_errors);
    let by_error = |mut order: Vec<usize>| {
        order.sort_unstable_by(|&a, &b| errors[b].abs().total_cmp(&errors[a].abs()));
        order
    };
    let mut order = by_error((0..gaps).collect());
    order.extend(by_error((gaps..candidates.len()).collect()));
    let chosen = spaced(&candidates, order, options.spacing * radius);
    (candidates, errors, chosen)
}

/// Level 0: the loop of paper 5 on the coarsest goal of `goal`'s pyramid, with its own target
/// ([`LevelOptions::base_target_error`]); the stage, and that goal's dims and voxel size.
/// `goal` stands at `goal_level` of the fit's pyramid.
fn fit_base(
    goal: &Goal,
    goal_level: GridLevel,
    options: &FitOptions,
    log: &mut Log,
    on_iteration: &mut impl FnMut(&IterationReport, &Implicit),
) -> Result<(super::Stage, ([usize; 3], f64))> {
    let mut current = coarse::CoarseStart::of(goal, options).expect("`applies` checked it");
    let mut level_options = current.options(options);
    let mut level = goal_level.coarser().unwrap_or(GridLevel::Eighth);
    while let (Some(next), Some(coarser)) =
        (coarse::CoarseStart::of(&current.goal, &level_options), level.coarser())
    {
        level_options = next.options(&level_options);
        current = next;
        level = coarser;
    }
    // Level 0's forecast (after a stall) is for its own target, in voxels of the full grid.
    let target_error = options.levels.base_target_error;
    let hand_over = options
        .hand_over
        .map(|h| super::HandOver { target_error: target_error * level.voxel_scale(), ..h });
    let base_options = FitOptions { target_error, hand_over, ..level_options };
    let stage = super::fit_level(&current.goal, &base_options, level, log, on_iteration)?;
    let grid = current.goal.grid();
    Ok((stage, (grid.dims, grid.voxel_size)))
}

/// The voxels of the goal's grid whose goal signed distance is between [`SURFACE_BAND`] and a
/// band's width, and the voxels opened in its slits' gaps (`fit/slit.rs`): where the model
/// must have the goal's side. Their model values (in voxels) are
/// kept up to date as levels are added, their positions computed when needed.
struct OffSurface<'a> {
    goal: &'a Goal,
    /// The band's voxels, then from `gaps` on the slits' opened voxels outside the band.
    voxels: Vec<u32>,
    gaps: usize,
    values: Vec<f32>,
}

/// Voxels closer than this to the goal's surface (in voxels) are left to the surface points:
/// their sides follow the sub-voxel position of the surface.
const SURFACE_BAND: f32 = 1.5;

impl<'a> OffSurface<'a> {
    fn new(goal: &'a Goal, base: &Implicit, band: f64) -> OffSurface<'a> {
        let band = band as f32;
        let in_band = |i: usize| (SURFACE_BAND..=band).contains(&goal.sd.data[i].abs());
        let mut voxels: Vec<u32> = (0..goal.sd.data.len())
            .into_par_iter()
            .filter(|&i| in_band(i))
            .map(|i| i as u32)
            .collect();
        let gaps = voxels.len();
        if let Some(slits) = goal.slits() {
            // A slit's gap is outside however near the surface: it is what a polygonizer on
            // the grid sees of the slit.
            let mut opened: Vec<u32> = slits
                .carved
                .iter()
                .copied()
                .filter(|&i| goal.sd.data[i as usize] < 0.0 && !in_band(i as usize))
                .collect();
            opened.sort_unstable();
            opened.dedup();
            voxels.extend(opened);
        }
        let mut off = OffSurface { goal, voxels, gaps, values: Vec::new() };
        let voxel = goal.grid().voxel_size;
        off.values = off
            .voxels
            .par_chunks(1 << 16)
            .flat_map_iter(|chunk| {
                let points: Vec<DVec3> = chunk.iter().map(|&i| off.position(i)).collect();
                base.values(&points).into_iter().map(move |v| (v / voxel) as f32)
            })
            .collect();
        off
    }

    fn position(&self, index: u32) -> DVec3 {
        let grid = self.goal.grid();
        grid.position(grid.voxel(index as usize))
    }

    /// The voxels where the model has the wrong side, with what it takes to correct them (the
    /// goal's signed distance less the model's value, in voxels) and whether they are in a
    /// slit's gap.
    fn wrong_sides(&self) -> Vec<(DVec3, f64, bool)> {
        self.voxels
            .par_iter()
            .zip(&self.values)
            .enumerate()
            .filter_map(|(k, (&i, &v))| {
                let sd = self.goal.sd.data[i as usize];
                (v * sd <= 0.0).then(|| (self.position(i), f64::from(sd - v), k >= self.gaps))
            })
            .collect()
    }

    /// The slits' opened voxels, each with what takes the model to the goal's signed distance
    /// there (as for [`OffSurface::wrong_sides`]).
    fn gaps(&self) -> Vec<(DVec3, f64)> {
        self.voxels[self.gaps..]
            .par_iter()
            .zip(&self.values[self.gaps..])
            .map(|(&i, &v)| (self.position(i), f64::from(self.goal.sd.data[i as usize] - v)))
            .collect()
    }

    /// Adds `level`'s values.
    fn add(&mut self, level: &DetailLevel) {
        let voxel = self.goal.grid().voxel_size;
        let this = &*self;
        let added: Vec<f32> = this
            .voxels
            .par_iter()
            .map(|&i| (level.value(this.position(i)) / voxel) as f32)
            .collect();
        self.values.iter_mut().zip(added).for_each(|(v, a)| *v += a);
    }
}

/// The largest `|r|` and its 99.9th percentile ([`crate::metrics::percentile`]).
fn error_figures(residual: &[f64]) -> (f64, f64) {
    let mut errors: Vec<f64> = residual.par_iter().map(|r| r.abs()).collect();
    if errors.is_empty() {
        return (0.0, 0.0);
    }
    let max = errors.iter().copied().fold(0.0, f64::max);
    (max, crate::metrics::percentile(&mut errors, 0.999))
}

/// The points a level of support `radius` interpolates: greatest `|residual|` first, each at
/// least `spacing x radius` from those chosen before, among the points within `radius` of a
/// point whose error is above `hot_fraction x target` (so the level also holds its
/// neighbourhood at its residual and spills less onto points that were right).
fn choose_centres(
    points: &[DVec3],
    residual: &[f64],
    radius: f64,
    target: f64,
    options: &LevelOptions,
) -> Vec<usize> {
    let hot: Vec<DVec3> = (0..points.len())
        .filter(|&i| residual[i].abs() > options.hot_fraction * target)
        .map(|i| points[i])
        .collect();
    let near_hot = PointSet::new(radius, &hot);
    let mut order: Vec<usize> =
        (0..points.len()).into_par_iter().filter(|&i| near_hot.any_within(points[i])).collect();
    order.par_sort_unstable_by(|&a, &b| residual[b].abs().total_cmp(&residual[a].abs()));
    spaced(points, order, options.spacing * radius)
}

/// The points of `order`, in that order, each kept unless one kept before is within `spacing`.
fn spaced(points: &[DVec3], order: Vec<usize>, spacing: f64) -> Vec<usize> {
    let mut chosen = PointSet::new(spacing, &[]);
    let mut picked = Vec::new();
    for i in order {
        if !chosen.any_within(points[i]) {
            chosen.insert(points[i]);
            picked.push(i);
        }
    }
    picked
}

/// Points in a hash grid of cells of side `reach`, asked whether any lies within `reach`.
struct PointSet {
    reach: f64,
    cells: Cells<DVec3>,
}

impl PointSet {
    fn new(reach: f64, points: &[DVec3]) -> PointSet {
        let mut set = PointSet { reach, cells: Cells::new(reach) };
        for &p in points {
            set.insert(p);
        }
        set
    }

    fn insert(&mut self, p: DVec3) {
        self.cells.insert(p, p);
    }

    fn any_within(&self, p: DVec3) -> bool {
        let reach2 = self.reach * self.reach;
        self.cells.near(p).any(|q| q.distance_squared(p) < reach2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(longest: usize) -> Grid {
        Grid { dims: [longest, 6, 5], origin: [0.0; 3], voxel_size: 1.0 }
    }

    /// The defaults (200 voxels) fit as the paper does; 512 voxels have levels unless they are
    /// turned off or every iteration runs on the full grid.
    #[test]
    fn levels_apply_from_the_minimum_axis_and_can_be_turned_off() {
        let options = FitOptions::default();
        assert!(!applies(&grid(200), &options));
        assert!(!applies(&grid(383), &options));
        assert!(applies(&grid(512), &options));
        let mut off = options.clone();
        off.levels.max_levels = 0;
        assert!(!applies(&grid(512), &off));
        let mut full = options.clone();
        full.coarse_start = false;
        assert!(!applies(&grid(512), &full));
    }

    /// The levels fit points on the mesh where the goal agrees with it (a face buried inside
    /// the solid is left out) and the goal's surface where no mesh point is near (here, the
    /// lower half of a ball whose mesh has only its upper half).
    #[test]
    fn levels_fit_the_mesh_where_the_goal_agrees_and_the_goal_elsewhere() {
        let centre = DVec3::splat(12.3);
        let radius = 8.2;
        let mut on_mesh: Vec<DVec3> = (0..2000)
            .map(|i| {
                let z = i as f64 / 2000.0;
                let angle = i as f64 * 2.399_963;
                let ring = (1.0 - z * z).sqrt();
                centre + DVec3::new(ring * angle.cos(), ring * angle.sin(), z) * radius
            })
            .collect();
        let buried = centre + DVec3::new(0.0, 0.0, -3.0);
        on_mesh.push(buried);
        let goal = Goal::ball(26, centre, radius).with_mesh_points(on_mesh.clone(), 1.0);
        let kept = goal.mesh_points().unwrap();
        assert_eq!(kept.len(), 2000, "the buried point is left out");
        assert!(!kept.contains(&buried));
        let points = data_points(&goal);
        assert_eq!(&points[..2000], kept);
        let from_goal = &points[2000..];
        assert!(!from_goal.is_empty());
        // The goal's points fill the lower half, a voxel or more from the mesh's points.
        for p in from_goal {
            assert!(p.z < centre.z + 1.0, "{p}");
            assert!(kept.iter().all(|q| q.distance(*p) >= 1.0), "{p}");
        }
        let lower = goal.surface().iter().filter(|p| p.z < centre.z - 1.0).count();
        assert!(from_goal.len() >= lower, "{} of {lower}", from_goal.len());
    }

    /// Centres go to the largest errors first, a fraction of the radius apart, and only near
    /// errors above the hot fraction of the target.
    #[test]
    fn centres_are_chosen_greatest_error_first_and_spaced() {
        let points: Vec<DVec3> = (0..100).map(|i| DVec3::new(i as f64 * 0.25, 0.0, 0.0)).collect();
        // An error of 3 at x = 5, falling off linearly, and nothing beyond x = 10.
        let residual: Vec<f64> =
            points.iter().map(|p| (3.0 - (p.x - 5.0).abs() * 0.6).max(0.0)).collect();
        let options = LevelOptions::default();
        let chosen = choose_centres(&points, &residual, 4.0, 1.0, &options);
        assert_eq!(chosen[0], 20, "the largest error first");
        for (a, &i) in chosen.iter().enumerate() {
            for &j in &chosen[..a] {
                assert!(points[i].distance(points[j]) >= 1.2 - 1e-12);
            }
            // Within the radius (4) of a point whose error is above 0.5.
            assert!(points[i].x > 0.8 - 4.0 && points[i].x < 9.2 + 4.0, "{}", points[i]);
        }
    }
}
