//! The interpolation solve of paper 3.1 for large systems: FGMRES ([`super::gmres`])
//! preconditioned by two-level domain decomposition ([`super::schwarz`]), as FastRBF (Carr et
//! al., SIGGRAPH 2001) fits its hundreds of thousands of centres.
//!
//! The dense solve ([`super::solve`]) costs `O(n^3)` time and `O(n^2)` memory: 3.2 GB for the
//! matrix alone at 20,000 constraints. Here the matrix is never formed: a product with it is the
//! radial sum at every centre by the vectorized loops of evaluation, `O(n^2)` time and `O(n)`
//! memory, and the preconditioner's factorizations take `O(n)` memory (leaves of a few hundred
//! centres and a coarse problem of at most a few thousand).
//!
//! The iteration stops once the residual's Euclidean norm, and so its largest entry, is at
//! most [`TOLERANCE`] times the largest `|h_i|`, or earlier where rounding stops its progress
//! (nearly coincident centres make the weights, and the rounding of the products, large). The
//! outcome reports the residual reached and the products it took; the front door
//! ([`super::solve`]) decides whether that residual is a solution and measures the residual by
//! evaluation as for the dense solve.
//!
//! A fit adds constraints to those of its last model; that model's weights (zero for the new
//! constraints) start the iteration ([`warm_start`]), so only the new constraints' residuals
//! are left to remove.

use super::gmres::{self, Limits, Outcome};
use super::kernel::{self, Kernel};
use super::schwarz::{Schwarz, Settings};
use super::{Constraint, Implicit, Normalization};

/// The iteration stops once the residual is at most this fraction of the largest `|h_i|`.
pub(super) const TOLERANCE: f64 = 1e-8;

/// Krylov directions kept before a restart.
const RESTART: usize = 60;

/// The most preconditioned products before the solve gives up.
const MAX_ITERATIONS: usize = 400;

/// The weights and polynomial for the normalized `centres` and `values`, from `start` (or zero),
/// with the decomposition `settings`, as far as the iteration got; `None` if a local problem
/// of the preconditioner is singular.
pub(super) fn solve(
    dim: usize,
    kernel: Kernel,
    centres: &[f64],
    values: &[f64],
    start: Option<Vec<f64>>,
    settings: &Settings,
) -> Option<Outcome> {
    let n = values.len();
    let terms = dim + 1;
    let schwarz = Schwarz::new(dim, kernel, centres, settings)?;
    let matrix = |x: &[f64]| product(dim, kernel, centres, x);
    let precondition = |r: &[f64]| schwarz.apply(centres, &r[..n]);
    let mut b = values.to_vec();
    b.resize(n + terms, 0.0);
    let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let limits =
        Limits { tolerance: TOLERANCE * largest, restart: RESTART, max_iterations: MAX_ITERATIONS };
    let x0 = start.unwrap_or_else(|| vec![0.0; n + terms]);
    Some(gmres::fgmres(matrix, precondition, &b, x0, limits))
}

/// The product of the interpolation matrix with `x = (d, p)`: `(Phi d + Q p, Q^T d)`.
fn product(dim: usize, kernel: Kernel, centres: &[f64], x: &[f64]) -> Vec<f64> {
    let n = centres.len() / dim;
    let (d, p) = x.split_at(n);
    let mut y = kernel::radial_sums(dim, kernel, centres, d, centres);
    for (j, y) in y.iter_mut().enumerate() {
        *y += p[0] + (0..dim).map(|a| p[1 + a] * centres[a * n + j]).sum::<f64>();
    }
    y.push(d.iter().sum());
    for a in 0..dim {
        y.push(d.iter().zip(&centres[a * n..(a + 1) * n]).map(|(d, c)| d * c).sum());
    }
    y
}

