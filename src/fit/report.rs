//! The fit report: the columns of the paper's Table 1 (constraints and error) and Table 2
//! (running time), overall and for each iteration.

use std::fmt::Write as _;

use serde::Serialize;

use crate::metrics::ErrorMetrics;
use crate::metrics::surface::MeshDistances;

/// Constraint counts by kind, as in the paper's Table 1.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct ConstraintCounts {
    /// Boundary (zero) constraints.
    pub boundary: usize,
    /// Interior (positive) constraints.
    pub interior: usize,
    /// Exterior (negative) constraints.
    pub exterior: usize,
}

impl ConstraintCounts {
    /// Counts constraints by the sign of their values.
    pub fn of_values(values: impl IntoIterator<Item = f64>) -> Self {
        let mut counts = ConstraintCounts::default();
        for v in values {
            match v.partial_cmp(&0.0) {
                Some(std::cmp::Ordering::Greater) => counts.interior += 1,
                Some(std::cmp::Ordering::Less) => counts.exterior += 1,
                _ => counts.boundary += 1,
            }
        }
        counts
    }

    /// All constraints.
    pub fn total(&self) -> usize {
        self.boundary + self.interior + self.exterior
    }
}

/// Seconds spent in each stage, as in the paper's Table 2.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Timings {
    /// The current surfaces' signed distances; `implicitize fit`, which starts from the mesh,
    /// adds the voxelization and the goal's signed distance and radii of regularity.
    pub signed_distance: f64,
    /// Evaluating the implicit function over the volume (5.2).
    pub implicit_evaluation: f64,
    /// Everything else: solving, radii of regularity, candidates and pruning.
    pub misc: f64,
    /// Wall-clock time of the whole fit (with `implicitize fit`, from the mesh read to the best
    /// model found).
    pub total: f64,
}

impl Timings {
    /// Adds `other`'s times to these (a fit made of two).
    pub fn add(&mut self, other: &Timings) {
        self.signed_distance += other.signed_distance;
        self.implicit_evaluation += other.implicit_evaluation;
        self.misc += other.misc;
        self.total += other.total;
    }
}

/// The grid an iteration ran on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GridLevel {
    /// The fit's grid.
    #[default]
    Full,
    /// Half its resolution (the coarse start): voxels twice the size.
    Half,
    /// A quarter of its resolution (the coarse start of a grid of 512 voxels or more).
    Quarter,
    /// An eighth of its resolution (the coarse start of a grid of 2048 voxels or more).
    Eighth,
}

impl GridLevel {
    /// The side of this level's voxels, in voxels of the full grid.
    pub fn voxel_scale(self) -> f32 {
        match self {
            GridLevel::Full => 1.0,
            GridLevel::Half => 2.0,
            GridLevel::Quarter => 4.0,
            GridLevel::Eighth => 8.0,
        }
    }

    /// The level of half this one's resolution, if there is one.
    pub fn coarser(self) -> Option<GridLevel> {
        match self {
            GridLevel::Full => Some(GridLevel::Half),
            GridLevel::Half => Some(GridLevel::Quarter),
            GridLevel::Quarter => Some(GridLevel::Eighth),
            GridLevel::Eighth => None,
        }
    }

    /// How the progress line names this level: nothing for the full grid.
    fn label(self) -> &'static str {
        match self {
            GridLevel::Full => "",
            GridLevel::Half => "  (half resolution)",
            GridLevel::Quarter => "  (quarter resolution)",
            GridLevel::Eighth => "  (eighth resolution)",
        }
    }
}

/// The figures of one iteration.
#[derive(Debug, Clone, Serialize)]
pub struct IterationReport {
    /// 1 for the model of the initial constraints.
    pub iteration: usize,
    /// The grid the model was measured on. Errors are in voxels of the full grid whatever the
    /// level: those measured at half the resolution are twice their value in its own voxels.
    pub grid: GridLevel,
    /// The model's constraints.
    pub constraints: ConstraintCounts,
    /// E, in voxels.
    pub max_error_voxels: f32,
    /// Ew.
    pub weighted_error: f32,
    /// RMS error, in voxels.
    pub rms_error_voxels: f32,
    /// E to sub-voxel precision (from surface points rather than voxel centres), in voxels.
    pub max_error_subvoxel_voxels: f32,
    /// The RMS error to sub-voxel precision, in voxels.
    pub rms_error_subvoxel_voxels: f32,
    /// Time spent in this iteration.
    pub timings_s: Timings,
}

