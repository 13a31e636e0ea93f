//! The iterative fit (paper 5): constraints are added where the current implicit surface is
//! furthest from the goal until the two match.
//!
//! ```text
//! constraints = initial_constraints()                      5.1
//!     (on a large grid: the loop below at half the resolution, then its best constraints;
//!      on a larger one, that loop itself starts at a quarter, ...)
//! repeat
//!     f_curr = solve(constraints)                          3.1
//!     evaluate f_curr over the volume, coarse to fine      5.2
//!     sd_curr, ∂f_curr, E, Ew, RMS                         4.2, 4.3
//!     constraints += pruned candidates, greatest error first   5.3
//! until accurate enough, no better for 4 iterations, or too many   5.4
//! ```
//!
//! The fit works in continuous voxel coordinates of the goal's grid (constraint positions) and
//! voxel units (constraint values: signed distances), and hands the solver positions and values
//! in mesh units, so the model file speaks the mesh's units and a scaled or moved mesh gives the
//! same constraints in voxels. The best model by E, then RMS, is kept, not the last.

mod coarse;
mod compact;
pub(crate) mod detail;
mod goal;
mod init;
pub(crate) mod naive;
mod refine;
mod report;
mod slit;
mod surface;
mod thickness;

use std::time::Instant;

use rayon::prelude::*;

use crate::edt;
use crate::error::Result;
use crate::field::Field;
use crate::geometry::DVec3;
use crate::grid::{Grid, Volume};
pub use crate::metrics::RegularityOptions;
use crate::metrics::{self, BoundaryErrors, ErrorMetrics, SubVoxel};
use crate::rbf::{self, Implicit, Kernel};

pub use compact::Precision;
pub use detail::LevelOptions;
pub use goal::Goal;
pub(crate) use goal::MESH_AGREEMENT;
pub use report::{
    BudgetTrial, ByteBudget, ConstraintCounts, FitReport, GridLevel, IterationReport, LevelReport,
    LevelsReport, LevelsStop, PaperLoop, REPORT_VERSION, TargetOutcome, Termination, Timings,
};
pub use slit::SlitReport;
pub(crate) use slit::{WALL_SAMPLES, WALL_STEP};
pub use thickness::Thickness;

/// Every threshold of the fit, with the paper's values as defaults where the paper gives one.
///
/// Made with [`FitOptions::default`] and changed field by field; [`FitOptions::check`] says
/// whether the values can be used. It serializes (as the batch manifest records what made
/// each model).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[non_exhaustive]
pub struct FitOptions {
    /// Seed of the random choice of initial constraints.
    pub seed: u64,
    /// Boundary constraints placed at random by the initialization (paper: 50).
    pub initial_constraints: usize,
    /// An initial boundary constraint this close (voxels) to an earlier one is skipped
    /// (paper: "too close", unquantified; we use 4 voxels).
    pub initial_spacing: f64,
    /// No initial boundary constraint where the radius of regularity is below this (voxels)
    /// (paper: "too small", unquantified; we use 3 voxels, where a voxelized surface is still
    /// reliably two-sided).
    pub initial_min_rreg: f64,
    /// A candidate closer than `added_spacing_factor x sd(x)` to a voxel x where a constraint was
    /// added this iteration is pruned (paper: 2).
    pub added_spacing_factor: f64,
    /// A candidate closer than this (voxels) to an existing constraint is pruned (paper: 2);
    /// with [`ErrorMeasure::SubVoxel`], closer than the target E where that is smaller (see
    /// `refine.rs`).
    pub min_constraint_spacing: f64,
    /// A candidate whose error is below this fraction of E is pruned (paper: 1/2).
    pub error_fraction: f32,
    /// A candidate whose weighted error is below this is pruned (paper: 0.125), unless its
    /// voxel error is above `target_error` (see `refine.rs`).
    pub min_weighted_error: f32,
    /// Where some candidates' voxel errors are above `target_error`, only those are added
    /// (paper: every candidate that survives pruning, which `false` restores; see `refine.rs`).
    pub only_above_target: bool,
    /// A candidate from the current surface whose error is at most this (voxels) becomes a
    /// boundary constraint at the nearest point of the goal's surface instead of a soft
    /// constraint, where that point is found (paper: soft constraints only, which 0 restores;
    /// see `refine.rs` for why).
    pub snap_distance: f64,
    /// Stop once E is at most this, in voxels. The paper sets no default; 2 voxels is half the
    /// paper's error on its bunny. E moves in the voxel grid's steps (√k − ½: 2.33, 1.95, 1.74,
    /// 1.5, ...), and each step down costs hundreds of constraints more.
    pub target_error: f32,
    /// How E is measured where it is compared with `target_error`, where the best model is
    /// chosen, and where candidates are judged above the target.
    pub error_measure: ErrorMeasure,
    /// Stop once Ew is at most this.
    pub target_weighted_error: f32,
    /// Stop when no model has improved on the best E or on the lowest RMS error for this many
    /// iterations (paper: 4, "by either of the error metrics"). E alone is a poor judge of
    /// progress: it jumps by voxels from one iteration to the next as thin parts (the bunny's
    /// ears) pinch and recover, while the RMS error keeps falling; stopping on E alone ended
    /// some bunny fits at E 4.6 after 274 constraints that go on to E 2.3.
    pub patience: usize,
    /// An RMS error counts as an improvement for `patience` only if it is below the lowest so
    /// far by at least this fraction of it, so a fit whose E is stuck does not go on for ever
    /// on hundredths of a voxel.
    pub min_rms_improvement: f32,
    /// Stop after this many iterations.
    pub max_iterations: usize,
    /// Never add constraints beyond this many in all; `None` is the method's own limit (its
    /// `default_max_constraints`: 50,000 for the iterative fit, 2,000 for the naive one). A safety limit, far above what the paper's models need at E 2 (500 to 800), that
    /// a fit reaching it reports ([`Termination::ConstraintLimit`]): the solve scales
    /// (iteratively above `DIRECT_MAX` constraints), so the target E decides the count.
    pub max_constraints: Option<usize>,
    /// At most this fraction of the current count is added in one iteration (at least
    /// `initial_constraints / 2`), greatest error first. The paper adds every candidate that
    /// survives pruning; late in a fit, when E is small, that is hundreds at once, which pull on
    /// each other and overshoot. Growing by a fraction keeps the paper's order and pruning and
    /// lets the next iteration see what the last additions did.
    pub max_growth: f64,
    /// Whether the fit may start on the goal at half the resolution (see `coarse.rs` and
    /// `coarse_start_min_axis`); `false` runs every iteration on the full grid.
    pub coarse_start: bool,
    /// The fit starts on the goal at half the resolution (see `coarse.rs`) when its grid is 3D
    /// and has at least this many voxels along its longest axis, and that start at a quarter
    /// from four times as many, at an eighth from sixteen times as many; `usize::MAX` never does.
    pub coarse_start_min_axis: usize,
    /// The start at half the resolution hands over to the full grid once its E is at most
    /// this, in voxels of the full grid (or `target_error`, if larger): 3 voxels of the full
    /// grid are 1.5 of its own, a step E can reach there (√4 - 1/2).
    pub coarse_target_error: f32,
    /// `max_growth` at half the resolution: an iteration there costs about an eighth of one on
    /// the full grid, so it can afford to add more at once and let the next one correct it.
    pub coarse_max_growth: f64,
    /// The radial basis function.
    pub kernel: Kernel,
    /// How radii of regularity are measured.
    pub regularity: RegularityOptions,
    /// Detail levels over the fit on large grids (see [`LevelOptions`]).
    pub levels: LevelOptions,
    /// How finely the fit stores its functions (see `compact.rs`).
    pub precision: compact::Precision,
    /// Where the fit goes on with detail levels once the paper's loop hands over (set by the
    /// pipeline with [`detail::loop_limit`]): the loop also stops once it is on course for more
    /// constraints than that (see `on_course_past`).
    #[serde(skip)]
    pub(crate) hand_over: Option<HandOver>,
}

