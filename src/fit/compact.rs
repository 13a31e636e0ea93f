//! Compact by construction: the fit puts its functions' numbers on a lattice
//! ([`rbf::Lattice`]) as it makes them, so that the model file stores small integers, and
//! every figure the fit reports is that of the function as stored.
//!
//! ```text
//! level 0      centres snapped to a lattice of voxel / centre_cells_per_voxel (boundary
//!              constraints move by at most half a cell's diagonal), values to voxel / 64,
//!              solved again through them; weights rounded to the coarsest step 2^-b max|d| that keeps the function within
//!              level0_tolerance voxels of the unrounded one at its constraints
//! detail level centres snapped to a lattice of rho / level_cells_per_radius before the level's
//!              solve (so it interpolates at the points stored), weights rounded to
//!              level_weight_step voxels after it, and its centres whose weight is at most
//!              level_prune_steps steps dropped (pruning); the next level fits what this one,
//!              rounded and pruned, left (error feedback), and the report measures the levels
//!              as stored
//! ```
//!
//! Centres are listed along the Morton curve of their lattice points, the order in which the
//! model file's octree lists them, so that a model read back sums in the same order.

use serde::Serialize;

use crate::error::Result;
use crate::geometry::DVec3;
use crate::grid::Grid;
use crate::rbf::{self, Constraint, DetailLevel, Implicit, Lattice};

/// How finely the fit stores its functions, part of [`super::FitOptions`].
#[derive(Debug, Clone, PartialEq, Serialize)]
#[non_exhaustive]
pub struct Precision {
    /// Level 0's centres lie on a lattice of this many points per voxel of its grid; 0 stores
    /// every number as it is (no lattice).
    pub centre_cells_per_voxel: u32,
    /// Level 0's rounded weights keep its values at its constraints within this many voxels of
    /// its grid of the unrounded function's (solved through the snapped constraints).
    pub level0_tolerance: f64,
    /// A detail level's centres lie on a lattice of this many points per support radius.
    pub level_cells_per_radius: u32,
    /// A detail level's weights are whole multiples of this many voxels of the fit's grid.
    pub level_weight_step: f64,
    /// A detail level drops the centres whose rounded weight is at most this many steps, whose
    /// part of the sum is at most that many steps anywhere; the next level fits what they
    /// leave, as it fits what the rounding leaves.
    pub level_prune_steps: u32,
}

impl Default for Precision {
    fn default() -> Self {
        Precision {
            centre_cells_per_voxel: 16,
            level0_tolerance: 0.02,
            level_cells_per_radius: 16,
            level_weight_step: 1.0 / 32.0,
            level_prune_steps: 1,
        }
    }
}

impl Precision {
    /// How many precisions, each [`Precision::finer`] than the one before, a fit tries before
    /// it stores its function as it is.
    pub const TRIES: usize = 3;

    /// A rounding that moves the surface near the goal's by more than this many voxels is
    /// not measured but made finer, while finer tries are left: on the paper's models at the
    /// defaults, the coarsest precision moved the bunny's by 0.37 voxels (its E rose from 1.95
    /// to 2.5), the triceratops' by 0.14 (E 3.97) and the horse's by 0.13 (E kept 1.95), so
    /// moves of a few tenths never kept E, and a skip costs only a finer try's bytes.
    pub const MOVE_VOXELS: f64 = 0.25;

    /// How far, in voxels, the E of a stored function may exceed both the target and the
    /// unrounded function's E when no precision tried keeps it within them.
    pub const SLACK_VOXELS: f32 = 0.5;

    /// A finer precision: level 0's lattice twice as fine and its tolerance a quarter.
    pub fn finer(&self) -> Precision {
        Precision {
            centre_cells_per_voxel: self.centre_cells_per_voxel.saturating_mul(2),
            level0_tolerance: self.level0_tolerance / 4.0,
            ..self.clone()
        }
    }