impl IterationReport {
    /// The report of one iteration.
    pub fn new(
        iteration: usize,
        constraints: ConstraintCounts,
        metrics: ErrorMetrics,
        timings_s: Timings,
    ) -> Self {
        IterationReport {
            iteration,
            grid: GridLevel::Full,
            constraints,
            max_error_voxels: metrics.max_error,
            weighted_error: metrics.weighted_error,
            rms_error_voxels: metrics.rms_error,
            max_error_subvoxel_voxels: metrics.max_error_subvoxel,
            rms_error_subvoxel_voxels: metrics.rms_error_subvoxel,
            timings_s,
        }
    }

    /// This report, of an iteration on the grid `grid`.
    pub fn at(self, grid: GridLevel) -> Self {
        IterationReport { grid, ..self }
    }

    /// One line for the terminal: iteration, constraints, E, Ew, RMS, time, and the grid if it
    /// is not the full one.
    pub fn line(&self) -> String {
        let grid = self.grid.label();
        format!(
            "iteration {:>3}  constraints {:>5} ({} zero, {} in, {} out)  E {:>6.2} ({:.2})  Ew {:>6.3}  RMS {:>6.3} ({:.3})  {:>6.2} s{grid}",
            self.iteration,
            self.constraints.total(),
            self.constraints.boundary,
            self.constraints.interior,
            self.constraints.exterior,
            self.max_error_voxels,
            self.max_error_subvoxel_voxels,
            self.weighted_error,
            self.rms_error_voxels,
            self.rms_error_subvoxel_voxels,
            self.timings_s.total,
        )
    }
}

/// Why a fit stopped (paper 5.4), written in reports as `{"reason": "target_error", ...}`
/// with the limit that was reached.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "reason", rename_all = "snake_case")]
pub enum Termination {
    /// E reached the target (voxels).
    TargetError {
        /// The target E, voxels.
        target: f32,
        /// How E was measured.
        measure: super::ErrorMeasure,
    },
    /// Ew reached the target.
    TargetWeightedError {
        /// The target Ew.
        target: f32,
    },
    /// No model improved on the best E or the lowest RMS error for `patience` iterations.
    NoImprovement {
        /// Iterations without improvement.
        patience: usize,
    },
    /// The iteration limit was reached.
    IterationLimit {
        /// The limit.
        limit: usize,
    },
    /// The constraint limit was reached.
    ConstraintLimit {
        /// The limit.
        limit: usize,
    },
    /// The paper's loop reached [`super::LevelOptions::loop_constraints`] above its target, and
    /// the fit went on with detail levels (see `super::detail::loop_limit`).
    LoopLimit {
        /// The constraints.
        constraints: usize,
    },
    /// The paper's loop, above its target, was on course for more than
    /// [`super::LevelOptions::loop_constraints`] (its lowest E times its constraints over the
    /// target), and the fit went on with detail levels (see `super::detail::loop_limit`).
    LoopForecast {
        /// The constraints.
        constraints: usize,
        /// The constraints it was on course for.
        forecast: usize,
    },
    /// The constraints reached the most whose solve fits in the memory limit (see
    /// [`crate::pipeline::Prepared::fit`]).
    MemoryLimit {
        /// The constraints the memory limit allows.
        constraints: usize,
    },
    /// Every candidate was pruned: nothing was left to add.
    NoCandidate,
    /// The naive method (paper 3.2) solves once.
    SingleSolve,
}

impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Termination::TargetError { target, measure: super::ErrorMeasure::Voxel } => {
                write!(f, "E reached the target of {target} voxels")
            }
            Termination::TargetError { target, measure: super::ErrorMeasure::SubVoxel } => {
                write!(f, "the sub-voxel E reached the target of {target} voxels")
            }
            Termination::TargetWeightedError { target } => {
                write!(f, "Ew reached the target of {target}")
            }
            Termination::NoImprovement { patience } => {
                write!(f, "no improvement in E or RMS over {patience} iterations")
            }
            Termination::IterationLimit { limit } => {
                write!(f, "reached the limit of {limit} iterations (`max_iterations`)")
            }
            Termination::ConstraintLimit { limit } => {
                write!(f, "reached the limit of {limit} constraints (`max_constraints`)")
            }
            Termination::LoopLimit { constraints } => write!(
                f,
                "reached {constraints} constraints above the target, where detail levels go on"
            ),
            Termination::LoopForecast { constraints, forecast } => write!(
                f,
                "on course for {forecast} constraints at {constraints}, where detail levels go on"
            ),
            Termination::MemoryLimit { constraints } => write!(
                f,
                "reached the {constraints} constraints whose solve fits in the memory limit \
                 (`memory_limit`)"
            ),
            Termination::NoCandidate => f.write_str("no candidate survived pruning"),
            Termination::SingleSolve => f.write_str("the naive method solves once"),
        }
    }
}

/// The version of the report's format ([`FitReport::version`]): raised when a field changes
/// meaning or goes away; fields may be added within a version.
pub const REPORT_VERSION: u32 = 2;

/// The whole fit's report (written as JSON by `implicitize fit --report`).
#[derive(Debug, Clone, Serialize)]
pub struct FitReport {
    /// The version of this format, [`REPORT_VERSION`].
    pub version: u32,
    /// How the constraints were made: "iterative" (paper 5) or "naive" (paper 3.2).
    pub method: String,
    /// Iterations run, the initial model counting as the first.
    pub iterations: usize,
    /// The iteration whose model was kept (the best by E, then by RMS).
    pub best_iteration: usize,
    /// Why the loop stopped.
    pub termination: Termination,
    /// The kept model's constraints.
    pub constraints: ConstraintCounts,
    /// The kept model's E, in voxels.
    pub max_error_voxels: f32,
    /// The kept model's E, in mesh units.
    pub max_error: f64,
    /// The kept model's Ew.
    pub weighted_error: f32,
    /// The kept model's RMS error, in voxels.
    pub rms_error_voxels: f32,
    /// Time spent, summed over the whole fit.
    pub timings_s: Timings,
    /// The grid's size.
    pub dims: [usize; 3],
    /// The centre of voxel (0, 0, 0), mesh units.
    pub origin: [f64; 3],
    /// The voxel's side, mesh units.
    pub voxel_size: f64,
    /// The figures of every iteration.
    pub per_iteration: Vec<IterationReport>,
    /// The size of the model file, in bytes, once written.
    pub model_bytes: Option<u64>,
    /// The size of the input mesh file, in bytes, when it came from a file.
    pub mesh_bytes: Option<u64>,
    /// For a mesh's goal, the fraction of the grid's voxels whose generalized winding number
    /// is near one half, where the mesh has no trustworthy inside
    /// ([`crate::voxelize::Ambiguity`]); `None` for a goal given as densities.
    pub winding_near_half: Option<f64>,
    /// How thick the goal's solid is (see [`super::Thickness`]), in voxels of the fit's grid
    /// (measured on the goal's, which may be coarser: `super::detail::goal_grid`); `None` for
    /// a goal given as densities.
    pub thickness: Option<super::Thickness>,
    /// For a fit of a mesh's surface thickened into a shell (`shell`), its thickness in all,
    /// in voxels; absent otherwise. Its `mesh_distance` then measures the model against the
    /// thickened surface (polygonized from the goal's densities).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shell_voxels: Option<f64>,
    /// A multi-scale fit's level 0 and detail levels (see `fit/detail.rs`); absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub levels: Option<LevelsReport>,
    /// For a mesh's fit, the model's polygonized surface (the one `--mesh-out` writes)
    /// measured against the mesh both ways with exact distances, in voxels
    /// (`crate::metrics::surface`); `None` for a goal given as densities, or where either
    /// surface has no area.
    pub mesh_distance: Option<MeshDistances>,
    /// For a fit under a byte budget (`max_bytes`), what was chosen and what was tried; absent
    /// otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub byte_budget: Option<ByteBudget>,
    /// For a mesh's fit, the target E asked for and the E the model reached, by the fit's
    /// measure; `None` for a goal given as densities.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<TargetOutcome>,
    /// For a fit of the paper's loop on a grid without detail levels that was fitted again with
    /// them and replaced (it stalled above its target, `super::detail::stalled`, or left the
    /// mesh's points farther than the target allows, `fit::detail::checks_mesh`): how that
    /// first fit ended; absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_loop: Option<PaperLoop>,
}

