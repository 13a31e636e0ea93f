//! Evaluation of a solved function at points, in batches (paper 5.2 evaluates it over the
//! whole volume at every iteration of a fit): the choice between the direct sum and the
//! treecode, the polynomial part, and the split of the points over threads. The sums
//! themselves are the loops of [`super::kernel`].
//!
//! ## Precision
//! The sum `sum_j d_j phi(|x - c_j|)` cancels heavily (the side conditions make the weights sum
//! to zero, and the far-field growth of `r^2 log r` cancels against the polynomial), so the terms
//! are orders of magnitude larger than the result. f32 would leave an error near
//! `1e-7 * sum_j |d_j phi_j|`, far above the `1e-6` relative agreement with exact evaluation that
//! the peer comparison and the model's users need; f64 keeps it near `1e-15` of that sum, and
//! [`values`], [`value_at`] and [`gradient_at`] are f64 throughout. The fit's volume passes need
//! less: each voxel's sign and the surface's position to a small fraction of a voxel. For them
//! [`values_f32`] runs the thin-plate sum in f32 (a loop of its own on every instruction set),
//! and the fit checks a model's f32 error before using it.
//!
//! ## Guarantees
//! * The direct sum ([`values_exact`]) is exact to the rounding of f64 (see the kernel loops'
//!   guarantee). [`values`] sums many points of a three-dimensional function of many centres by
//!   the treecode ([`treecode::pays`]), within `1e-5` of the value range of the direct sum.
//! * Points are normalized like the constraints, so a point equal to a constraint's position
//!   lands exactly on its centre.
//! * A point with a NaN or infinite coordinate makes its own value NaN or infinite, no other.
//! * Blocks of points are spread over threads with rayon; the values do not depend on the
//!   number of threads.

use rayon::prelude::*;

use super::isa::Isa;
use super::kernel::{self, CHUNK, Centres, LANES, Phi, Specialized, ThinPlateF32};
use super::{Implicit, Kernel, treecode};

/// How the radial sum is taken.
#[derive(Debug, Clone, Copy)]
pub(super) enum Summation {
    /// The treecode where it pays ([`treecode::pays`]), the direct sum elsewhere.
    Auto,
    /// The exact sum over every centre.
    Direct,
}

/// The values of `implicit` at `count` points, the `i`th written (in the mesh's units, `dim`
/// coordinates, into a zeroed buffer) by `point(i, buffer)`. Parallel and vectorized; many
/// points of a function of many centres go through the treecode ([`treecode`]).
pub(super) fn values(
    implicit: &Implicit,
    count: usize,
    point: impl Fn(usize, &mut [f64]) + Sync,
) -> Vec<f64> {
    values_with(Isa::selected(), Summation::Auto, implicit, count, point)
}

/// The fewest points at which [`values`] sums `implicit` by the treecode, if it ever does.
pub(super) fn fast_batch(implicit: &Implicit) -> Option<usize> {
    (implicit.dim == 3).then(|| treecode::least_points(implicit.len())).flatten()
}

/// [`values`] by the direct sum, whatever the number of centres and points.
pub(super) fn values_exact(
    implicit: &Implicit,
    count: usize,
    point: impl Fn(usize, &mut [f64]) + Sync,
) -> Vec<f64> {
    values_with(Isa::selected(), Summation::Direct, implicit, count, point)
}

/// [`values`] with the instruction set (it must be supported) and summation chosen by the
/// caller.
pub(super) fn values_with(
    isa: Isa,
    sum: Summation,
    implicit: &Implicit,
    count: usize,
    point: impl Fn(usize, &mut [f64]) + Sync,
) -> Vec<f64> {
    let work = Values { isa, sum, implicit, count, point: &point };
    kernel::specialize(implicit.dim, implicit.kernel, work)
}

/// The work of [`values_with`].
struct Values<'a, P> {
    isa: Isa,
    sum: Summation,
    implicit: &'a Implicit,
    count: usize,
    point: &'a P,
}