/// Where the paper's loop hands over to detail levels: at `constraints`, or earlier once its E
/// forecasts more than [`LevelOptions::forecast_margin`] times as many for `target_error`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct HandOver {
    /// The constraints ([`LevelOptions::loop_constraints`]).
    pub constraints: usize,
    /// The fit's target E, in voxels of its full grid.
    pub target_error: f32,
    /// [`LevelOptions::forecast_from`].
    pub from: f64,
    /// [`LevelOptions::forecast_margin`].
    pub margin: f64,
}

impl HandOver {
    /// A hand-over at `constraints` for `target_error` (voxels of the full grid), forecast as
    /// `levels` says.
    pub fn new(levels: &LevelOptions, constraints: usize, target_error: f32) -> HandOver {
        HandOver {
            constraints,
            target_error,
            from: levels.forecast_from,
            margin: levels.forecast_margin,
        }
    }

    /// The constraints a loop at `count` constraints whose lowest E so far is `lowest` (voxels
    /// of the full grid) is on course for: E falls about as one over the constraints (their
    /// spacing on the surface, and with it what the surface can do between them, shrinks as
    /// they grow), so `count` times `lowest` over the target.
    fn forecast(self, count: usize, lowest: f32) -> usize {
        (count as f64 * f64::from(lowest) / f64::from(self.target_error)).ceil() as usize
    }

    /// Why the loop hands over at `count` constraints with `lowest` E so far (voxels of the
    /// full grid), if it does on the forecast: from `from` times the constraints on, on course
    /// for more than `margin` times them.
    fn on_course_past(self, count: usize, lowest: f32) -> Option<Termination> {
        let limit = self.constraints as f64;
        let forecast = self.forecast(count, lowest);
        (count as f64 >= self.from * limit && forecast as f64 > self.margin * limit)
            .then_some(Termination::LoopForecast { constraints: count, forecast })
    }
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            seed: 1,
            initial_constraints: 50,
            initial_spacing: 4.0,
            initial_min_rreg: 3.0,
            added_spacing_factor: 2.0,
            min_constraint_spacing: 2.0,
            error_fraction: 0.5,
            min_weighted_error: 0.125,
            only_above_target: true,
            snap_distance: 3.0,
            target_error: 2.0,
            error_measure: ErrorMeasure::Voxel,
            target_weighted_error: 0.0,
            patience: 4,
            min_rms_improvement: 0.01,
            max_iterations: 100,
            max_constraints: None,
            max_growth: 0.1,
            coarse_start: true,
            coarse_start_min_axis: 128,
            coarse_target_error: 3.0,
            coarse_max_growth: 0.2,
            kernel: Kernel::default(),
            regularity: RegularityOptions::default(),
            levels: LevelOptions::default(),
            precision: compact::Precision::default(),
            hand_over: None,
        }
    }
}

/// The iterative fit's constraint limit where [`FitOptions::max_constraints`] sets none.
pub(crate) const MAX_CONSTRAINTS: usize = 50_000;