/// How a fit of the paper's loop that detail levels replaced ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PaperLoop {
    /// Why it stopped.
    pub termination: Termination,
    /// Its iterations.
    pub iterations: usize,
    /// Its E, voxels.
    pub max_error_voxels: f32,
    /// Where it met its target: the 99.9th percentile of its distance to the mesh's points
    /// (`super::detail::mesh_distance`), voxels, above the target plus
    /// [`super::LevelOptions::mesh_slack`]; absent where it stalled.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh_p999_voxels: Option<f64>,
}

/// The target E a fit was asked for and what it reached.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct TargetOutcome {
    /// How E was measured.
    pub measure: super::ErrorMeasure,
    /// The target E, voxels.
    pub target_voxels: f32,
    /// The model's E by that measure, voxels; for a multi-scale fit, the largest error at the
    /// goal's surface points after its last detail level (see [`FitReport::target_outcome`]).
    pub reached_voxels: f32,
    /// Whether the target was met: `reached_voxels` within `target_voxels`, and for a
    /// multi-scale fit every band voxel on the right side too.
    pub met: bool,
}

impl FitReport {
    /// The model's E by `measure`: for the sub-voxel measure, that of the multi-scale model,
    /// or of the iteration kept.
    pub fn error_by(&self, measure: super::ErrorMeasure) -> f32 {
        let best = self.best_iteration.checked_sub(1).and_then(|i| self.per_iteration.get(i));
        match (measure, &self.levels, best) {
            (super::ErrorMeasure::Voxel, ..) => self.max_error_voxels,
            (super::ErrorMeasure::SubVoxel, Some(levels), _) => levels.max_error_subvoxel_voxels,
            (super::ErrorMeasure::SubVoxel, None, Some(best)) => best.max_error_subvoxel_voxels,
            (super::ErrorMeasure::SubVoxel, None, None) => self.max_error_voxels,
        }
    }

    /// The outcome of a fit to `target` voxels by `measure`. A multi-scale fit is judged as
    /// its detail levels judge themselves: the largest error at the goal's surface points
    /// after the last level, met when the levels stopped for meeting the target (which also
    /// asks every band voxel on the right side); level 0's E is a step towards it.
    pub fn target_outcome(&self, measure: super::ErrorMeasure, target: f32) -> TargetOutcome {
        let (reached, met) = match &self.levels {
            Some(levels) => {
                let at_points = levels
                    .levels
                    .last()
                    .map_or(levels.base_max_error_voxels, |l| l.max_error_voxels);
                (at_points as f32, levels.stopped == LevelsStop::TargetMet)
            }
            None => {
                let reached = self.error_by(measure);
                (reached, reached <= target)
            }
        };
        TargetOutcome { measure, target_voxels: target, reached_voxels: reached, met }
    }
}

/// What a fit under a byte budget chose: the most accurate of the fits it tried whose binary
/// model file is within the budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ByteBudget {
    /// The budget: the most bytes the model file may have.
    pub max_bytes: u64,
    /// The fits tried, in order; the chosen one is `chosen`.
    pub tried: Vec<BudgetTrial>,
    /// The index in `tried` of the fit kept.
    pub chosen: usize,
}

/// One fit tried under a byte budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BudgetTrial {
    /// Voxels along the grid's longest axis.
    pub resolution: usize,
    /// The target E, voxels of that grid.
    pub target_error_voxels: f32,
    /// Detail levels the model has (0: the paper's single function).
    pub levels: usize,
    /// The binary model file's size.
    pub bytes: u64,
    /// The mean of the two mean distances between the model's surface and the mesh, mesh
    /// units (the report's `mesh_distance`): how the fits are compared.
    pub mean_distance: f64,
}