    /// Whether the fit stores its functions on lattices.
    pub fn is_on(&self) -> bool {
        self.centre_cells_per_voxel > 0
    }
}

/// Constraint values are whole multiples of this fraction of a voxel.
const VALUE_STEP_VOXELS: f64 = 1.0 / 64.0;

/// At most this many constraints are the check points of level 0's rounding.
const MAX_CHECK_POINTS: usize = 4096;

/// `implicit`, fitted on `grid`, with its centres, values and weights on a lattice (see the
/// module doc): solved again through its constraints snapped to the lattice (moving a weight's
/// centre without a new solve would move the function by the weight, which is large where the
/// weights cancel), then its weights rounded. Unchanged when it is not 3D, its centres are too
/// far apart for the lattice, or two of them fall on one lattice point.
///
/// # Errors
/// What the solve through the snapped constraints reports.
pub(crate) fn implicit(implicit: Implicit, grid: &Grid, precision: &Precision) -> Result<Implicit> {
    if implicit.dim() != 3 || !precision.is_on() {
        return Ok(implicit);
    }
    let voxel = grid.voxel_size;
    let lattice = Lattice {
        origin: DVec3::from_array(grid.origin),
        cell: voxel / f64::from(precision.centre_cells_per_voxel),
        weight_step: 1.0,
        value_step: voxel * VALUE_STEP_VOXELS,
    };
    let Some(snapped) = snap_constraints(&implicit, &lattice) else {
        return Ok(implicit);
    };
    let solved = Implicit::solve(3, implicit.kernel(), &snapped)?;
    let checks = check_points(&solved);
    let exact = solved.values3_exact(&checks);
    let largest = solved.weights().iter().fold(0.0f64, |m, w| m.max(w.abs()));
    let tolerance = precision.level0_tolerance * voxel;
    let at_bits = |bits: i32| -> Result<(Implicit, bool)> {
        let mut lattice = lattice;
        lattice.weight_step = if largest > 0.0 { largest * 2f64.powi(-bits) } else { 1.0 };
        let weights = round_all(solved.weights(), lattice.weight_step);
        let rounded = rebuild(&solved, weights, lattice)?;
        let values = rounded.values3_exact(&checks);
        let within = values.iter().zip(&exact).all(|(a, b)| (a - b).abs() <= tolerance);
        Ok((rounded, within))
    };
    // The fewest bits within the tolerance, by bisection; 36, short of the most a lattice index
    // holds, keeps the weights within 1e-11 of the largest.
    let (mut lo, mut hi) = (4, 36);
    let (mut best, within) = at_bits(hi)?;
    if !within {
        return Ok(best);
    }
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        let (rounded, within) = at_bits(mid)?;
        if within {
            (hi, best) = (mid, rounded);
        } else {
            lo = mid;
        }
    }
    Ok(best)
}

/// The constraints of `implicit` snapped to `lattice`, in the lattice's Morton order, values
/// rounded: None when the lattice cannot hold them (too far apart, or two on one point).
fn snap_constraints(implicit: &Implicit, lattice: &Lattice) -> Option<Vec<Constraint>> {
    let keys: Vec<[i64; 3]> = implicit
        .constraints()
        .iter()
        .map(|c| lattice.nearest(DVec3::from_slice(c.position())))
        .collect::<Option<_>>()?;
    let order = rbf::lattice_order(&keys)?;
    if order.windows(2).any(|w| keys[w[0]] == keys[w[1]]) {
        return None;
    }
    Some(
        order
            .into_iter()
            .map(|i| {
                let value = round_value(implicit.constraints()[i].value(), lattice.value_step);
                Constraint::new(&lattice.point(keys[i]).to_array(), value)
            })
            .collect(),
    )
}

/// `value` rounded to a multiple of `step`, keeping its kind: a nonzero value stays at least one
/// step from zero.
fn round_value(value: f64, step: f64) -> f64 {
    let k = Lattice::nearest_multiple(value, step).unwrap_or(0);
    let k = if value == 0.0 { 0 } else { k.abs().max(1) * value.signum() as i64 };
    k as f64 * step
}