impl FitOptions {
    /// The constraint limit of the iterative fit: `max_constraints`, or 50,000.
    pub fn constraint_limit(&self) -> usize {
        self.max_constraints.unwrap_or(MAX_CONSTRAINTS)
    }

    /// Checks the settings a caller sets: a target E that is a number of voxels, at least one
    /// iteration and one constraint, a forecast of the hand-over to detail levels that can be
    /// made.
    ///
    /// # Errors
    /// The first setting out of its range, named (see [`crate::Error::worded`]).
    pub fn check(&self) -> Result<()> {
        let invalid = |message: String| Err(crate::Error::invalid("options", message));
        if !(self.target_error.is_finite() && self.target_error >= 0.0) {
            return invalid(format!(
                "`target_error` must be a finite number of voxels >= 0, not {}",
                self.target_error
            ));
        }
        if self.max_iterations == 0 {
            return invalid("`max_iterations` must be at least 1".into());
        }
        if self.max_constraints == Some(0) {
            return invalid("`max_constraints` must be at least 1".into());
        }
        let levels = &self.levels;
        let from_ok = levels.forecast_from.is_finite() && levels.forecast_from >= 0.0;
        let margin_ok = levels.forecast_margin > 0.0; // false for NaN
        if !(from_ok && margin_ok) {
            return invalid(format!(
                "`levels.forecast_from` must be a finite share >= 0 and `levels.forecast_margin` \
                 a number > 0, not {} and {}",
                levels.forecast_from, levels.forecast_margin
            ));
        }
        Ok(())
    }
}

/// How the fit measures E against its target.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorMeasure {
    /// The paper's E (equation 3): distances from voxel centres, in the voxel grid's steps
    /// (√k − ½: 0.5, 0.91, 1.23, 1.5, 1.74, 1.95, 2.33, ...), half a voxel for surfaces that
    /// coincide. The default, so that E compares with the paper's tables.
    #[default]
    Voxel,
    /// E to sub-voxel precision: the largest distance from a point on either surface to the
    /// other (`ErrorMetrics::max_error_subvoxel`), 0 for surfaces that coincide. Free of the
    /// voxel steps, it is the measure for targets of a voxel or less (on the bunny at 128, a
    /// voxel-centre E of 1.50 went with a sub-voxel E of 0.99). A fit of a mesh
    /// ([`crate::pipeline::Prepared::new`]) measures the current surface's points against the
    /// mesh itself, with the exact distance to its triangles ([`Goal::with_mesh`]).
    #[serde(rename = "subvoxel")]
    SubVoxel,
}

impl ErrorMeasure {
    /// E by this measure.
    pub fn of(self, metrics: &ErrorMetrics) -> f32 {
        match self {
            ErrorMeasure::Voxel => metrics.max_error,
            ErrorMeasure::SubVoxel => metrics.max_error_subvoxel,
        }
    }
}

/// A constraint as the fit sees it: a position in continuous voxel coordinates, a value in
/// voxels (0 on the boundary, the goal's signed distance elsewhere) and the error that made it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitConstraint {
    /// Position in continuous voxel coordinates of the goal's grid.
    pub position: DVec3,
    /// Value in voxel units: 0 boundary, positive interior, negative exterior.
    pub value: f64,
    /// The error (voxels) of the candidate it came from; 0 for initial constraints.
    pub error: f32,
}

/// A fitted model and the report of the fit.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The best implicit function found, in mesh units.
    pub implicit: Implicit,
    /// The figures of the fit.
    pub report: FitReport,
}

/// What one evaluation of a model against the goal found.
struct Measured {
    metrics: ErrorMetrics,
    goal_side: BoundaryErrors,
    current_side: BoundaryErrors,
}

/// Fits a variational implicit surface to `goal` with the iterative method of the paper.
///
/// `on_iteration` is called after each iteration with its figures and its model (for progress
/// lines and snapshots). The
/// returned model is the best by E, then RMS, over all iterations.
pub fn fit(
    goal: &Goal,
    options: &FitOptions,
    mut on_iteration: impl FnMut(&IterationReport, &Implicit),
) -> Result<Fit> {
    let started = Instant::now();
    let grid = *goal.grid();
    let mut log = Log { per_iteration: Vec::new(), totals: Timings::default() };
    let stage = fit_level(goal, options, GridLevel::Full, &mut log, &mut on_iteration)?;
    let clock = Instant::now();
    let (implicit, metrics) = stored(goal, stage.implicit, stage.metrics, options, &mut log)?;
    log.totals.misc += clock.elapsed().as_secs_f64();
    log.totals.total = started.elapsed().as_secs_f64();
    let report = report_of(&grid, &metrics, stage.best_iteration, stage.termination, log);
    Ok(Fit { implicit, report })
}