/// The solution of `previous` as a start for `constraints` under `normalization`: its weights
/// for the constraints it shares (`constraints` must begin with its constraints, else `None`),
/// zero for the rest, and its polynomial, all rewritten for the new normalization so that they
/// describe the same function.
///
/// With `a = s_new / s_old` and `b = (m_new - m_old) / s_old`, old normalized coordinates are
/// `a x + b` in the new ones and `phi(a r) = a^k phi(r)` (`k` 2, 3 or 1), plus
/// `a^2 log(a) r^2` for `r^2 log r`, whose sum over the weights reduces to the constant
/// `a^2 log(a) sum_j d_j |c_j|^2` under the side conditions (see the [module doc](super)).
pub(super) fn warm_start(
    previous: &Implicit,
    constraints: &[Constraint],
    normalization: &Normalization,
    centres: &[f64],
) -> Option<Vec<f64>> {
    let dim = previous.dim;
    let shared = previous.len();
    if shared > constraints.len() || previous.constraints[..] != constraints[..shared] {
        return None;
    }
    let old = &previous.normalization;
    let a = normalization.scale / old.scale;
    let b: Vec<f64> =
        (0..dim).map(|k| (normalization.translate[k] - old.translate[k]) / old.scale).collect();
    let power = match previous.kernel {
        Kernel::ThinPlate => 2,
        Kernel::Cubic => 3,
        Kernel::Linear => 1,
    };
    let factor = a.powi(power);
    let n = constraints.len();
    let mut x: Vec<f64> = previous.weights.iter().map(|d| d * factor).collect();
    x.resize(n, 0.0);
    let p = &previous.polynomial;
    let mut constant = p[0] + (0..dim).map(|k| p[1 + k] * b[k]).sum::<f64>();
    if previous.kernel == Kernel::ThinPlate {
        let squares: f64 = (0..shared)
            .map(|j| {
                let r2: f64 = (0..dim).map(|k| centres[k * n + j].powi(2)).sum();
                previous.weights[j] * r2
            })
            .sum();
        constant += a * a * a.ln() * squares;
    }
    x.push(constant);
    x.extend((0..dim).map(|k| a * p[1 + k]));
    Some(x)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::rbf::read_constraints;

    fn bunny() -> Vec<Constraint> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bunny_constraints.csv");
        read_constraints(&path).unwrap().1
    }

    /// Small leaves, so that even a few hundred constraints make many local problems.
    const SMALL: Settings =
        Settings { leaf: 64, overlap: 0.5, coarse_fraction: 0.125, coarse_max: 3000 };

    fn iterative(constraints: &[Constraint], kernel: Kernel, start: Option<&Implicit>) -> Implicit {
        Implicit::solve_with(3, kernel, constraints, start, &SMALL, 0).unwrap()
    }

    /// The largest difference between two functions at their constraints and at points around
    /// them, relative to the largest |value|.
    fn difference(a: &Implicit, b: &Implicit) -> f64 {
        let mut points: Vec<[f64; 3]> = Vec::new();
        for (k, c) in a.constraints().iter().enumerate() {
            let p = c.position();
            points.push([p[0], p[1], p[2]]);
            let shift = 0.01 * ((k % 7) as f64 - 3.0);
            points.push([p[0] + shift, p[1] - shift, p[2] + 0.5 * shift]);
        }
        let (va, vb) = (a.values3(&points), b.values3(&points));
        let largest = (a.constraints().iter().chain(b.constraints()))
            .map(|c| c.value().abs())
            .fold(0.0, f64::max);
        va.iter().zip(&vb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / largest
    }

    /// The iterative solve finds the dense solve's function, for every kernel.
    #[test]
    fn agrees_with_the_dense_solve() {
        let constraints = bunny();
        for kernel in [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear] {
            let dense = Implicit::solve(3, kernel, &constraints).unwrap();
            let fast = iterative(&constraints, kernel, None);
            assert!(fast.residual() <= 10.0 * TOLERANCE, "{kernel}: {}", fast.residual());
            let d = difference(&dense, &fast);
            assert!(d < 1e-6, "{kernel}: relative difference {d:e}");
        }
    }

    /// `n` constraints on a bumpy sphere, as a fit places them: half on the surface, a quarter
    /// 0.05 inside (value 0.05) and a quarter 0.05 outside (value -0.05), along the radius.
    fn bumpy_sphere(n: usize) -> Vec<Constraint> {
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let (ring, azimuth) = ((1.0 - z * z).sqrt(), i as f64 * 2.399_963_229_728_653);
                let (x, y) = (ring * azimuth.cos(), ring * azimuth.sin());
                let radius = 1.0 + 0.15 * (3.0 * x).sin() * (2.0 * y).cos() + 0.1 * (4.0 * z).cos();
                let (offset, value) = match i % 4 {
                    0 | 2 => (0.0, 0.0),
                    1 => (-0.05, 0.05),
                    _ => (0.05, -0.05),
                };
                let r = radius + offset;
                Constraint::new(&[r * x, r * y, r * z], value)
            })
            .collect()
    }

    /// The most products a cold solve of [`bumpy_sphere`]'s 3,000 constraints may take with the
    /// default decomposition: about twice what it takes.
    const COLD_PRODUCTS: usize = 20;

    /// The preconditioner does its job: a cold solve of a few thousand constraints converges in
    /// few products. Without it (the identity in its place) FGMRES stalls or needs hundreds.
    #[test]
    fn the_schwarz_preconditioner_makes_a_cold_solve_short() {
        let constraints = bumpy_sphere(3000);
        let normalization = Normalization { translate: vec![0.0; 3], scale: 2.5 };
        let n = constraints.len();
        let model = Implicit::from_parts(
            "test",
            3,
            Kernel::ThinPlate,
            constraints.clone(),
            normalization,
            vec![0.0; n],
            vec![0.0; 4],
            0.0,
        )
        .unwrap();
        let values: Vec<f64> = constraints.iter().map(|c| c.value()).collect();
        let settings = Settings::default();
        let outcome =
            solve(3, Kernel::ThinPlate, &model.centres, &values, None, &settings).unwrap();
        assert!(outcome.converged, "residual {:e}", outcome.residual);
        assert!(outcome.products <= COLD_PRODUCTS, "{} products", outcome.products);
    }

    /// Started from the model of its first constraints, the solve needs fewer products and finds
    /// the same function.
    #[test]
    fn a_warm_start_saves_iterations() {
        let constraints = bunny();
        let first = iterative(&constraints[..600], Kernel::ThinPlate, None);
        let cold = iterative(&constraints, Kernel::ThinPlate, None);
        let warm = iterative(&constraints, Kernel::ThinPlate, Some(&first));
        assert!(difference(&cold, &warm) < 1e-6);
        let products = |start: Option<&Implicit>| {
            let norm = cold.normalization().clone();
            let x0 = start.and_then(|s| warm_start(s, &constraints, &norm, &cold.centres));
            assert_eq!(x0.is_some(), start.is_some());
            let values: Vec<f64> = constraints.iter().map(|c| c.value()).collect();
            solve(3, Kernel::ThinPlate, &cold.centres, &values, x0, &SMALL).unwrap().products
        };
        let (cold_products, warm_products) = (products(None), products(Some(&first)));
        assert!(warm_products < cold_products, "{warm_products} >= {cold_products}");
    }

    /// The start describes the previous function exactly, in the new normalization.
    #[test]
    fn the_warm_start_is_the_previous_function() {
        let constraints = bunny();
        for kernel in [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear] {
            let first = Implicit::solve(3, kernel, &constraints[..400]).unwrap();
            let all = Implicit::solve(3, kernel, &constraints).unwrap();
            let x = warm_start(&first, &constraints, all.normalization(), &all.centres).unwrap();
            let n = constraints.len();
            let moved = Implicit { weights: x[..n].to_vec(), polynomial: x[n..].to_vec(), ..all };
            let d = difference(&first, &moved);
            assert!(d < 1e-9, "{kernel}: {d:e}");
        }
        let first = Implicit::solve(3, Kernel::ThinPlate, &constraints[1..300]).unwrap();
        let all = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
        assert!(warm_start(&first, &constraints, all.normalization(), &all.centres).is_none());
    }

    /// Local problems on flat patches (here most centres lie in one plane) use the polynomials
    /// on their own span, and the solve still finds the dense solve's function.
    #[test]
    fn flat_patches_are_solved() {
        let mut constraints = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let (x, y) = (i as f64 * 0.05, j as f64 * 0.05);
                constraints.push(Constraint::new(&[x, y, 0.0], 0.0));
            }
        }
        for k in 0..40 {
            let (x, y) = ((k % 7) as f64 * 0.13 + 0.02, (k / 7) as f64 * 0.15 + 0.03);
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            constraints.push(Constraint::new(&[x, y, 0.1 * side], 0.1 * side));
        }
        let dense = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
        let fast = iterative(&constraints, Kernel::ThinPlate, None);
        let d = difference(&dense, &fast);
        assert!(d < 1e-6, "relative difference {d:e}");
    }

    /// Nearly coincident centres (a millionth of the extent apart) make the weights large and
    /// set a floor on the residual above the tolerance; the solve stops there and is accepted,
    /// agreeing with the dense solve.
    #[test]
    fn nearly_coincident_centres_are_solved_to_the_rounding_floor() {
        let mut constraints = bunny();
        let twins: Vec<Constraint> = constraints[..700]
            .iter()
            .step_by(35)
            .map(|c| {
                let p = c.position();
                Constraint::new(&[p[0] + 2e-7, p[1], p[2] - 1e-7], c.value())
            })
            .collect();
        constraints.extend(twins);
        let dense = Implicit::solve(3, Kernel::ThinPlate, &constraints).unwrap();
        let fast = iterative(&constraints, Kernel::ThinPlate, None);
        let d = difference(&dense, &fast);
        assert!(d < 1e-5, "relative difference {d:e}");
    }
}