impl FitReport {
    /// The paper's Table 1 and Table 2 rows for this fit, for the terminal.
    pub fn table(&self, name: &str) -> String {
        let [nx, ny, nz] = self.dims;
        let volume = if nz == 1 { format!("{nx} x {ny}") } else { format!("{nx} x {ny} x {nz}") };
        let t = &self.timings_s;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{:<14} {:<16} {:>10} {:>6} {:>9} {:>9} {:>11}",
            "model", "volume", "iterations", "zero", "interior", "exterior", "max error"
        );
        let _ = writeln!(
            s,
            "{:<14} {:<16} {:>10} {:>6} {:>9} {:>9} {:>11.2}",
            name,
            volume,
            self.iterations,
            self.constraints.boundary,
            self.constraints.interior,
            self.constraints.exterior,
            self.max_error_voxels
        );
        let _ = writeln!(
            s,
            "{:<14} {:<16} {:>15} {:>20} {:>10} {:>9}",
            "model", "volume", "signed dist (s)", "implicit eval (s)", "misc (s)", "total (s)"
        );
        let _ = writeln!(
            s,
            "{:<14} {:<16} {:>15.2} {:>20.2} {:>10.2} {:>9.2}",
            name, volume, t.signed_distance, t.implicit_evaluation, t.misc, t.total
        );
        match &self.levels {
            None => {
                let _ = writeln!(
                    s,
                    "stopped: {}; kept iteration {} of {}",
                    self.termination, self.best_iteration, self.iterations
                );
            }
            Some(levels) if self.iterations == 0 => {
                let _ = writeln!(
                    s,
                    "level 0: a constant, outside everywhere (a shell: the levels fit its \
                     thickened surface from it)"
                );
                levels.write_levels(&mut s);
            }
            Some(levels) => {
                if let Some(first) = &self.paper_loop {
                    let far = first.mesh_p999_voxels.map(|far| {
                        format!(", 0.1% of the mesh's points farther than {far:.2} voxels from it")
                    });
                    let _ = writeln!(
                        s,
                        "the paper's loop stopped at E {:.2} after {} iterations ({}){}; fitted \
                         again with detail levels:",
                        first.max_error_voxels,
                        first.iterations,
                        first.termination,
                        far.unwrap_or_default()
                    );
                }
                let [bx, by, bz] = levels.base_dims;
                let _ = writeln!(
                    s,
                    "level 0 ({bx} x {by} x {bz}, {} centres) stopped: {}; kept iteration {} of \
                     {}",
                    levels.base_centres, self.termination, self.best_iteration, self.iterations
                );
                levels.write_levels(&mut s);
            }
        }
        if let Some(d) = &self.mesh_distance {
            let _ = writeln!(
                s,
                "mesh -> model (voxels): max {:.2}, 99.99% {:.2}, 99.9% {:.2}, mean {:.3}; \
                 model -> mesh: max {:.2}, 99.99% {:.2}, 99.9% {:.2}, mean {:.3}",
                d.mesh_to_model.max,
                d.mesh_to_model.p99_99,
                d.mesh_to_model.p99_9,
                d.mesh_to_model.mean,
                d.model_to_mesh.max,
                d.model_to_mesh.p99_99,
                d.model_to_mesh.p99_9,
                d.model_to_mesh.mean
            );
            if let (Some(to), Some(from)) = (&d.solid_to_model, &d.model_to_solid) {
                let _ = writeln!(
                    s,
                    "the solid the open mesh's winding number defines -> model (voxels): max \
                     {:.2}, 99.9% {:.2}, mean {:.3}; model -> that solid: max {:.2}, 99.9% \
                     {:.2}, mean {:.3}",
                    to.max, to.p99_9, to.mean, from.max, from.p99_9, from.mean
                );
            }
            if let Some(solid) = &d.bounding_to_model {
                let _ = writeln!(
                    s,
                    "{:.1}% of the mesh lies inside its own solid; the rest -> model (voxels): \
                     max {:.2}, 99.9% {:.2}, mean {:.3}",
                    100.0 * d.interior,
                    solid.max,
                    solid.p99_9,
                    solid.mean
                );
            }
        }
        s
    }
}