/// The model as stored, and its figures: `implicit` (which measured `metrics`) made compact
/// ([`compact::implicit`]) and measured again, at finer precisions while that takes its E above
/// both the target and its own E before (rounding can tip a voxel's side), up to
/// [`compact::Precision::TRIES`] tries. A try but the last whose rounding moves the surface by
/// more than [`compact::Precision::MOVE_VOXELS`] ([`surface_move`]) goes finer unmeasured: a
/// measure costs as much as an iteration of the loop, making it compact a few milliseconds.
/// When none is within that, the try of least E is kept
/// if it is within [`compact::Precision::SLACK_VOXELS`] more (E moves in steps: a voxel whose
/// side tips moves it by a step), and the function as it is otherwise.
fn stored(
    goal: &Goal,
    implicit: Implicit,
    metrics: ErrorMetrics,
    options: &FitOptions,
    log: &mut Log,
) -> Result<(Implicit, ErrorMetrics)> {
    let allowed = options.error_measure.of(&metrics).max(options.target_error);
    let mut precision = options.precision.clone();
    let mut least: Option<(Implicit, ErrorMetrics)> = None;
    for tries_left in (0..compact::Precision::TRIES).rev() {
        let compact = compact::implicit(implicit.clone(), goal.grid(), &precision)?;
        if compact.lattice().is_none() {
            break;
        }
        if tries_left > 0
            && surface_move(goal, &implicit, &compact) > compact::Precision::MOVE_VOXELS
        {
            precision = precision.finer();
            continue;
        }
        let measured = measure(goal, &compact, options, &mut log.totals).metrics;
        let error = options.error_measure.of(&measured);
        if error <= allowed {
            return Ok((compact, measured));
        }
        if least.as_ref().is_none_or(|(_, m)| error < options.error_measure.of(m)) {
            least = Some((compact, measured));
        }
        precision = precision.finer();
    }
    match least {
        Some((compact, measured))
            if options.error_measure.of(&measured)
                <= allowed + compact::Precision::SLACK_VOXELS =>
        {
            Ok((compact, measured))
        }
        _ => Ok((implicit, metrics)),
    }
}

/// At most this many of the goal's surface points are read by [`surface_move`].
const MOVE_SAMPLES: usize = 4096;

/// How far (voxels) `compact` moves the surface of `implicit` near the goal's surface: the
/// largest `|compact - implicit| / |gradient of implicit|` over the goal's surface points (every
/// one when there are at most [`MOVE_SAMPLES`], evenly spread ones beyond), in double
/// precision.
fn surface_move(goal: &Goal, implicit: &Implicit, compact: &Implicit) -> f64 {
    let grid = goal.grid();
    let stride = goal.surface.len().div_ceil(MOVE_SAMPLES).max(1);
    let sites: Vec<DVec3> =
        goal.surface.iter().step_by(stride).map(|&p| grid.to_world(p)).collect();
    let points: Vec<[f64; 3]> = sites.iter().map(|p| p.to_array()).collect();
    let before = implicit.values3_exact(&points);
    let after = compact.values3_exact(&points);
    let moves: Vec<f64> = before.iter().zip(&after).map(|(a, b)| b - a).collect();
    surface_offset(implicit, &sites, &moves, grid.voxel_size)
}

/// The report of a fit on `grid` whose kept model measured `metrics`, from `log`.
fn report_of(
    grid: &Grid,
    metrics: &ErrorMetrics,
    best_iteration: usize,
    termination: Termination,
    log: Log,
) -> FitReport {
    let Log { per_iteration, totals } = log;
    // A shell's levels have no iterations of the paper's loop below them (no constraints).
    let kept = best_iteration.checked_sub(1).map(|i| per_iteration[i].constraints);
    FitReport {
        version: REPORT_VERSION,
        method: "iterative".into(),
        iterations: per_iteration.len(),
        best_iteration,
        termination,
        constraints: kept.unwrap_or_default(),
        max_error_voxels: metrics.max_error,
        max_error: f64::from(metrics.max_error) * grid.voxel_size,
        weighted_error: metrics.weighted_error,
        rms_error_voxels: metrics.rms_error,
        timings_s: totals,
        dims: grid.dims,
        origin: grid.origin,
        voxel_size: grid.voxel_size,
        per_iteration,
        model_bytes: None,
        mesh_bytes: None,
        winding_near_half: None,
        thickness: None,
        shell_voxels: None,
        levels: None,
        mesh_distance: None,
        byte_budget: None,
        target: None,
        paper_loop: None,
    }
}

/// The fit on `goal`, at grid `level` of the whole fit: the loop from the initial constraints
/// (5.1), or, on a large grid, from the best constraints of the fit on the goal at half the
/// resolution (see `coarse.rs`), itself started the same way on a grid large enough. A goal
/// whose wall the coarser grid loses ([`crate::Error::Thin`] from its initialization) starts on
/// this grid instead.
fn fit_level(
    goal: &Goal,
    options: &FitOptions,
    level: GridLevel,
    log: &mut Log,
    on_iteration: &mut impl FnMut(&IterationReport, &Implicit),
) -> Result<Stage> {
    let clock = Instant::now();
    let coarse = level
        .coarser()
        .and_then(|coarser| Some((coarser, coarse::CoarseStart::of(goal, options)?)));
    let constraints = match coarse {
        Some((coarser, start)) => {
            log.totals.signed_distance += clock.elapsed().as_secs_f64();
            match fit_level(&start.goal, &start.options(options), coarser, log, on_iteration) {
                Ok(stage) => stage.constraints.iter().map(|c| start.to_full(c, goal)).collect(),
                // A wall too thin for the coarser grid starts on this one.
                Err(crate::Error::Thin { .. }) => init::initial_constraints(goal, options)?,
                Err(e) => return Err(e),
            }
        }
        None => init::initial_constraints(goal, options)?,
    };
    iterate(goal, constraints, options, level, log, on_iteration)
}

/// The figures of the iterations so far, and the time they took.
struct Log {
    per_iteration: Vec<IterationReport>,
    totals: Timings,
}

/// The outcome of the loop on one goal: its best model and that model's constraints.
struct Stage {
    implicit: Implicit,
    metrics: ErrorMetrics,
    /// The best model's iteration, counted from the fit's first.
    best_iteration: usize,
    termination: Termination,
    /// The constraints of the best model.
    constraints: Vec<FitConstraint>,
}

