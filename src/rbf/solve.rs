//! The interpolation solve of paper 3.1, equation (2) with its side conditions: the checking
//! front door of both solves.
//!
//! For `n` constraints in `dim` dimensions the unknowns are the `n` weights and the `dim + 1`
//! coefficients of the polynomial, and the square system is
//!
//! ```text
//! [ Phi  Q ] [ d ]   [ h ]        Phi_ij = phi(|c_i - c_j|)
//! [ Q^T  0 ] [ p ] = [ 0 ]        Q_i    = (1, c_i)
//! ```
//!
//! [`Implicit::solve`] checks the constraints, normalizes the positions (centroid and largest
//! extent; the [module doc](crate::rbf) says why that leaves the interpolant unchanged), and
//! solves the system: up to [`DIRECT_MAX`] constraints by the dense factorization
//! ([`super::dense`]), beyond by the iterative solve ([`super::iterative`]), which takes
//! `O(n)` memory and starts from the previous model of a fit.
//!
//! ## Guarantees
//! * Constraints with the wrong number of coordinates or a NaN or infinite number, constraints
//!   closer than [`MIN_SEPARATION`] of the largest extent, and positions in a lower-dimensional
//!   flat are errors before any solve.
//! * An iterative solve whose residual is above [`MAX_RESIDUAL`] of the largest `|h_i|` is an
//!   error.
//! * Either way the solution is then checked by evaluation: a function whose largest
//!   interpolation residual, relative to the largest `|h_i|`, exceeds [`MAX_RESIDUAL`] (or is
//!   NaN) is refused as numerically singular, never returned.

use faer::Mat;
use rayon::prelude::*;

use super::schwarz::Settings;
use super::{Constraint, DIMENSIONS, Implicit, Kernel, Normalization, dense, iterative};
use crate::error::{Error, Result};

/// Constraints closer than this, relative to the largest extent, count as coincident.
pub(crate) const MIN_SEPARATION: f64 = 1e-9;

/// The largest relative interpolation residual accepted before a system is declared singular.
pub(crate) const MAX_RESIDUAL: f64 = 1e-6;

/// The smallest ratio of the least to the largest spread of the positions along any direction
/// before they count as lying in a lower-dimensional flat (on a line in 2D, a plane in 3D).
const MIN_FLATNESS: f64 = 1e-9;

const CONTEXT: &str = "constraints";

/// Systems of up to this many constraints are solved by the dense factorization, larger ones
/// iteratively: about where the iterative solve overtakes the dense one on samples of the
/// bunny.
pub(crate) const DIRECT_MAX: usize = 2500;

impl Implicit {
    /// Solves for the variational implicit function interpolating `constraints` in `dim`
    /// dimensions (2, 3 or 4) with `kernel`: positive inside, negative outside.
    ///
    /// The system is solved in normalized coordinates (see the [module doc](crate::rbf) for
    /// why that leaves the function unchanged), in f64 and in parallel: up to `DIRECT_MAX`
    /// constraints by a dense factorization (the null-space method and Cholesky) with
    /// iterative refinement, beyond by preconditioned FGMRES.
    /// [`Implicit::residual`] then holds the largest `|f(c_i) - h_i|` relative to the largest
    /// `|h_i|` (or to the largest extent when every value is zero).
    ///
    /// # Errors
    /// A constraint with the wrong number of coordinates or a NaN or infinite number; two
    /// constraints closer than `MIN_SEPARATION` times the largest extent; fewer than `dim + 1`
    /// affinely independent positions (the degree-one polynomial needs them); or a solve whose
    /// residual exceeds `MAX_RESIDUAL`.
    pub fn solve(dim: usize, kernel: Kernel, constraints: &[Constraint]) -> Result<Implicit> {
        Implicit::solve_from(dim, kernel, constraints, None)
    }

    /// [`Implicit::solve`], started from `start` where the solve is iterative: a model whose
    /// constraints are the first of `constraints` (as in a fit, which only adds constraints).
    /// The function found is the same, to the solve's tolerance, with or without a start; a
    /// start whose constraints are not a prefix of `constraints` is ignored.
    ///
    /// # Errors
    /// As [`Implicit::solve`].
    pub fn solve_from(
        dim: usize,
        kernel: Kernel,
        constraints: &[Constraint],
        start: Option<&Implicit>,
    ) -> Result<Implicit> {
        Implicit::solve_with(dim, kernel, constraints, start, &Settings::default(), DIRECT_MAX)
    }

