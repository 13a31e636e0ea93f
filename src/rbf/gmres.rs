//! The flexible generalized minimal residual method (FGMRES, Saad 1993), restarted: the Krylov
//! solver of the iterative interpolation solve ([`super::iterative`]).
//!
//! GMRES suits the interpolation system, which is symmetric but indefinite (a saddle point):
//! it needs only products with the matrix, and the preconditioner (domain decomposition,
//! [`super::schwarz`]) need not be symmetric. The flexible variant keeps the preconditioned
//! directions, so the solution is updated without applying the preconditioner again.
//!
//! Arnoldi by modified Gram-Schmidt, the small least-squares problem by Givens rotations; the
//! residual norm it tracks is checked against the true residual at every restart and at the end.
//! A run ends at the tolerance, at the iteration limit, or when a whole cycle fails to halve
//! the true residual (the floor set by rounding in the products, on ill-conditioned systems).

/// What a run of [`fgmres`] achieved.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Outcome {
    /// The solution reached.
    pub x: Vec<f64>,
    /// Whether the true residual's norm reached the tolerance.
    pub converged: bool,
    /// Products with the matrix, the preconditioned ones and the restarts' residuals together.
    pub products: usize,
    /// The true residual's Euclidean norm at `x`.
    pub residual: f64,
}

/// A restart that leaves the true residual above this fraction of the last one ends the run.
const STALL: f64 = 0.5;

/// The limits of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Limits {
    /// Stop once the residual's Euclidean norm is at most this.
    pub tolerance: f64,
    /// Krylov directions kept before a restart.
    pub restart: usize,
    /// Preconditioned products in all, over every restart.
    pub max_iterations: usize,
}

/// Solves `A x = b` from the start `x0`, with `matrix(v) = A v` and `precondition(v)` an
/// approximation of `A^-1 v`.
pub(super) fn fgmres(
    matrix: impl Fn(&[f64]) -> Vec<f64>,
    precondition: impl Fn(&[f64]) -> Vec<f64>,
    b: &[f64],
    x0: Vec<f64>,
    limits: Limits,
) -> Outcome {
    let mut x = x0;
    let mut products = 0;
    let mut iterations = 0;
    let mut last = f64::INFINITY;
    loop {
        let r = residual(&matrix, b, &x);
        products += 1;
        let beta = norm(&r);
        // A cycle that did not halve the true residual has reached the floor that rounding in
        // the products sets: more cycles would only repeat it.
        let stalled = beta > STALL * last;
        if !beta.is_finite()
            || beta <= limits.tolerance
            || iterations >= limits.max_iterations
            || stalled
        {
            let converged = beta <= limits.tolerance;
            return Outcome { x, converged, products, residual: beta };
        }
        last = beta;
        let steps = limits.restart.min(limits.max_iterations - iterations);
        let cycle = arnoldi_cycle(&matrix, &precondition, r, beta, steps, limits.tolerance);
        iterations += cycle.directions.len();
        products += cycle.directions.len();
        for (z, y) in cycle.directions.iter().zip(&cycle.coefficients) {
            for (x, z) in x.iter_mut().zip(z) {
                *x += y * z;
            }
        }
        if cycle.directions.is_empty() {
            // A breakdown before the first direction: nothing more can be gained.
            return Outcome { x, converged: false, products, residual: beta };
        }
    }
}

/// One cycle's preconditioned directions and their coefficients in the update.
struct Cycle {
    directions: Vec<Vec<f64>>,
    coefficients: Vec<f64>,
}

