//! The dense solve of paper 3.1's interpolation system, equation (2) with its side conditions,
//! for the direct solve of up to [`super::DIRECT_MAX`] constraints and for the local problems of
//! the domain decomposition preconditioner ([`super::schwarz`]).
//!
//! For `n` centres and `t` polynomial terms (`dim + 1`, or fewer on a local problem's own
//! affine span) the system is
//!
//! ```text
//! [ Phi  Q ] [ d ]   [ h ]        Phi_ij = phi(|c_i - c_j|)
//! [ Q^T  0 ] [ p ] = [ g ]        Q_it   = term t at c_i
//! ```
//!
//! It is symmetric but indefinite. [`NullSpace`] factors it by the null-space method:
//! Householder reflections reduce it to the kernel block on the weights that annihilate the
//! polynomials, which is definite for these kernels and factored by Cholesky (faer, f64, in
//! parallel), a third of the work of an LU of the whole system. The kernel block is assembled
//! by the loops of evaluation ([`super::kernel::kernel_columns`]).
//!
//! ## Guarantees
//! * [`NullSpace::new`] refuses (`None`) positions that do not span the polynomial terms and a
//!   kernel block that is not definite on the polynomials' null space, which for these kernels
//!   only rounding on a numerically singular arrangement causes; a factorization it returns
//!   solves the system exactly up to rounding.
//! * [`solve`] refines its solution while each step at least halves the residual, so the
//!   digits lost to the factorization's rounding are recovered where they can be.
//! * Memory is `O(n^2)` and time `O(n^3)`: the iterative solve takes larger systems.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use rayon::prelude::*;

use super::kernel::{self, Kernel};

/// The most steps of iterative refinement after the factorization.
const REFINEMENT_STEPS: usize = 4;

/// The system matrix of the module doc for the normalized `centres` (one axis after another)
/// and the degree-one polynomial `(1, c)`: the kernel block by the loops of evaluation, in
/// parallel, then the polynomial blocks.
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
    kernel::kernel_columns(dim, kernel, centres, &mut columns, m);
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

/// Solves the system for the normalized `centres` (one axis after another), the degree-one
/// polynomial and the right-hand side `(values, 0)`: the weights, then the polynomial. `None`
/// where [`NullSpace::new`] refuses the system.
pub(super) fn solve(
    dim: usize,
    kernel: Kernel,
    centres: &[f64],
    values: &[f64],
) -> Option<Vec<f64>> {
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
        // With as many constraints as terms (a tetrahedron's corners in 3D) the block is empty.
        let trailing = transformed.get(terms * n + terms..).unwrap_or_default();
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