    /// The solve with the decomposition `settings` and the dense solve up to `direct_max`
    /// constraints.
    pub(super) fn solve_with(
        dim: usize,
        kernel: Kernel,
        constraints: &[Constraint],
        start: Option<&Implicit>,
        settings: &Settings,
        direct_max: usize,
    ) -> Result<Implicit> {
        check_constraints(CONTEXT, dim, constraints)?;
        let normalization = normalization(dim, constraints)?;
        let centres = normalized_centres(dim, constraints, &normalization);
        check_separation(dim, &centres, constraints, &normalization)?;
        check_affine_span(dim, &centres)?;
        let values: Vec<f64> = constraints.iter().map(|c| c.value).collect();
        let n = constraints.len();
        let solution = if n <= direct_max {
            dense::solve(dim, kernel, &centres, &values).ok_or_else(|| singular(f64::NAN))?
        } else {
            let start = start
                .filter(|s| s.dim == dim && s.kernel == kernel)
                .and_then(|s| iterative::warm_start(s, constraints, &normalization, &centres));
            let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            // Short of the tolerance (rounding sets a floor on ill-conditioned systems, such as
            // nearly coincident centres), a residual within what the solve accepts is still a
            // solution.
            iterative::solve(dim, kernel, &centres, &values, start, settings)
                .filter(|outcome| outcome.residual <= MAX_RESIDUAL * largest)
                .ok_or_else(not_converged)?
                .x
        };
        let mut implicit = Implicit {
            dim,
            kernel,
            constraints: constraints.to_vec(),
            normalization,
            centres,
            weights: solution[..n].to_vec(),
            polynomial: solution[n..].to_vec(),
            residual: f64::NAN,
            lattice: None,
        };
        implicit.residual = interpolation_residual(&implicit);
        if implicit.residual.is_nan() || implicit.residual > MAX_RESIDUAL {
            return Err(singular(implicit.residual));
        }
        Ok(implicit)
    }
}

fn not_converged() -> Error {
    Error::invalid(
        CONTEXT,
        format!(
            "the iterative solve did not reach a relative residual of {:e}; the constraints may \
             nearly coincide or lie in a degenerate arrangement",
            iterative::TOLERANCE
        ),
    )
}

/// Checks that every constraint has `dim` finite coordinates and a finite value.
pub(super) fn check_constraints(
    context: &str,
    dim: usize,
    constraints: &[Constraint],
) -> Result<()> {
    if !DIMENSIONS.contains(&dim) {
        return Err(Error::invalid(context, format!("dimension {dim} is not 2, 3 or 4")));
    }
    for (i, c) in constraints.iter().enumerate() {
        if c.position.len() != dim {
            return Err(Error::invalid(
                context,
                format!(
                    "constraint {} has {} coordinates, expected {dim}",
                    i + 1,
                    c.position.len()
                ),
            ));
        }
        if !c.value.is_finite() || c.position.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid(
                context,
                format!("constraint {} has a NaN or infinite number", i + 1),
            ));
        }
    }
    Ok(())
}

fn singular(residual: f64) -> Error {
    let residual = if residual.is_nan() {
        String::new()
    } else {
        format!(" (relative residual {residual:.3e})")
    };
    Error::invalid(
        CONTEXT,
        format!(
            "the interpolation system is numerically singular{residual}; remove constraints \
             that nearly coincide or lie in a degenerate arrangement"
        ),
    )
}

fn too_few(dim: usize, n: usize) -> Error {
    Error::invalid(
        CONTEXT,
        format!(
            "{n} constraints do not span {dim} dimensions: the degree-one polynomial needs at \
             least {} affinely independent positions (not all on one {})",
            dim + 1,
            match dim {
                2 => "line",
                3 => "plane",
                _ => "hyperplane",
            }
        ),
    )
}

