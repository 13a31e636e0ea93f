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
//! It is symmetric but indefinite. It is solved exactly by the null-space method: Householder
//! reflections reduce it to the kernel block on the weights that annihilate the polynomials,
//! which is definite for these kernels and factored by Cholesky (faer, f64, in parallel), a
//! third of the work of an LU of the whole system; iterative refinement follows while it helps.
//! The kernel block is assembled with the vectorized loops of evaluation.
//!
//! This is the solve for up to [`DIRECT_MAX`] constraints; larger systems, whose dense matrix
//! would take `O(n^2)` memory and `O(n^3)` time, go to the iterative solve
//! (`rbf/iterative.rs`), which also starts from the previous model of a fit.
//!
//! Positions are first normalized (centroid and largest extent); the [module doc](crate::rbf)
//! says why that leaves the interpolant unchanged.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use rayon::prelude::*;

use super::schwarz::Settings;
use super::{Constraint, DIMENSIONS, Implicit, Kernel, Normalization, iterative};
use crate::error::{Error, Result};

/// Constraints closer than this, relative to the largest extent, count as coincident.
pub const MIN_SEPARATION: f64 = 1e-9;

/// The largest relative interpolation residual accepted before a system is declared singular.
pub const MAX_RESIDUAL: f64 = 1e-6;

/// The smallest ratio of the least to the largest spread of the positions along any direction
/// before they count as lying in a lower-dimensional flat (on a line in 2D, a plane in 3D).
const MIN_FLATNESS: f64 = 1e-9;

/// The most steps of iterative refinement after the direct solve.
const REFINEMENT_STEPS: usize = 4;

const CONTEXT: &str = "constraints";

/// Systems of up to this many constraints are solved by the dense factorization, larger ones
/// iteratively (`rbf/iterative.rs`). Measured on bunny samples (2 cores, AVX2): the dense
/// solve is faster at 2,000 constraints, the iterative one at 3,000 (2.7x) and beyond.
pub const DIRECT_MAX: usize = 2500;