/// Every weight rounded to a multiple of `step`.
fn round_all(weights: &[f64], step: f64) -> Vec<f64> {
    weights.iter().map(|&w| Lattice::nearest_multiple(w, step).unwrap_or(0) as f64 * step).collect()
}

/// `implicit` with `weights`, on `lattice`.
fn rebuild(implicit: &Implicit, weights: Vec<f64>, lattice: Lattice) -> Result<Implicit> {
    Ok(Implicit::from_parts(
        "the compact model",
        3,
        implicit.kernel(),
        implicit.constraints().to_vec(),
        implicit.normalization().clone(),
        weights,
        implicit.polynomial().to_vec(),
        implicit.residual(),
    )?
    .on_lattice(lattice))
}

/// Up to [`MAX_CHECK_POINTS`] of the constraints' positions, evenly through their list.
fn check_points(implicit: &Implicit) -> Vec<[f64; 3]> {
    let constraints = implicit.constraints();
    let stride = constraints.len().div_ceil(MAX_CHECK_POINTS).max(1);
    constraints.iter().step_by(stride).map(|c| DVec3::from_slice(c.position()).to_array()).collect()
}

/// The lattice of a detail level of support `radius` over `grid`: its centres' spacing and its
/// weights' step.
pub(crate) fn level_lattice(radius: f64, grid: &Grid, precision: &Precision) -> Option<Lattice> {
    precision.is_on().then(|| Lattice {
        origin: DVec3::from_array(grid.origin),
        cell: radius / f64::from(precision.level_cells_per_radius.max(1)),
        weight_step: precision.level_weight_step * grid.voxel_size,
        value_step: grid.voxel_size * VALUE_STEP_VOXELS,
    })
}

/// The candidate centres `chosen` (indices into `points`) snapped to `lattice`, one per lattice
/// point (the first, the one of largest error, wins), with the indices kept.
pub(crate) fn snap_centres(
    points: &[DVec3],
    chosen: &[usize],
    lattice: &Lattice,
) -> (Vec<DVec3>, Vec<usize>) {
    let mut seen = std::collections::HashSet::new();
    let mut centres = Vec::with_capacity(chosen.len());
    let mut kept = Vec::with_capacity(chosen.len());
    for &i in chosen {
        let Some(k) = lattice.nearest(points[i]) else { continue };
        if seen.insert(k) {
            centres.push(lattice.point(k));
            kept.push(i);
        }
    }
    (centres, kept)
}