/// Up to `steps` Arnoldi steps from the residual `r` of norm `beta`, stopping early once the
/// least-squares residual is at most `tolerance`.
fn arnoldi_cycle(
    matrix: &impl Fn(&[f64]) -> Vec<f64>,
    precondition: &impl Fn(&[f64]) -> Vec<f64>,
    r: Vec<f64>,
    beta: f64,
    steps: usize,
    tolerance: f64,
) -> Cycle {
    let mut basis = vec![scaled(r, 1.0 / beta)];
    let mut directions: Vec<Vec<f64>> = Vec::new();
    // Columns of the Hessenberg matrix, already rotated to upper triangular form.
    let mut h: Vec<Vec<f64>> = Vec::new();
    let mut rotations: Vec<(f64, f64)> = Vec::new();
    let mut g = vec![beta];
    for j in 0..steps {
        let z = precondition(&basis[j]);
        let mut w = matrix(&z);
        directions.push(z);
        let mut column = Vec::with_capacity(j + 2);
        for v in &basis {
            let c = dot(&w, v);
            axpy(&mut w, -c, v);
            column.push(c);
        }
        let next = norm(&w);
        column.push(next);
        for (i, &(c, s)) in rotations.iter().enumerate() {
            let (a, b) = (column[i], column[i + 1]);
            column[i] = c * a + s * b;
            column[i + 1] = -s * a + c * b;
        }
        let (c, s) = givens(column[j], column[j + 1]);
        column[j] = c * column[j] + s * column[j + 1];
        column.truncate(j + 1);
        rotations.push((c, s));
        g.push(-s * g[j]);
        g[j] *= c;
        h.push(column);
        // A zero (or non-finite) next direction ends the cycle: the space is exhausted.
        let exhausted = next.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater);
        let done = g[j + 1].abs() <= tolerance || exhausted || !next.is_finite();
        if done {
            break;
        }
        basis.push(scaled(w, 1.0 / next));
    }
    let coefficients = back_substitute(&h, &g[..h.len()]);
    if coefficients.iter().any(|y| !y.is_finite()) {
        return Cycle { directions: Vec::new(), coefficients: Vec::new() };
    }
    Cycle { directions, coefficients }
}

/// The rotation `(c, s)` that takes `(a, b)` to `(hypot(a, b), 0)`.
fn givens(a: f64, b: f64) -> (f64, f64) {
    let r = a.hypot(b);
    if r == 0.0 { (1.0, 0.0) } else { (a / r, b / r) }
}

/// Solves the upper triangular system whose columns are `h` for the right-hand side `g`.
fn back_substitute(h: &[Vec<f64>], g: &[f64]) -> Vec<f64> {
    let k = h.len();
    let mut y = vec![0.0; k];
    for i in (0..k).rev() {
        let s: f64 = (i + 1..k).map(|j| h[j][i] * y[j]).sum();
        y[i] = (g[i] - s) / h[i][i];
    }
    y
}

fn residual(matrix: &impl Fn(&[f64]) -> Vec<f64>, b: &[f64], x: &[f64]) -> Vec<f64> {
    let ax = matrix(x);
    b.iter().zip(&ax).map(|(b, a)| b - a).collect()
}

fn scaled(mut v: Vec<f64>, s: f64) -> Vec<f64> {
    v.iter_mut().for_each(|x| *x *= s);
    v
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

fn norm(v: &[f64]) -> f64 {
    dot(v, v).sqrt()
}

fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nonsymmetric, diagonally dominant system is solved to the tolerance, with and without a
    /// (Jacobi) preconditioner, across restarts.
    #[test]
    fn solves_a_nonsymmetric_system_across_restarts() {
        let n = 60;
        let a = |i: usize, j: usize| -> f64 {
            if i == j {
                4.0 + i as f64 * 0.1
            } else if j == i + 1 {
                1.5
            } else if i == j + 2 {
                -0.7
            } else {
                0.0
            }
        };
        let matrix = |v: &[f64]| -> Vec<f64> {
            (0..n).map(|i| (0..n).map(|j| a(i, j) * v[j]).sum()).collect()
        };
        let expected: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let b = matrix(&expected);
        let limits = Limits { tolerance: 1e-10, restart: 7, max_iterations: 500 };
        for jacobi in [false, true] {
            let precondition = |v: &[f64]| -> Vec<f64> {
                v.iter().enumerate().map(|(i, x)| if jacobi { x / a(i, i) } else { *x }).collect()
            };
            let out = fgmres(matrix, precondition, &b, vec![0.0; n], limits);
            assert!(out.converged, "{out:?}");
            assert!(out.residual <= 1e-10);
            let error = out.x.iter().zip(&expected).map(|(x, e)| (x - e).abs()).fold(0.0, f64::max);
            assert!(error < 1e-9, "error {error}");
        }
    }

    /// A start that already solves the system costs one product and no iteration.
    #[test]
    fn an_exact_start_is_returned_at_once() {
        let matrix = |v: &[f64]| v.iter().map(|x| 2.0 * x).collect::<Vec<_>>();
        let limits = Limits { tolerance: 1e-12, restart: 5, max_iterations: 10 };
        let out = fgmres(matrix, |v| v.to_vec(), &[2.0, 4.0], vec![1.0, 2.0], limits);
        assert!(out.converged);
        assert_eq!(out.products, 1);
        assert_eq!(out.x, vec![1.0, 2.0]);
    }
}
