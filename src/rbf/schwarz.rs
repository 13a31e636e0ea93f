//! The domain decomposition preconditioner of the iterative interpolation solve: two-level
//! overlapping Schwarz, after Beatson, Light and Billings, "Fast solution of the radial basis
//! function interpolation equations: domain decomposition methods" (SIAM J. Sci. Comput. 22,
//! 2000), as FastRBF (Carr et al. 2001) uses it inside GMRES.
//!
//! The centres are split by recursive bisection into leaves of at most [`Settings::leaf`]
//! centres; each leaf takes in the nearest centres of its neighbours (the overlap, as many as
//! its own) and its interpolation problem (kernel block plus polynomial) is factored once. A
//! coarse problem on every eighth centre of each leaf carries the smooth, global part that
//! small local problems cannot see. Applying the preconditioner to a residual `r`:
//!
//! 1. every leaf solves its local problem for `r` on its own and its overlap's centres, and keeps
//!    the weights of its own centres (restricted additive Schwarz);
//! 2. those weights are projected onto the side conditions (`sum d = 0`, `sum d c = 0`);
//! 3. the coarse problem is solved for what remains of `r` at the coarse centres, and its
//!    weights and polynomial are added (multiplicative between the levels).
//!
//! Every correction satisfies the side conditions, so the Krylov iterates do too.
//!
//! A small patch of a surface is nearly flat, and a flat set of centres does not determine a
//! degree-one polynomial in space: each local problem uses the polynomials of degree one on its
//! centres' own affine span (found by a singular value decomposition), which the kernels are
//! conditionally definite on.

use faer::Mat;
use rayon::prelude::*;

use super::dense::{NullSpace, system_matrix_with};
use super::kernel::{self, Kernel};

/// The sizes of the decomposition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Settings {
    /// The most centres a leaf owns.
    pub leaf: usize,
    /// A leaf's overlap, as a fraction of the centres it owns.
    pub overlap: f64,
    /// The fraction of each leaf's centres that go to the coarse problem.
    pub coarse_fraction: f64,
    /// The most centres of the coarse problem.
    pub coarse_max: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Settings { leaf: 512, overlap: 1.0, coarse_fraction: 0.125, coarse_max: 3000 }
    }
}

/// Directions whose spread is below this fraction of the largest count as flat.
const FLAT: f64 = 1e-6;

/// The factored preconditioner for one set of centres.
pub(super) struct Schwarz {
    dim: usize,
    kernel: Kernel,
    leaves: Vec<Local>,
    coarse: Local,
    /// An orthonormal basis of the polynomial block's columns `(1, c)`, one vector per term.
    polynomials: Vec<Vec<f64>>,
}

/// One factored local problem.
struct Local {
    /// The global indices of its centres: first those it owns, then its overlap.
    indices: Vec<usize>,
    /// How many of `indices` it owns.
    owned: usize,
    basis: AffineBasis,
    factored: NullSpace,
}

impl Schwarz {
    /// Decomposes and factors the problems for the normalized `centres` (one axis after
    /// another). `None` if a local problem cannot be factored (a numerically singular
    /// arrangement).
    pub(super) fn new(
        dim: usize,
        kernel: Kernel,
        centres: &[f64],
        settings: &Settings,
    ) -> Option<Schwarz> {
        let n = centres.len() / dim;
        let position = |j: usize| -> Vec<f64> { (0..dim).map(|a| centres[a * n + j]).collect() };
        let points: Vec<Vec<f64>> = (0..n).map(position).collect();
        let owned = bisect(&points, (0..n).collect(), settings.leaf);
        let coarse_indices = coarse_centres(&owned, settings);
        let overlapped = with_overlap(&points, &owned, settings.overlap);
        let leaves: Option<Vec<Local>> = overlapped
            .into_par_iter()
            .zip(owned.par_iter())
            .map(|(indices, own)| Local::new(dim, kernel, &points, indices, own.len()))
            .collect();
        let coarse_len = coarse_indices.len();
        let coarse = Local::new(dim, kernel, &points, coarse_indices, coarse_len)?;
        Some(Schwarz {
            dim,
            kernel,
            leaves: leaves?,
            coarse,
            polynomials: polynomial_basis(&points),
        })
    }