/// The loop of paper 5 (5.3 and 5.4) on `goal` from `constraints`, its iterations at grid
/// `level` of the fit, logged in `log`.
fn iterate(
    goal: &Goal,
    mut constraints: Vec<FitConstraint>,
    options: &FitOptions,
    level: GridLevel,
    log: &mut Log,
    on_iteration: &mut impl FnMut(&IterationReport, &Implicit),
) -> Result<Stage> {
    let grid = *goal.grid();
    constraints.truncate(options.constraint_limit());
    let mut best: Option<(Implicit, ErrorMetrics, usize)> = None;
    // The best model's iteration, counted from the fit's first.
    let mut best_in_fit = 0;
    let termination;
    // The lowest E and RMS so far and the last iteration that improved on either (5.4).
    let (mut lowest_error, mut best_rms) = (f32::INFINITY, f32::INFINITY);
    let mut last_improvement = 1;
    let mut iteration = 0;
    // The last model, whose weights start the next solve where it is iterative.
    let mut previous: Option<Implicit> = None;
    loop {
        iteration += 1;
        let mut timings = Timings::default();
        let clock = Instant::now();
        let implicit = solve(&grid, &constraints, options.kernel, previous.as_ref())?;
        previous = Some(implicit.clone());
        timings.misc += clock.elapsed().as_secs_f64();
        let measured = measure(goal, &implicit, options, &mut timings);
        let metrics = measured.metrics;
        timings.total = timings.signed_distance + timings.implicit_evaluation + timings.misc;
        let counts = ConstraintCounts::of_values(constraints.iter().map(|c| c.value));
        let number = log.per_iteration.len() + 1;
        let line = IterationReport::new(
            number,
            counts,
            metrics.in_smaller_voxels(level.voxel_scale()),
            timings,
        )
        .at(level);
        on_iteration(&line, &implicit);
        log.per_iteration.push(line);
        add_timings(&mut log.totals, &timings);
        if best.as_ref().is_none_or(|(_, b, _)| better(&metrics, b, options.error_measure)) {
            best = Some((implicit, metrics, constraints.len()));
            best_in_fit = number;
        }
        let error = options.error_measure.of(&metrics);
        if error < lowest_error
            || metrics.rms_error_subvoxel < best_rms * (1.0 - options.min_rms_improvement)
        {
            last_improvement = iteration;
        }
        lowest_error = lowest_error.min(error);
        best_rms = best_rms.min(metrics.rms_error_subvoxel);
        let lowest_in_full_voxels = lowest_error * level.voxel_scale();
        if let Some(reason) = stop_reason(
            &metrics,
            [iteration, log.per_iteration.len()],
            last_improvement,
            constraints.len(),
            options,
        )
        .or_else(|| options.hand_over?.on_course_past(constraints.len(), lowest_in_full_voxels))
        {
            termination = reason;
            break;
        }
        let clock = Instant::now();
        let mut added = refine::new_constraints(
            goal,
            &measured.goal_side,
            &measured.current_side,
            metrics.max_error_subvoxel,
            &constraints,
            options,
        );
        added.truncate(added_limit(constraints.len(), options));
        log.totals.misc += clock.elapsed().as_secs_f64();
        if added.is_empty() {
            termination = Termination::NoCandidate;
            break;
        }
        constraints.extend(added);
    }
    let (implicit, metrics, count) = best.expect("the loop runs at least once");
    // Constraints are only ever appended: the best model's are the first `count`.
    constraints.truncate(count);
    Ok(Stage { implicit, metrics, best_iteration: best_in_fit, termination, constraints })
}

/// Evaluates `implicit` over the goal's grid (5.2) and measures it against the goal (4.3).
fn measure(
    goal: &Goal,
    implicit: &Implicit,
    options: &FitOptions,
    timings: &mut Timings,
) -> Measured {
    let clock = Instant::now();
    let values = if single_precision_suffices(implicit, goal.grid(), options.target_error) {
        rbf::evaluate_on_grid(&rbf::SinglePrecision(implicit), goal.grid(), Some(&goal.sd))
    } else {
        rbf::evaluate_on_grid(implicit, goal.grid(), Some(&goal.sd))
    };
    timings.implicit_evaluation += clock.elapsed().as_secs_f64();
    measure_values(goal, &values, options, timings)
}

/// E, Ew and RMS of any field (such as a multi-scale model) against `goal`, as [`measure`]
/// measures a model of the loop: evaluated over the goal's grid coarse to fine (5.2).
fn measure_field<F: Field + ?Sized>(goal: &Goal, field: &F, options: &FitOptions) -> ErrorMetrics {
    let values = rbf::evaluate_on_grid(field, goal.grid(), Some(&goal.sd));
    measure_values(goal, &values, options, &mut Timings::default()).metrics
}

