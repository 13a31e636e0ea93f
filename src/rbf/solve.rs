//! The interpolation solve of paper 3.1, equation (2) with its side conditions.
//!
//! For `n` constraints in `dim` dimensions the unknowns are the `n` weights and the `dim + 1`
//! coefficients of the polynomial, and the square system is
//!
//! ```text
//! [ Phi  Q ] [ d ]   [ h ]        Phi_ij = phi(|c_i - c_j|)
//! [ Q^T  0 ] [ p ] = [ 0 ]        Q_i    = (1, c_i)
//! ```
//!
//! It is symmetric but indefinite, and solved exactly by a dense LU factorization with partial
//! pivoting (faer, f64, in parallel), followed by iterative refinement while it helps.
//!
//! Constraints added during the fit are solved from scratch, not by a block update of the
//! factorization: benches/rbf.rs measures the solve for 1,500 constraints (`solve/1500`) at a
//! few percent of the coarse-to-fine grid evaluation that every fit iteration also runs
//! (`grid_200/1500`), so an update could save no more than that.
//!
//! Positions are first normalized (centroid and largest extent); the [module doc](crate::rbf)
//! says why that leaves the interpolant unchanged.

use faer::Mat;
use faer::linalg::solvers::Solve;
use rayon::prelude::*;

use super::{Constraint, DIMENSIONS, Implicit, Kernel, Normalization};
use crate::error::{Error, Result};

/// Constraints closer than this, relative to the largest extent, count as coincident.
pub const MIN_SEPARATION: f64 = 1e-9;

/// The largest relative interpolation residual accepted before a system is declared singular.
pub const MAX_RESIDUAL: f64 = 1e-6;

/// The smallest ratio of the least to the largest spread of the positions along any direction
/// before they count as lying in a lower-dimensional flat (on a line in 2D, a plane in 3D).
const MIN_FLATNESS: f64 = 1e-9;

/// The most steps of iterative refinement after the LU solve.
const REFINEMENT_STEPS: usize = 4;

const CONTEXT: &str = "constraints";

impl Implicit {
    /// Solves for the variational implicit function interpolating `constraints` in `dim`
    /// dimensions (2, 3 or 4) with `kernel`: positive inside, negative outside.
    ///
    /// The system is solved in normalized coordinates (see the [module doc](crate::rbf) for
    /// why that leaves the function unchanged) by a dense LU factorization in f64, in parallel,
    /// with iterative refinement. [`Implicit::residual`] then holds the largest `|f(c_i) - h_i|` relative to
    /// the largest `|h_i|` (or to the largest extent when every value is zero).
    ///
    /// # Errors
    /// A constraint with the wrong number of coordinates or a NaN or infinite number; two
    /// constraints closer than [`MIN_SEPARATION`] times the largest extent; fewer than `dim + 1`
    /// affinely independent positions (the degree-one polynomial needs them); or a solve whose
    /// residual exceeds [`MAX_RESIDUAL`].
    pub fn solve(dim: usize, kernel: Kernel, constraints: &[Constraint]) -> Result<Implicit> {
        check_constraints(CONTEXT, dim, constraints)?;
        let normalization = normalization(dim, constraints)?;
        let centres = normalized_centres(dim, constraints, &normalization);
        check_separation(dim, &centres, constraints, &normalization)?;
        check_affine_span(dim, &centres)?;
        let values: Vec<f64> = constraints.iter().map(|c| c.value).collect();
        let solution = solve_system(dim, kernel, &centres, &values);
        let n = constraints.len();
        let mut implicit = Implicit {
            dim,
            kernel,
            constraints: constraints.to_vec(),
            normalization,
            centres,
            weights: solution[..n].to_vec(),
            polynomial: solution[n..].to_vec(),
            residual: f64::NAN,
        };
        implicit.residual = interpolation_residual(&implicit);
        if implicit.residual.is_nan() || implicit.residual > MAX_RESIDUAL {
            return Err(Error::invalid(
                CONTEXT,
                format!(
                    "the interpolation system is numerically singular (relative residual {:.3e}); \
                     remove constraints that nearly coincide or lie in a degenerate arrangement",
                    implicit.residual
                ),
            ));
        }
        Ok(implicit)
    }
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

/// The system matrix of the module doc, assembled in parallel, column by column.
pub(super) fn system_matrix(dim: usize, kernel: Kernel, centres: &[f64]) -> Mat<f64> {
    let n = centres.len() / dim;
    let m = n + dim + 1;
    let mut a = Mat::<f64>::zeros(m, m);
    a.par_col_iter_mut().enumerate().for_each(|(j, mut col)| {
        if j < n {
            for i in 0..n {
                let r2: f64 =
                    (0..dim).map(|ax| (centres[ax * n + i] - centres[ax * n + j]).powi(2)).sum();
                col[i] = kernel.phi_of_r2(r2);
            }
            col[n] = 1.0;
            for ax in 0..dim {
                col[n + 1 + ax] = centres[ax * n + j];
            }
        } else if j == n {
            for i in 0..n {
                col[i] = 1.0;
            }
        } else {
            for i in 0..n {
                col[i] = centres[(j - n - 1) * n + i];
            }
        }
    });
    a
}

/// Solves the system for the right-hand side `(values, 0)`: the weights, then the polynomial.
fn solve_system(dim: usize, kernel: Kernel, centres: &[f64], values: &[f64]) -> Vec<f64> {
    let n = values.len();
    let m = n + dim + 1;
    let a = system_matrix(dim, kernel, centres);
    let b = Mat::from_fn(m, 1, |i, _| if i < n { values[i] } else { 0.0 });
    let lu = a.partial_piv_lu();
    let mut x = lu.solve(&b);
    // Iterative refinement recovers the digits lost to the LU's rounding, as long as each step
    // shrinks the residual.
    let norm = |r: &Mat<f64>| (0..m).map(|i| r[(i, 0)].abs()).fold(0.0, f64::max);
    let mut r = &b - &a * &x;
    for _ in 0..REFINEMENT_STEPS {
        let before = norm(&r);
        let next = &x + lu.solve(&r);
        let r_next = &b - &a * &next;
        let after = norm(&r_next);
        if after.is_nan() || after >= 0.5 * before {
            break;
        }
        (x, r) = (next, r_next);
    }
    (0..m).map(|i| x[(i, 0)]).collect()
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