/// `level` with its weights rounded to its lattice's step, on that lattice, without the centres
/// whose rounded weight is at most `prune_steps` steps.
pub(crate) fn round_level(
    level: DetailLevel,
    lattice: Lattice,
    prune_steps: u32,
) -> Result<DetailLevel> {
    let step = lattice.weight_step;
    let (centres, weights): (Vec<DVec3>, Vec<f64>) = level
        .centres()
        .iter()
        .zip(level.weights())
        .filter_map(|(&c, &w)| {
            let steps = Lattice::nearest_multiple(w, step).unwrap_or(0);
            (steps.unsigned_abs() > u64::from(prune_steps)).then_some((c, steps as f64 * step))
        })
        .unzip();
    Ok(DetailLevel::new("a detail level", level.radius(), centres, weights)?.on_lattice(lattice))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rounded_value_keeps_its_kind() {
        let step = 0.25;
        assert_eq!(round_value(0.0, step), 0.0);
        assert_eq!(round_value(0.01, step), 0.25);
        assert_eq!(round_value(-0.01, step), -0.25);
        assert_eq!(round_value(1.3, step), 1.25);
    }

    /// A thin-plate ball fitted on a grid, made compact: its centres on the lattice in Morton
    /// order, its weights multiples of the step, and its values at the constraints within the
    /// tolerance of the unrounded function's.
    #[test]
    fn a_compact_function_lies_on_its_lattice_within_the_tolerance() {
        let grid = Grid { dims: [40, 40, 40], origin: [-2.0, -2.0, -2.0], voxel_size: 0.1 };
        let mut constraints = Vec::new();
        for i in 0..200 {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 200.0;
            let a = i as f64 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            constraints.push(Constraint::new(&[r * a.cos(), r * a.sin(), z], 0.0));
        }
        constraints.push(Constraint::new(&[0.0, 0.0, 0.0], 1.0));
        constraints.push(Constraint::new(&[1.5, 0.3, 0.0], -0.5));
        let implicit = Implicit::solve(3, rbf::Kernel::default(), &constraints).unwrap();
        let precision = Precision::default();
        let compact = super::implicit(implicit.clone(), &grid, &precision).unwrap();
        let lattice = *compact.lattice().expect("on a lattice");
        let keys: Vec<[i64; 3]> = compact
            .constraints()
            .iter()
            .map(|c| lattice.index(DVec3::from_slice(c.position())).expect("a lattice point"))
            .collect();
        assert_eq!(rbf::lattice_order(&keys).unwrap(), (0..keys.len()).collect::<Vec<_>>());
        for (c, w) in compact.constraints().iter().zip(compact.weights()) {
            assert!(Lattice::multiple(*w, lattice.weight_step).is_some());
            assert!(Lattice::multiple(c.value(), lattice.value_step).is_some());
        }
        let points: Vec<[f64; 3]> =
            constraints.iter().map(|c| DVec3::from_slice(c.position()).to_array()).collect();
        // Within the tolerance of the rounding and the snap (half a cell's diagonal, at a
        // slope of about one).
        let snap = 0.5 * 3f64.sqrt() * lattice.cell;
        let tolerance = precision.level0_tolerance * grid.voxel_size + snap;
        for (a, b) in implicit.values3_exact(&points).iter().zip(compact.values3_exact(&points)) {
            assert!((a - b).abs() <= tolerance, "{a} {b}");
        }
        assert!(lattice.weight_step > 0.0);
    }

    /// Rounding a level drops the centres whose rounded weight is at most the pruning's steps
    /// and keeps the others' rounded weights; without pruning only the zero weights go, which
    /// changes no value.
    #[test]
    fn a_rounded_level_drops_its_smallest_weights() {
        let grid = Grid { dims: [20, 20, 20], origin: [0.0; 3], voxel_size: 0.1 };
        let lattice = level_lattice(0.4, &grid, &Precision::default()).expect("on");
        let step = lattice.weight_step;
        let centres: Vec<DVec3> =
            (0..6).map(|i| DVec3::new(0.5 + 0.1 * i as f64, 1.0, 1.0)).collect();
        let weights = vec![0.2 * step, 0.9 * step, -1.4 * step, 2.2 * step, -7.0 * step, 0.0];
        let level = DetailLevel::new("a level", 0.4, centres, weights).unwrap();
        let kept = |prune| {
            let rounded = round_level(level.clone(), lattice, prune).unwrap();
            let mut weights: Vec<i64> =
                rounded.weights().iter().map(|&w| Lattice::multiple(w, step).unwrap()).collect();
            weights.sort_unstable();
            (rounded, weights)
        };
        assert_eq!(kept(0).1, [-7, -1, 1, 2]);
        assert_eq!(kept(1).1, [-7, 2]);
        assert_eq!(kept(2).1, [-7]);
        let rounded = round_all(level.weights(), step);
        let unpruned = DetailLevel::new("a level", 0.4, level.centres().to_vec(), rounded).unwrap();
        for x in [0.3, 0.55, 0.8, 1.0, 1.2] {
            let p = DVec3::new(x, 1.02, 0.97);
            assert_eq!(kept(0).0.value(p), unpruned.value(p));
        }
    }
}