/// Measures the current surface of `values`, a model's values over the goal's grid, against
/// the goal (4.3).
fn measure_values(
    goal: &Goal,
    values: &Volume<f32>,
    options: &FitOptions,
    timings: &mut Timings,
) -> Measured {
    let clock = Instant::now();
    let sd_current = current_signed_distance(values, goal, &options.regularity);
    timings.signed_distance += clock.elapsed().as_secs_f64();

    let clock = Instant::now();
    let current_boundary = edt::boundary_voxels(&sd_current);
    let current_fine = SubVoxel { values, level: 0.0, sd: &sd_current, reach: 2.0 };
    let current_points = current_boundary
        .par_iter()
        .map(|v| current_fine.project(DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)))
        .collect();
    let goal_side = BoundaryErrors::new(
        goal.boundary.clone(),
        goal.rreg.clone(),
        goal.surface.clone(),
        &sd_current,
        |p| current_fine.signed_distance(p),
    );
    let unmeasured = vec![f32::NAN; current_boundary.len()];
    let mut current_side =
        BoundaryErrors::new(current_boundary, unmeasured, current_points, &goal.sd, |p| {
            goal.fine_signed_distance(p)
        });
    current_regularity(&goal_side, &mut current_side, &sd_current, options);
    let metrics = ErrorMetrics::measure(&goal_side, &current_side);
    timings.misc += clock.elapsed().as_secs_f64();
    Measured { metrics, goal_side, current_side }
}

/// The volume passes sum in single precision (twice the lanes per vector) while that
/// misplaces the surface by at most this fraction of the target E
/// ([`single_precision_error`]), in double precision beyond.
///
/// Measured at the boundary constraints of the models the fits keep: at the paper's sizes
/// (460 to 730 centres) single precision moves the surface by 0.02 to 0.05 voxels at most,
/// against a target of 2; at 512 (2,000 to 4,300 centres, whose weights are larger and cancel
/// more) by 0.47 to 0.79 voxels at most and 0.14 to 0.47 at the 99th percentile, against a
/// target of 1: there the rounding, not the model, decided whether E came below the target.
const SINGLE_PRECISION_SHARE: f64 = 0.1;

/// Whether the volume passes of `implicit` on `grid` may sum in single precision for a fit
/// aiming at `target_error` voxels (see [`SINGLE_PRECISION_SHARE`]).
fn single_precision_suffices(implicit: &Implicit, grid: &Grid, target_error: f32) -> bool {
    single_precision_error(implicit, grid) <= f64::from(target_error) * SINGLE_PRECISION_SHARE
}

/// At most this many boundary constraints are read by [`single_precision_error`].
const PRECISION_SAMPLES: usize = 2000;

/// How far (voxels of `grid`) the single-precision sums misplace the surface of `implicit`: the
/// largest `|f32 value| / |gradient|` over its boundary constraints (every one when there are
/// at most [`PRECISION_SAMPLES`], evenly spread ones beyond), where the exact value is zero to
/// the solve's residual. The sums there cancel as much as anywhere near the surface.
fn single_precision_error(implicit: &Implicit, grid: &Grid) -> f64 {
    let boundary: Vec<DVec3> = implicit
        .constraints()
        .iter()
        .filter(|c| c.value() == 0.0)
        .map(|c| {
            let mut p = [0.0; 3];
            let k = c.position().len().min(3);
            p[..k].copy_from_slice(&c.position()[..k]);
            DVec3::from_array(p)
        })
        .collect();
    let stride = boundary.len().div_ceil(PRECISION_SAMPLES).max(1);
    let sites: Vec<DVec3> = boundary.into_iter().step_by(stride).collect();
    let values = rbf::SinglePrecision(implicit).values(&sites);
    surface_offset(implicit, &sites, &values, grid.voxel_size)
}

/// How far (voxels of `voxel_size`), to first order, values off those of `implicit` by
/// `offsets` at `sites` move its surface there: the largest `|offset| / |gradient|` (where
/// that is finite).
fn surface_offset(implicit: &Implicit, sites: &[DVec3], offsets: &[f64], voxel_size: f64) -> f64 {
    sites
        .par_iter()
        .zip(offsets)
        .map(|(&p, offset)| offset.abs() / implicit.gradient(p).length() / voxel_size)
        .filter(|e| e.is_finite())
        .fold(|| 0.0, f64::max)
        .reduce(|| 0.0, f64::max)
}

/// The radius of regularity of the current surface where it can matter: at the voxels that
/// may become candidates (a sub-voxel error of at least the error fraction of the largest), and
/// where the weighted error could exceed the goal side's Ew (radii are at least `min_radius`).
/// Elsewhere the radius stays NaN, "not measured": it changes neither Ew nor any candidate, and
/// the walk is the costliest part of measuring a model.
fn current_regularity(
    goal_side: &BoundaryErrors,
    current_side: &mut BoundaryErrors,
    sd_current: &Volume<f32>,
    options: &FitOptions,
) {
    let sides = [goal_side, &*current_side];
    let max_fine = sides
        .iter()
        .flat_map(|side| (0..side.voxels.len()).map(|i| side.fine_error(i)))
        .fold(0.0f32, f32::max);
    let goal_ew =
        (0..goal_side.voxels.len()).map(|i| goal_side.weighted_error(i)).fold(0.0f32, f32::max);
    let min_radius = options.regularity.min_radius as f32;
    let needed: Vec<usize> = (0..current_side.voxels.len())
        .filter(|&i| {
            current_side.fine_error(i) >= max_fine * options.error_fraction
                || current_side.error(i) > goal_ew * min_radius
        })
        .collect();
    let voxels: Vec<[usize; 3]> = needed.iter().map(|&i| current_side.voxels[i]).collect();
    let radii = metrics::radii_of_regularity(sd_current, &voxels, &options.regularity);
    for (i, r) in needed.into_iter().zip(radii) {
        current_side.rreg[i] = r;
    }
}