impl<P: Fn(usize, &mut [f64]) + Sync> Specialized for Values<'_, P> {
    type Output = Vec<f64>;

    fn run<const D: usize, K: Phi>(self) -> Vec<f64> {
        let Values { isa, sum, implicit, count, point } = self;
        let by_treecode = match sum {
            Summation::Auto => D == 3 && treecode::pays(implicit.len(), count),
            Summation::Direct => false,
        };
        if by_treecode
            && let Some(values) =
                treecode::values::<K>(isa, &treecode::PARAMS, implicit, count, point)
        {
            return values;
        }
        let centres = Centres { centres: &implicit.centres, weights: &implicit.weights };
        in_chunks::<D, f64>(
            implicit,
            count,
            point,
            LANES,
            |x| x,
            |points, sums| kernel::sum::<D, K>(isa, &centres, points, sums),
        )
    }
}

/// The values at `count` points, in parallel chunks: each chunk's normalized points go to
/// `radial` per axis (as `T`, zero-padded to a multiple of `lanes`), which writes their radial
/// sums; the polynomial is added in f64.
fn in_chunks<const D: usize, T: Copy + Default>(
    implicit: &Implicit,
    count: usize,
    point: &(impl Fn(usize, &mut [f64]) + Sync),
    lanes: usize,
    convert: impl Fn(f64) -> T + Sync,
    radial: impl Fn(&[Vec<T>; D], &mut [f64]) + Sync,
) -> Vec<f64> {
    let poly = &implicit.polynomial;
    let mut out = vec![0.0; count];
    out.par_chunks_mut(CHUNK).enumerate().for_each(|(chunk, out)| {
        let start = chunk * CHUNK;
        let padded = out.len().div_ceil(lanes) * lanes;
        let mut points: [Vec<T>; D] = std::array::from_fn(|_| vec![T::default(); padded]);
        let mut raw = [0.0; D];
        let mut x = [0.0; D];
        for i in 0..out.len() {
            raw.fill(0.0);
            point(start + i, &mut raw);
            implicit.normalization.apply(&raw, &mut x);
            let mut p = poly[0];
            for a in 0..D {
                points[a][i] = convert(x[a]);
                p += poly[a + 1] * x[a];
            }
            out[i] = p;
        }
        let mut sums = vec![0.0; out.len()];
        radial(&points, &mut sums);
        for (o, r) in out.iter_mut().zip(sums) {
            *o += r;
        }
    });
    out
}

/// [`values`] with the radial sum in f32 where that is faster: the thin-plate kernel by the f32
/// loop of the instruction set ([`ThinPlateF32`]), the other kernels by the f64 loops. The
/// error grows to about `1e-7 sum_j |d_j phi_j|` (see the module doc): for the fit's volume
/// passes, which need only each voxel's sign and the surface's position to a small fraction of
/// a voxel.
pub(super) fn values_f32(
    implicit: &Implicit,
    count: usize,
    point: impl Fn(usize, &mut [f64]) + Sync,
) -> Vec<f64> {
    if implicit.kernel == Kernel::ThinPlate {
        let work = ValuesF32 {
            f32_loop: ThinPlateF32::of(Isa::selected()),
            implicit,
            count,
            point: &point,
        };
        kernel::specialize(implicit.dim, implicit.kernel, work)
    } else {
        values(implicit, count, point)
    }
}

/// The work of [`values_f32`], for the thin-plate kernel.
struct ValuesF32<'a, P> {
    f32_loop: ThinPlateF32,
    implicit: &'a Implicit,
    count: usize,
    point: &'a P,
}

impl<P: Fn(usize, &mut [f64]) + Sync> Specialized for ValuesF32<'_, P> {
    type Output = Vec<f64>;

    fn run<const D: usize, K: Phi>(self) -> Vec<f64> {
        let ValuesF32 { f32_loop, implicit, count, point } = self;
        let centres: Vec<f32> = implicit.centres.iter().map(|&c| c as f32).collect();
        let weights: Vec<f32> = implicit.weights.iter().map(|&d| d as f32).collect();
        let (centres, weights) = (&centres, &weights);
        let lanes = f32_loop.lanes();
        in_chunks::<D, f32>(
            implicit,
            count,
            point,
            lanes,
            |x| x as f32,
            |points, sums| f32_loop.sum::<D>(centres, weights, points, sums),
        )
    }
}