/// The centroid and largest extent of the positions.
fn normalization(dim: usize, constraints: &[Constraint]) -> Result<Normalization> {
    let n = constraints.len();
    if n < dim + 1 {
        return Err(too_few(dim, n));
    }
    let mut translate = vec![0.0; dim];
    let mut scale: f64 = 0.0;
    for (a, t) in translate.iter_mut().enumerate() {
        let axis = constraints.iter().map(|c| c.position[a]);
        let (lo, hi) = axis
            .clone()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        // Summing positions relative to the low corner keeps the centroid exact for meshes far
        // from the origin.
        *t = lo + axis.map(|v| v - lo).sum::<f64>() / n as f64;
        scale = scale.max(hi - lo);
    }
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(too_few(dim, 1));
    }
    Ok(Normalization { translate, scale })
}

/// The normalized centres, one axis after another: `centres[a * n + j]`.
pub(super) fn normalized_centres(
    dim: usize,
    constraints: &[Constraint],
    norm: &Normalization,
) -> Vec<f64> {
    let n = constraints.len();
    let mut centres = vec![0.0; dim * n];
    let mut x = [0.0; 4];
    for (j, c) in constraints.iter().enumerate() {
        norm.apply(&c.position, &mut x[..dim]);
        for a in 0..dim {
            centres[a * n + j] = x[a];
        }
    }
    centres
}

/// Refuses constraints closer than [`MIN_SEPARATION`] (in normalized units), by a sweep along x.
fn check_separation(
    dim: usize,
    centres: &[f64],
    constraints: &[Constraint],
    norm: &Normalization,
) -> Result<()> {
    let n = constraints.len();
    let at = |j: usize, a: usize| centres[a * n + j];
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_unstable_by(|&i, &j| at(i, 0).total_cmp(&at(j, 0)));
    for (s, &i) in order.iter().enumerate() {
        for &j in &order[s + 1..] {
            if at(j, 0) - at(i, 0) >= MIN_SEPARATION {
                break;
            }
            let d2: f64 = (0..dim).map(|a| (at(i, a) - at(j, a)).powi(2)).sum();
            if d2 < MIN_SEPARATION * MIN_SEPARATION {
                let (i, j) = (i.min(j), i.max(j));
                return Err(Error::invalid(
                    CONTEXT,
                    format!(
                        "constraints {} and {} nearly coincide ({:.3e} apart in mesh units, less \
                         than {MIN_SEPARATION:e} of the extent {}): remove one",
                        i + 1,
                        j + 1,
                        d2.sqrt() * norm.scale,
                        norm.scale
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Refuses positions that lie in a lower-dimensional flat, where the polynomial is not
/// determined: the singular values of the centred positions must not vanish.
fn check_affine_span(dim: usize, centres: &[f64]) -> Result<()> {
    let n = centres.len() / dim;
    let mean: Vec<f64> =
        (0..dim).map(|a| centres[a * n..(a + 1) * n].iter().sum::<f64>() / n as f64).collect();
    let x = Mat::from_fn(n, dim, |j, a| centres[a * n + j] - mean[a]);
    let sigma = x.singular_values().map_err(|_| too_few(dim, n))?;
    let largest = sigma.iter().cloned().fold(0.0, f64::max);
    let least = sigma.iter().cloned().fold(f64::INFINITY, f64::min);
    if least.is_nan() || least <= MIN_FLATNESS * largest {
        return Err(too_few(dim, n));
    }
    Ok(())
}

/// The largest `|f(c_i) - h_i|` relative to the largest `|h_i|`, or to the largest extent when
/// every value is zero; evaluated with the same code as any other point. NaN if the solve
/// produced a non-finite number.
fn interpolation_residual(implicit: &Implicit) -> f64 {
    let points: Vec<f64> =
        implicit.constraints.par_iter().flat_map_iter(|c| c.position.clone()).collect();
    let values = implicit.values_flat(&points);
    let reference = implicit.constraints.iter().map(|c| c.value.abs()).fold(0.0, f64::max);
    let reference = if reference > 0.0 { reference } else { implicit.normalization.scale };
    let worst = values.iter().zip(&implicit.constraints).map(|(v, c)| (v - c.value).abs()).fold(
        0.0,
        |w: f64, e| {
            if e.is_nan() || w.is_nan() { f64::NAN } else { w.max(e) }
        },
    );
    worst / reference
}