/// sd_curr: the signed distance of the voxels where the implicit function is positive, exact
/// wherever the measurement reads it.
///
/// That is near the current surface, and at the goal's boundary voxels and around them. Near
/// the current surface, the walks of the radii of regularity read it at most `max_radius`
/// (plus one step of at most √3) from a boundary voxel, one voxel further for the neighbours
/// they compare, and a boundary voxel is next to one of the other state: so the transform is
/// taken within a band `max_radius + tolerance + 6` voxels wide (at least 4 beyond the
/// farthest read), which on large grids leaves most of the volume out. If a goal boundary voxel
/// is within 4 voxels of the band's edge (the current surface is far from part of the goal, as
/// in the first iterations), the trilinear samples around it could read clamped values, and the
/// whole transform is taken instead.
fn current_signed_distance(
    values: &Volume<f32>,
    goal: &Goal,
    regularity: &RegularityOptions,
) -> Volume<f32> {
    let inside = Volume { grid: values.grid, data: values.data.iter().map(|&v| v > 0.0).collect() };
    let band = (regularity.max_radius + regularity.tolerance.max(0.0) + 6.0) as f32;
    // In the first iterations the check below usually fails and this band is thrown away: a
    // fraction of the cost of the whole transform, on grids where iterations are cheap.
    let banded = edt::signed_distance_within(&inside, band);
    let reach = band - 0.5 - 4.0;
    if goal.boundary.par_iter().all(|&v| banded.get(v).abs() < reach) {
        banded
    } else {
        drop(banded);
        edt::signed_distance(&inside)
    }
}

/// Solves for the implicit function through `constraints`, in mesh units, started from
/// `start` (see [`Implicit::solve_from`]) where the constraints extend its own.
pub fn solve(
    grid: &Grid,
    constraints: &[FitConstraint],
    kernel: Kernel,
    start: Option<&Implicit>,
) -> Result<Implicit> {
    let dim = if grid.is_2d() { 2 } else { 3 };
    let rbf_constraints: Vec<rbf::Constraint> = constraints
        .iter()
        .map(|c| {
            let p = grid.to_world(c.position);
            rbf::Constraint::new(&p.to_array()[..dim], c.value * grid.voxel_size)
        })
        .collect();
    Implicit::solve_from(dim, kernel, &rbf_constraints, start)
}

/// How many constraints one iteration may add to `count` (see [`FitOptions::max_growth`]).
fn added_limit(count: usize, options: &FitOptions) -> usize {
    let growth = (count as f64 * options.max_growth).ceil() as usize;
    let room = options.constraint_limit().saturating_sub(count);
    growth.max(options.initial_constraints / 2).min(room)
}

/// Whether `a` is a better model than `b`: smaller E by `measure`, then smaller RMS (paper
/// 5.4), the RMS to sub-voxel precision, which separates models that voxel-centre distances
/// would tie.
fn better(a: &ErrorMetrics, b: &ErrorMetrics, measure: ErrorMeasure) -> bool {
    (measure.of(a), a.rms_error_subvoxel) < (measure.of(b), b.rms_error_subvoxel)
}

/// Why the loop stops after this iteration, if it does (paper 5.4). `[iteration, in_fit]`
/// count this iteration in the loop on one grid (for the patience, from `last_improvement`)
/// and in the whole fit (for the iteration limit, whose iterations at half the resolution
/// count too).
fn stop_reason(
    metrics: &ErrorMetrics,
    [iteration, in_fit]: [usize; 2],
    last_improvement: usize,
    constraint_count: usize,
    options: &FitOptions,
) -> Option<Termination> {
    if options.error_measure.of(metrics) <= options.target_error {
        Some(Termination::TargetError {
            target: options.target_error,
            measure: options.error_measure,
        })
    } else if metrics.weighted_error <= options.target_weighted_error {
        Some(Termination::TargetWeightedError { target: options.target_weighted_error })
    } else if iteration >= last_improvement + options.patience {
        Some(Termination::NoImprovement { patience: options.patience })
    } else if in_fit >= options.max_iterations {
        Some(Termination::IterationLimit { limit: options.max_iterations })
    } else if constraint_count >= options.constraint_limit() {
        Some(Termination::ConstraintLimit { limit: options.constraint_limit() })
    } else {
        None
    }
}