/// The value at one point (missing coordinates zero), by the same code as batches.
pub(super) fn value_at(implicit: &Implicit, x: &[f64]) -> f64 {
    values_with(Isa::selected(), Summation::Direct, implicit, 1, |_, out| {
        let k = out.len().min(x.len());
        out[..k].copy_from_slice(&x[..k]);
    })[0]
}

/// The gradient at one point, by the analytic derivative of every term, in the mesh's units.
pub(super) fn gradient_at(implicit: &Implicit, x: &[f64]) -> Vec<f64> {
    let dim = implicit.dim;
    let n = implicit.len();
    let mut raw = vec![0.0; dim];
    let k = dim.min(x.len());
    raw[..k].copy_from_slice(&x[..k]);
    let mut xn = vec![0.0; dim];
    implicit.normalization.apply(&raw, &mut xn);
    // d/dx' of P, then of each radial term: d_j phi'(r)/r (x' - c'_j).
    let mut g: Vec<f64> = implicit.polynomial[1..].to_vec();
    let mut t = vec![0.0; dim];
    for (j, &d) in implicit.weights.iter().enumerate() {
        let mut r2 = 0.0;
        for a in 0..dim {
            t[a] = xn[a] - implicit.centres[a * n + j];
            r2 += t[a] * t[a];
        }
        let s = d * implicit.kernel.dphi_over_r(r2);
        for a in 0..dim {
            g[a] += s * t[a];
        }
    }
    // x' = (x - m) / s, so d/dx = (1 / s) d/dx'.
    g.iter_mut().for_each(|v| *v /= implicit.normalization.scale);
    g
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rbf::Constraint;
    use crate::rbf::isa::IsaLevel;

    /// The values by every instruction set this CPU runs, normalization and polynomial
    /// included, agree with the textbook sum, for every kernel.
    #[test]
    fn values_agree_with_the_scalar_formula_on_every_instruction_set() {
        let mut constraints = Vec::new();
        for i in 0..60 {
            let t = i as f64 * 0.7;
            let p = [t.cos() * (1.0 + 0.1 * t.sin()), t.sin(), (0.3 * t).cos() * 0.8];
            constraints.push(Constraint::new(
                &p,
                if i % 3 == 0 { 0.5 } else { 0.0 } - 0.1 * (i % 2) as f64,
            ));
        }
        let points: Vec<[f64; 3]> =
            (0..37).map(|i| [0.05 * i as f64 - 0.9, 0.3, -0.2 + 0.01 * i as f64]).collect();
        for kernel in [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear] {
            let implicit = Implicit::solve(3, kernel, &constraints).unwrap();
            let scalar: Vec<f64> = points.iter().map(|p| scalar_value(&implicit, p)).collect();
            for isa in IsaLevel::ALL.into_iter().filter_map(Isa::supported) {
                let got = values_with(isa, Summation::Direct, &implicit, points.len(), |i, out| {
                    out.copy_from_slice(&points[i])
                });
                for (g, s) in got.iter().zip(&scalar) {
                    assert!(
                        (g - s).abs() <= 1e-12 * (1.0 + s.abs()),
                        "{isa:?} {kernel:?}: {g} vs {s}"
                    );
                }
            }
        }
    }

    /// The textbook sum with std's logarithm.
    fn scalar_value(implicit: &Implicit, x: &[f64]) -> f64 {
        let n = implicit.len();
        let mut xn = [0.0; 3];
        implicit.normalization.apply(x, &mut xn);
        let mut f = implicit.polynomial[0]
            + (0..3).map(|a| implicit.polynomial[a + 1] * xn[a]).sum::<f64>();
        for j in 0..n {
            let r2: f64 = (0..3).map(|a| (xn[a] - implicit.centres[a * n + j]).powi(2)).sum();
            f += implicit.weights[j] * implicit.kernel.phi_of_r2(r2);
        }
        f
    }
}