impl Implicit {
    /// Solves for the variational implicit function interpolating `constraints` in `dim`
    /// dimensions (2, 3 or 4) with `kernel`: positive inside, negative outside.
    ///
    /// The system is solved in normalized coordinates (see the [module doc](crate::rbf) for
    /// why that leaves the function unchanged) by a dense factorization in f64 (the null-space
    /// method and Cholesky, see the module doc), in parallel, with iterative refinement.
    /// [`Implicit::residual`] then holds the largest `|f(c_i) - h_i|` relative to the largest
    /// `|h_i|` (or to the largest extent when every value is zero).
    ///
    /// # Errors
    /// A constraint with the wrong number of coordinates or a NaN or infinite number; two
    /// constraints closer than [`MIN_SEPARATION`] times the largest extent; fewer than `dim + 1`
    /// affinely independent positions (the degree-one polynomial needs them); or a solve whose
    /// residual exceeds [`MAX_RESIDUAL`].
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
            solve_system(dim, kernel, &centres, &values).ok_or_else(|| singular(f64::NAN))?
        } else {
            let start = start
                .filter(|s| s.dim == dim && s.kernel == kernel)
                .and_then(|s| iterative::warm_start(s, constraints, &normalization, &centres));
            iterative::solve(dim, kernel, &centres, &values, start, settings)
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

/// The system matrix of the module doc: the kernel block by the vectorized evaluation loops
/// ([`super::evaluate`]), in parallel, then the polynomial blocks.
pub(super) fn system_matrix(dim: usize, kernel: Kernel, centres: &[f64]) -> Mat<f64> {
    let n = centres.len() / dim;
    system_matrix_with(dim, kernel, centres, dim + 1, |j, t| {
        if t == 0 { 1.0 } else { centres[(t - 1) * n + j] }
    })
}

/// The system matrix for the normalized `centres` with `terms` polynomial terms, the value of
/// term `t` at centre `j` being `term(j, t)`.
pub(super) fn system_matrix_with(
    dim: usize,
    kernel: Kernel,
    centres: &[f64],
    terms: usize,
    term: impl Fn(usize, usize) -> f64,
) -> Mat<f64> {
    let n = centres.len() / dim;
    let m = n + terms;
    let mut columns = vec![0.0; m * m];
    super::evaluate::kernel_columns(dim, kernel, centres, &mut columns, m);
    for (j, col) in columns.chunks_mut(m).enumerate() {
        if j < n {
            for t in 0..terms {
                col[n + t] = term(j, t);
            }
        } else {
            for (i, c) in col[..n].iter_mut().enumerate() {
                *c = term(i, j - n);
            }
        }
    }
    faer::MatRef::from_column_major_slice(&columns, m, m).to_owned()
}

/// Solves the system for the right-hand side `(values, 0)`: the weights, then the polynomial.
/// `None` where the kernel block is not definite on the polynomials' null space, which for
/// these kernels only rounding on a numerically singular arrangement can cause.
fn solve_system(dim: usize, kernel: Kernel, centres: &[f64], values: &[f64]) -> Option<Vec<f64>> {
    let n = values.len();
    let m = n + dim + 1;
    let a = system_matrix(dim, kernel, centres);
    let factored = NullSpace::new(&a, n, dim + 1, kernel)?;
    let b: Vec<f64> = (0..m).map(|i| if i < n { values[i] } else { 0.0 }).collect();
    let mut x = factored.solve(&b);
    // Iterative refinement recovers the digits lost to the factorization's rounding, as long
    // as each step shrinks the residual.
    let residual = |x: &[f64]| -> Vec<f64> {
        let x = Mat::from_fn(m, 1, |i, _| x[i]);
        let ax = &a * &x;
        (0..m).map(|i| b[i] - ax[(i, 0)]).collect()
    };
    let norm = |r: &[f64]| r.iter().fold(0.0f64, |w, v| w.max(v.abs()));
    let mut r = residual(&x);
    for _ in 0..REFINEMENT_STEPS {
        let before = norm(&r);
        let correction = factored.solve(&r);
        let next: Vec<f64> = x.iter().zip(&correction).map(|(x, c)| x + c).collect();
        let r_next = residual(&next);
        let after = norm(&r_next);
        if after.is_nan() || after >= 0.5 * before {
            break;
        }
        (x, r) = (next, r_next);
    }
    Some(x)
}

/// The system of the module doc factored by the null-space method: with Householder
/// reflections `H` that take the polynomial block `Q` to `[R; 0]`, the weights are
/// `d = H^T [y; w]`, where `R^T y` is the right-hand side of the side conditions and `w` solves
/// the trailing block of `H Phi H^T`. That block is the kernel restricted to weights that
/// annihilate every degree-one polynomial, where `r^2 log r` and `r^3` are positive definite
/// and `r` negative definite (they are conditionally definite of order 2, or 1 for `r`), so a
/// Cholesky factorization solves it: a third of the work of an LU of the whole system.
pub(super) struct NullSpace {
    /// The polynomial terms (`dim + 1`).
    terms: usize,
    /// The reflections `I - beta v v^T`, in the order applied to `Q`.
    reflections: Vec<(Vec<f64>, f64)>,
    /// `R`, upper triangular, `terms x terms`.
    r: Mat<f64>,
    /// The first `terms` columns of `H Phi H^T`, column-major, `n x terms`: all the solve
    /// reads of it besides the trailing block, which the Cholesky factor holds.
    coupling: Vec<f64>,
    /// Cholesky factor of `sign` times its trailing block.
    cholesky: faer::linalg::solvers::Llt<f64>,
    /// 1 for positive definite kernels, -1 for `r`.
    sign: f64,
}

impl NullSpace {
    /// Factors the system `a` (from [`system_matrix`]) of `n` constraints and `terms`
    /// polynomial terms.
    pub(super) fn new(a: &Mat<f64>, n: usize, terms: usize, kernel: Kernel) -> Option<NullSpace> {
        let mut q = Mat::from_fn(n, terms, |i, j| a[(i, n + j)]);
        let mut reflections = Vec::with_capacity(terms);
        for k in 0..terms {
            let (v, beta) = householder(&q, k)?;
            reflect_columns(&mut q, &v, beta);
            reflections.push((v, beta));
        }
        let r = Mat::from_fn(terms, terms, |i, j| if i <= j { q[(i, j)] } else { 0.0 });
        let mut transformed: Vec<f64> =
            (0..n).flat_map(|j| a.col_as_slice(j)[..n].iter().copied()).collect();
        for (v, beta) in &reflections {
            reflect_both_sides(&mut transformed, v, *beta);
        }
        let sign = if kernel == Kernel::Linear { -1.0 } else { 1.0 };
        let rest = n - terms;
        let trailing = &transformed[terms * n + terms..];
        let mut block =
            faer::MatRef::from_column_major_slice_with_stride(trailing, rest, rest, n).to_owned();
        if sign < 0.0 {
            block *= faer::Scale(-1.0);
        }
        let cholesky = block.llt(Side::Lower).ok()?;
        transformed.truncate(terms * n);
        transformed.shrink_to_fit();
        Some(NullSpace { terms, reflections, r, coupling: transformed, cholesky, sign })
    }

    /// The solution `(d, p)` for the right-hand side `rhs = (h, g)`.
    pub(super) fn solve(&self, rhs: &[f64]) -> Vec<f64> {
        let t = self.terms;
        let n = rhs.len() - t;
        let (h, g) = rhs.split_at(n);
        // R^T y = g, forward.
        let mut y = vec![0.0; t];
        for i in 0..t {
            let s: f64 = (0..i).map(|k| self.r[(k, i)] * y[k]).sum();
            y[i] = (g[i] - s) / self.r[(i, i)];
        }
        let mut c = h.to_vec();
        for (v, beta) in &self.reflections {
            reflect(&mut c, v, *beta);
        }
        let b = |i: usize, j: usize| self.coupling[j * n + i];
        let rest = n - t;
        let mut w = Mat::from_fn(rest, 1, |i, _| {
            let coupled: f64 = (0..t).map(|k| b(t + i, k) * y[k]).sum();
            self.sign * (c[t + i] - coupled)
        });
        self.cholesky.solve_in_place(w.as_mut());
        // R p = c_top - B11 y - B12 w, backward.
        let top: Vec<f64> = (0..t)
            .map(|i| {
                let b11: f64 = (0..t).map(|k| b(i, k) * y[k]).sum();
                // Row i of B12 is column i of the symmetric B below row t: contiguous.
                let column = &self.coupling[i * n + t..(i + 1) * n];
                let b12: f64 = column.iter().zip(0..rest).map(|(b, k)| b * w[(k, 0)]).sum();
                c[i] - b11 - b12
            })
            .collect();
        let mut p = vec![0.0; t];
        for i in (0..t).rev() {
            let s: f64 = (i + 1..t).map(|k| self.r[(i, k)] * p[k]).sum();
            p[i] = (top[i] - s) / self.r[(i, i)];
        }
        // d = H^T [y; w]: the reflections in reverse order.
        let mut d: Vec<f64> = y.into_iter().chain((0..rest).map(|i| w[(i, 0)])).collect();
        for (v, beta) in self.reflections.iter().rev() {
            reflect(&mut d, v, *beta);
        }
        d.extend(p);
        d
    }
}

/// The reflection `(v, beta)` that zeroes column `k` of `q` below row `k`; `None` if that part
/// of the column is zero (the positions do not span the polynomial space).
fn householder(q: &Mat<f64>, k: usize) -> Option<(Vec<f64>, f64)> {
    let n = q.nrows();
    let norm = (k..n).map(|i| q[(i, k)] * q[(i, k)]).sum::<f64>().sqrt();
    if norm.is_nan() || norm <= 0.0 {
        return None;
    }
    let alpha = if q[(k, k)] > 0.0 { -norm } else { norm };
    let mut v = vec![0.0; n];
    for i in k..n {
        v[i] = q[(i, k)];
    }
    v[k] -= alpha;
    let vv: f64 = v.iter().map(|x| x * x).sum();
    Some((v, 2.0 / vv))
}

/// `x <- (I - beta v v^T) x`.
fn reflect(x: &mut [f64], v: &[f64], beta: f64) {
    let dot: f64 = x.iter().zip(v).map(|(x, v)| x * v).sum();
    for (x, v) in x.iter_mut().zip(v) {
        *x -= beta * dot * v;
    }
}

/// Applies the reflection to every column of `q`.
fn reflect_columns(q: &mut Mat<f64>, v: &[f64], beta: f64) {
    for j in 0..q.ncols() {
        reflect(q.col_as_slice_mut(j), v, beta);
    }
}

/// `b <- H b H` for the symmetric `n x n` column-major `b` and `H = I - beta v v^T`, as the
/// rank-two update `b - v z^T - z v^T` with `u = b v` and `z = beta u - (beta^2 v^T u / 2) v`,
/// in parallel over columns.
fn reflect_both_sides(b: &mut [f64], v: &[f64], beta: f64) {
    let n = v.len();
    let u: Vec<f64> =
        b.par_chunks(n).map(|col| col.iter().zip(v).map(|(x, v)| x * v).sum::<f64>()).collect();
    let gamma: f64 = u.iter().zip(v).map(|(u, v)| u * v).sum();
    let z: Vec<f64> =
        u.iter().zip(v).map(|(u, v)| beta * u - 0.5 * beta * beta * gamma * v).collect();
    b.par_chunks_mut(n).enumerate().for_each(|(j, col)| {
        let (vj, zj) = (v[j], z[j]);
        for ((x, v), z) in col.iter_mut().zip(v).zip(&z) {
            *x -= v * zj + z * vj;
        }
    });
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