/// The figures of one detail level.
#[derive(Debug, Clone, Serialize)]
pub struct LevelReport {
    /// The support radius, in voxels of the full grid.
    pub radius_voxels: f64,
    /// Its centres, those its pruning kept (`matrix_entries` and the solve's figures are those
    /// of every centre chosen, before the pruning).
    pub centres: usize,
    /// What it adds to the binary model file, in bytes (0 until the model is finished: see
    /// [`crate::pipeline::Fitted::finish`]).
    pub bytes: usize,
    /// Stored entries of its sparse matrix.
    pub matrix_entries: usize,
    /// Conjugate gradient iterations of its solve.
    pub solve_iterations: usize,
    /// The largest interpolation residual at its centres, relative to the largest value.
    pub solve_residual: f64,
    /// The largest error at the goal's surface points before this level (with the levels
    /// below it), in voxels.
    pub max_error_before_voxels: f64,
    /// The 99.9th percentile of those errors, in voxels.
    pub p999_error_before_voxels: f64,
    /// The largest error at the goal's surface points with this level, in voxels.
    pub max_error_voxels: f64,
    /// The 99.9th percentile of those errors, in voxels.
    pub p999_error_voxels: f64,
    /// Voxels of the band where the levels below gave the wrong side, which this level fitted
    /// to the goal's signed distance.
    pub wrong_side_voxels: usize,
    /// Seconds spent on this level.
    pub seconds: f64,
}

/// The figures of a multi-scale fit, beside the report of its level 0.
#[derive(Debug, Clone, Serialize)]
pub struct LevelsReport {
    /// Level 0's grid.
    pub base_dims: [usize; 3],
    /// Level 0's centres.
    pub base_centres: usize,
    /// The binary model file's size with level 0 alone, in bytes (0 until the model is
    /// finished).
    pub base_bytes: usize,
    /// The largest error at the goal's surface points with level 0 alone, in voxels of the
    /// full grid.
    pub base_max_error_voxels: f64,
    /// The 99.9th percentile of those errors.
    pub base_p999_error_voxels: f64,
    /// The goal's surface points the levels were fitted at.
    pub points: usize,
    /// The slits narrower than a voxel the goal was carved for, if any (`fit/slit.rs`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slits: Option<super::SlitReport>,
    /// The band, in voxels of the full grid, of the goal's signed distance in which the side
    /// of the model is checked: level 0's sub-voxel E plus 2 voxels.
    pub band_voxels: f64,
    /// The multi-scale model's sub-voxel E against the goal, both ways, measured on the goal's
    /// grid, in voxels of the full grid.
    pub max_error_subvoxel_voxels: f32,
    /// Its RMS sub-voxel error.
    pub rms_error_subvoxel_voxels: f32,
    /// Each detail level, coarsest first.
    pub levels: Vec<LevelReport>,
    /// Why no further level was added.
    pub stopped: LevelsStop,
}

/// Why a multi-scale fit added no further detail level.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LevelsStop {
    /// Every point within the target and no band voxel on the wrong side.
    TargetMet,
    /// The next level's support would be below [`super::LevelOptions::min_radius`].
    SmallestRadius,
    /// [`super::LevelOptions::max_levels`] levels were added.
    LevelLimit,
    /// No point or band voxel was worth a centre.
    NoCentre,
}

impl std::fmt::Display for LevelsStop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LevelsStop::TargetMet => "the target was met",
            LevelsStop::SmallestRadius => {
                "the next level's support would be below the least radius"
            }
            LevelsStop::LevelLimit => "the level limit was reached",
            LevelsStop::NoCentre => "no point was worth a centre",
        })
    }
}

impl LevelsReport {
    /// The 99.9th percentile of the residual at the levels' points after the last level (level
    /// 0's where there is none), voxels.
    pub fn p999(&self) -> f64 {
        self.levels.last().map_or(self.base_p999_error_voxels, |l| l.p999_error_voxels)
    }

    /// One line of the report's table a detail level.
    pub(super) fn write_levels(&self, s: &mut String) {
        use std::fmt::Write;
        for (k, level) in self.levels.iter().enumerate() {
            let _ = writeln!(
                s,
                "level {} (radius {:.1} voxels): {} centres, max error at the points {:.2} voxels",
                k + 1,
                level.radius_voxels,
                level.centres,
                level.max_error_voxels
            );
        }
        let _ = writeln!(s, "detail levels stopped: {}", self.stopped);
        if let Some(slits) = &self.slits {
            let [lo, hi] = slits.bounds;
            let _ = writeln!(
                s,
                "slits narrower than a voxel: {:.3}% of the mesh on their walls, {} voxels opened \
                 ({} left inside), within ({:.4}, {:.4}, {:.4}) - ({:.4}, {:.4}, {:.4})",
                100.0 * slits.share,
                slits.carved_voxels,
                slits.closed_voxels,
                lo[0],
                lo[1],
                lo[2],
                hi[0],
                hi[1],
                hi[2]
            );
        }
    }
}