    /// The approximate solution `(d, p)` (weights, then the `dim + 1` polynomial coefficients)
    /// of the system for the right-hand side `(r, 0)`; `centres` as given to [`Schwarz::new`].
    pub(super) fn apply(&self, centres: &[f64], r: &[f64]) -> Vec<f64> {
        let n = r.len();
        let mut z = vec![0.0; n + self.dim + 1];
        let local: Vec<(Vec<usize>, Vec<f64>)> = self
            .leaves
            .par_iter()
            .map(|leaf| {
                let (d, _) = leaf.solve(r);
                (leaf.indices[..leaf.owned].to_vec(), d[..leaf.owned].to_vec())
            })
            .collect();
        for (indices, d) in local {
            for (i, d) in indices.into_iter().zip(d) {
                z[i] = d;
            }
        }
        project_out(&mut z[..n], &self.polynomials);
        let coarse = &self.coarse;
        let at: Vec<f64> = (0..self.dim)
            .flat_map(|a| coarse.indices.iter().map(move |&i| centres[a * n + i]))
            .collect();
        let reached = kernel::radial_sums(self.dim, self.kernel, centres, &z[..n], &at);
        let remaining: Vec<f64> =
            coarse.indices.iter().zip(&reached).map(|(&i, s)| r[i] - s).collect();
        let (d, p) = coarse.solve_local(&remaining);
        for (&i, d) in coarse.indices.iter().zip(d) {
            z[i] += d;
        }
        z[n..].copy_from_slice(&coarse.basis.to_global(&p));
        z
    }
}

impl Local {
    fn new(
        dim: usize,
        kernel: Kernel,
        points: &[Vec<f64>],
        indices: Vec<usize>,
        owned: usize,
    ) -> Option<Local> {
        let local: Vec<&[f64]> = indices.iter().map(|&i| points[i].as_slice()).collect();
        let basis = AffineBasis::of(dim, &local)?;
        let m = local.len();
        let centres: Vec<f64> = (0..dim).flat_map(|a| local.iter().map(move |p| p[a])).collect();
        let terms: Vec<Vec<f64>> = local.iter().map(|p| basis.terms(p)).collect();
        let a = system_matrix_with(dim, kernel, &centres, basis.len(), |j, t| terms[j][t]);
        let factored = NullSpace::new(&a, m, basis.len(), kernel)?;
        Some(Local { indices, owned, basis, factored })
    }

    /// The local weights and local polynomial for the global right-hand side `r`.
    fn solve(&self, r: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let rhs: Vec<f64> = self.indices.iter().map(|&i| r[i]).collect();
        self.solve_local(&rhs)
    }

    /// The local weights and local polynomial for the right-hand side `rhs` at its centres.
    fn solve_local(&self, rhs: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let m = rhs.len();
        let mut full = rhs.to_vec();
        full.resize(m + self.basis.len(), 0.0);
        let mut x = self.factored.solve(&full);
        let p = x.split_off(m);
        (x, p)
    }
}

/// The polynomials of degree one on the affine span of a set of points: `1` and
/// `u_k . (x - mean) / extent` for the directions `u_k` the points spread along.
struct AffineBasis {
    mean: Vec<f64>,
    /// Unit directions, divided by the points' extent.
    directions: Vec<Vec<f64>>,
}

impl AffineBasis {
    /// The basis for `points`; `None` for fewer than two distinct points or non-finite ones.
    fn of(dim: usize, points: &[&[f64]]) -> Option<AffineBasis> {
        let m = points.len();
        let mean: Vec<f64> =
            (0..dim).map(|a| points.iter().map(|p| p[a]).sum::<f64>() / m as f64).collect();
        let x = Mat::from_fn(m, dim, |i, a| points[i][a] - mean[a]);
        let svd = x.thin_svd().ok()?;
        let s = svd.S().column_vector();
        let largest = (0..dim).map(|k| s[k]).fold(0.0, f64::max);
        if !(largest > 0.0 && largest.is_finite()) {
            return None;
        }
        let extent = (0..dim)
            .map(|a| {
                let axis = points.iter().map(|p| p[a]);
                axis.clone().fold(f64::MIN, f64::max) - axis.fold(f64::MAX, f64::min)
            })
            .fold(0.0, f64::max);
        let v = svd.V();
        let directions = (0..dim)
            .filter(|&k| s[k] > FLAT * largest)
            .map(|k| (0..dim).map(|a| v[(a, k)] / extent).collect())
            .collect();
        Some(AffineBasis { mean, directions })
    }

    /// The number of terms.
    fn len(&self) -> usize {
        1 + self.directions.len()
    }

    /// The terms at `x`.
    fn terms(&self, x: &[f64]) -> Vec<f64> {
        let mut t = vec![1.0];
        for u in &self.directions {
            t.push(u.iter().zip(x).zip(&self.mean).map(|((u, x), m)| u * (x - m)).sum());
        }
        t
    }

    /// The coefficients `p` of this basis as the global polynomial's: the constant, then one
    /// coefficient per axis.
    fn to_global(&self, p: &[f64]) -> Vec<f64> {
        let dim = self.mean.len();
        let mut global = vec![0.0; dim + 1];
        global[0] = p[0];
        for (u, &c) in self.directions.iter().zip(&p[1..]) {
            for a in 0..dim {
                global[1 + a] += c * u[a];
                global[0] -= c * u[a] * self.mean[a];
            }
        }
        global
    }
}