fn add_timings(total: &mut Timings, t: &Timings) {
    total.signed_distance += t.signed_distance;
    total.implicit_evaluation += t.implicit_evaluation;
    total.misc += t.misc;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit goes on while either metric improves and stops `patience` iterations after the
    /// last improvement.
    #[test]
    fn the_patience_counts_from_the_last_improvement_of_either_metric() {
        let options = FitOptions::default();
        let metrics = ErrorMetrics { max_error: 5.0, weighted_error: 1.0, ..Default::default() };
        let stop =
            |iteration, last| stop_reason(&metrics, [iteration, iteration], last, 100, &options);
        assert_eq!(stop(10, 7), None);
        assert_eq!(stop(10, 6), Some(Termination::NoImprovement { patience: 4 }));
        let accurate = ErrorMetrics { max_error: 0.4, ..metrics };
        assert_eq!(
            stop_reason(&accurate, [2, 2], 2, 100, &options),
            Some(Termination::TargetError { target: 2.0, measure: ErrorMeasure::Voxel })
        );
    }

    /// The loop hands over on its forecast only from `forecast_from` of the constraints on, and
    /// only where its lowest E times its constraints over the target passes `forecast_margin`
    /// times them.
    #[test]
    fn the_loop_hands_over_where_its_e_forecasts_too_many_constraints() {
        let hand_over = HandOver::new(&LevelOptions::default(), 1000, 2.0);
        assert_eq!(hand_over.on_course_past(299, 100.0), None, "too early to forecast");
        assert_eq!(
            hand_over.on_course_past(300, 10.01),
            Some(Termination::LoopForecast { constraints: 300, forecast: 1502 })
        );
        assert_eq!(hand_over.on_course_past(300, 10.0), None, "1500: within the margin");
        assert_eq!(hand_over.on_course_past(750, 4.0), None, "on course for 1500");
        assert!(hand_over.on_course_past(800, 4.0).is_some(), "on course for 1600");
        let levels = LevelOptions { forecast_margin: f64::INFINITY, ..Default::default() };
        assert_eq!(HandOver::new(&levels, 1000, 2.0).on_course_past(999, 100.0), None);
        let mut options = FitOptions::default();
        options.levels.forecast_margin = f64::NAN;
        assert!(options.check().unwrap_err().to_string().contains("forecast_margin"));
    }

    /// 400 boundary constraints on a sphere of `radius`, with one inside and one outside.
    fn sphere_constraints(radius: f64) -> Vec<rbf::Constraint> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let mut constraints: Vec<rbf::Constraint> = (0..400)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / 400.0;
                let (r, t) = ((1.0 - z * z).sqrt(), golden * i as f64);
                rbf::Constraint::new(&[radius * r * t.cos(), radius * r * t.sin(), radius * z], 0.0)
            })
            .collect();
        constraints.push(rbf::Constraint::new(&[0.0, 0.0, 0.0], 1.0));
        constraints.push(rbf::Constraint::new(&[2.0, 0.0, 0.0], -1.0));
        constraints
    }

    /// The surface's move that makes `stored` skip a precision: none between a function and
    /// itself, and a sphere's radius grown by 0.3 voxels moves it by 0.3 voxels (to the first
    /// order of the difference over the slope) at the goal's surface points, the densities of
    /// a ball of radius 1 on a grid of voxels 0.05 wide.
    #[test]
    fn the_surface_move_is_the_difference_over_the_slope_at_the_goal_s_surface() {
        let grid = Grid { dims: [60, 60, 60], origin: [-1.5; 3], voxel_size: 0.05 };
        let mut density = Volume::filled(grid, 0.0f32);
        for (i, d) in density.data.iter_mut().enumerate() {
            let r = grid.position(grid.voxel(i)).length();
            *d = (0.5 + (1.0 - r) / grid.voxel_size).clamp(0.0, 1.0) as f32;
        }
        let goal = Goal::from_density(density, &FitOptions::default().regularity);
        assert!(goal.surface.len() > 1000, "{} surface points", goal.surface.len());
        let sphere = Implicit::solve(3, Kernel::ThinPlate, &sphere_constraints(1.0)).unwrap();
        assert_eq!(surface_move(&goal, &sphere, &sphere), 0.0);
        let grown = Implicit::solve(3, Kernel::ThinPlate, &sphere_constraints(1.015)).unwrap();
        let moved = surface_move(&goal, &sphere, &grown);
        assert!((moved - 0.3).abs() < 0.06, "moved {moved} voxels");
    }

    /// A sphere of 400 boundary constraints (radius 1, with a soft constraint inside and one
    /// outside): single precision moves its surface by a small fraction of a voxel of 0.01, and
    /// suffices for a target of 2 such voxels; on a grid of voxels a million times smaller the
    /// same rounding is hundreds of voxels and the passes sum in double precision.
    #[test]
    fn the_volume_passes_sum_in_double_precision_where_single_would_misplace_the_surface() {
        let implicit = Implicit::solve(3, Kernel::ThinPlate, &sphere_constraints(1.0)).unwrap();
        let grid = |voxel_size| Grid { dims: [300, 300, 300], origin: [-1.5; 3], voxel_size };
        let coarse = single_precision_error(&implicit, &grid(0.01));
        assert!(coarse > 0.0 && coarse < 0.01, "{coarse}");
        assert!(single_precision_suffices(&implicit, &grid(0.01), 2.0));
        let fine = single_precision_error(&implicit, &grid(1e-8));
        assert!((fine / coarse - 1e6).abs() < 1.0, "{fine} against {coarse}");
        assert!(!single_precision_suffices(&implicit, &grid(1e-8), 2.0));
    }

    /// Measured at sub-voxel precision, E reaches a target of 1 voxel that the voxel-centre E
    /// of the same surfaces (1.5) does not, and the best model is the one with the smaller
    /// sub-voxel E.
    #[test]
    fn the_subvoxel_measure_judges_the_target_and_the_best_model() {
        let voxel = FitOptions { target_error: 1.0, ..FitOptions::default() };
        let subvoxel = FitOptions { error_measure: ErrorMeasure::SubVoxel, ..voxel.clone() };
        let metrics = ErrorMetrics {
            max_error: 1.5,
            max_error_subvoxel: 0.9,
            weighted_error: 1.0,
            ..Default::default()
        };
        assert_eq!(stop_reason(&metrics, [2, 2], 2, 100, &voxel), None);
        assert_eq!(
            stop_reason(&metrics, [2, 2], 2, 100, &subvoxel),
            Some(Termination::TargetError { target: 1.0, measure: ErrorMeasure::SubVoxel })
        );
        let other = ErrorMetrics { max_error: 1.23, max_error_subvoxel: 1.1, ..metrics };
        assert!(better(&other, &metrics, ErrorMeasure::Voxel));
        assert!(better(&metrics, &other, ErrorMeasure::SubVoxel));
    }
}