/// Splits `indices` at the median of the axis of largest extent until every part has at most
/// `leaf` points.
fn bisect(points: &[Vec<f64>], mut indices: Vec<usize>, leaf: usize) -> Vec<Vec<usize>> {
    if indices.len() <= leaf {
        return vec![indices];
    }
    let dim = points[indices[0]].len();
    let spread = |a: usize| {
        let axis = indices.iter().map(|&i| points[i][a]);
        axis.clone().fold(f64::MIN, f64::max) - axis.fold(f64::MAX, f64::min)
    };
    let axis = (0..dim).max_by(|&a, &b| spread(a).total_cmp(&spread(b))).unwrap_or(0);
    let half = indices.len() / 2;
    indices.select_nth_unstable_by(half, |&i, &j| points[i][axis].total_cmp(&points[j][axis]));
    let upper = indices.split_off(half);
    let mut parts = bisect(points, indices, leaf);
    parts.extend(bisect(points, upper, leaf));
    parts
}

/// Each leaf's indices followed by its overlap: the `overlap` fraction of its count nearest to
/// its bounding box among the other leaves' centres.
fn with_overlap(points: &[Vec<f64>], leaves: &[Vec<usize>], overlap: f64) -> Vec<Vec<usize>> {
    let boxes: Vec<Bounds> = leaves.iter().map(|leaf| Bounds::of(points, leaf)).collect();
    (0..leaves.len())
        .into_par_iter()
        .map(|l| {
            let wanted = (leaves[l].len() as f64 * overlap).ceil() as usize;
            let reach = boxes[l].diagonal() * 0.5;
            let mut near: Vec<(f64, usize)> = (0..leaves.len())
                .filter(|&k| k != l && boxes[k].distance_to(&boxes[l]) <= reach)
                .flat_map(|k| leaves[k].iter().map(|&i| (boxes[l].distance(&points[i]), i)))
                .collect();
            near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let mut indices = leaves[l].clone();
            indices.extend(near.into_iter().take(wanted).map(|(_, i)| i));
            indices
        })
        .collect()
}

/// Every `1 / coarse_fraction`-th centre of each leaf, fewer where that would exceed
/// `coarse_max`.
fn coarse_centres(leaves: &[Vec<usize>], settings: &Settings) -> Vec<usize> {
    let n: usize = leaves.iter().map(Vec::len).sum();
    let fraction = settings.coarse_fraction.min(settings.coarse_max as f64 / n as f64);
    let mut coarse: Vec<usize> = leaves
        .iter()
        .flat_map(|leaf| {
            let count = ((leaf.len() as f64 * fraction).ceil() as usize).clamp(1, leaf.len());
            let stride = leaf.len() as f64 / count as f64;
            (0..count).map(move |k| leaf[(k as f64 * stride) as usize])
        })
        .collect();
    coarse.sort_unstable();
    coarse
}

/// An axis-aligned box around some points.
struct Bounds {
    lo: Vec<f64>,
    hi: Vec<f64>,
}

impl Bounds {
    fn of(points: &[Vec<f64>], indices: &[usize]) -> Bounds {
        let dim = points[indices[0]].len();
        let mut b = Bounds { lo: vec![f64::MAX; dim], hi: vec![f64::MIN; dim] };
        for &i in indices {
            for ((lo, hi), &x) in b.lo.iter_mut().zip(&mut b.hi).zip(&points[i]) {
                *lo = lo.min(x);
                *hi = hi.max(x);
            }
        }
        b
    }

    fn diagonal(&self) -> f64 {
        self.lo.iter().zip(&self.hi).map(|(l, h)| (h - l).powi(2)).sum::<f64>().sqrt()
    }

    /// The distance from `x` to the box (zero inside).
    fn distance(&self, x: &[f64]) -> f64 {
        let gap = |a: usize| (self.lo[a] - x[a]).max(x[a] - self.hi[a]).max(0.0);
        (0..x.len()).map(|a| gap(a).powi(2)).sum::<f64>().sqrt()
    }

    /// The distance between two boxes (zero if they meet).
    fn distance_to(&self, other: &Bounds) -> f64 {
        let gap = |a: usize| (self.lo[a] - other.hi[a]).max(other.lo[a] - self.hi[a]).max(0.0);
        (0..self.lo.len()).map(|a| gap(a).powi(2)).sum::<f64>().sqrt()
    }
}

/// An orthonormal basis of the columns `(1, c_a)` of the polynomial block, by Gram-Schmidt
/// applied twice.
fn polynomial_basis(points: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let dim = points[0].len();
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(dim + 1);
    for t in 0..=dim {
        let mut v: Vec<f64> = points.iter().map(|p| if t == 0 { 1.0 } else { p[t - 1] }).collect();
        project_out(&mut v, &basis);
        project_out(&mut v, &basis);
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.iter_mut().for_each(|x| *x /= norm);
        basis.push(v);
    }
    basis
}

/// `d <- d - U U^T d` for the orthonormal vectors `U`.
fn project_out(d: &mut [f64], basis: &[Vec<f64>]) {
    for u in basis {
        let c: f64 = d.iter().zip(u).map(|(d, u)| d * u).sum();
        d.iter_mut().zip(u).for_each(|(d, u)| *d -= c * u);
    }
}
