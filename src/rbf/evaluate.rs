//! Evaluation of a solved function at points, in batches: vectorized, parallel, f64.
//!
//! ## Why f64 lanes
//! The sum `sum_j d_j phi(|x - c_j|)` cancels heavily (the side conditions make the weights sum
//! to zero, and the far-field growth of `r^2 log r` cancels against the polynomial), so the terms
//! are orders of magnitude larger than the result. f32 would leave an error near
//! `1e-7 * sum_j |d_j phi_j|`, far above the `1e-6` relative agreement with exact evaluation that
//! the peer comparison and the model's users need; f64 keeps it near `1e-15` of that sum.
//! The fit's volume passes need less: each voxel's sign and the surface's position to a small
//! fraction of a voxel. For them [`values_f32`] runs the thin-plate sum in f32 on AVX-512 (16
//! lanes a vector, 2.6x the f64 loop) and on AVX2 ([`thin_plate_avx2`], 8 lanes a vector);
//! on a 768-constraint bunny model that is at most 0.005 voxels off, and a test holds every
//! iteration of a triceratops fit within 0.01 voxels.
//!
//! ## How it is fast
//! * Centres are stored one axis after another (SoA) in normalized coordinates.
//! * Points go in blocks of [`LANES`]; for each centre the block's distances and kernel values
//!   are computed lane by lane in straight-line f64 code that the compiler turns into vector
//!   instructions, and accumulated per lane (no horizontal sums).
//! * `r^2 log r = 0.5 r^2 ln(r^2)` needs no square root; the logarithm is the classic
//!   fdlibm/musl `log`'s reduction and series (exponent split, one division and a degree-14 odd
//!   series) without fdlibm's extra-precision correction terms, written without branches or
//!   table lookups so that it vectorizes: within 3 ulps of std's `f64::ln` (a test holds it).
//! * On AVX-512, `r^2 log r` has a loop of its own written with intrinsics
//!   ([`thin_plate_avx512`]): a table-driven logarithm without the division, a third fewer
//!   vector operations per pair, 1.5x the speed of the auto-vectorized loop.
//! * The loops are compiled for AVX-512, for AVX2 with FMA, and for the baseline target, and the
//!   best the CPU supports is picked at run time (the default target has no AVX2).
//! * Blocks of points are spread over threads with rayon.

use rayon::prelude::*;

use super::isa::{Isa, IsaLevel};
use super::{Implicit, Kernel, treecode};

#[cfg(target_arch = "x86_64")]
mod thin_plate_avx2;
#[cfg(target_arch = "x86_64")]
mod thin_plate_avx512;

/// Points evaluated together against each centre: two AVX-512 vectors, four AVX2 ones (more
/// independent work per centre than one vector; 32 spills registers).
pub const LANES: usize = 16;

/// Points per parallel task.
const CHUNK: usize = 512;

/// Multiply-add: fused where the CPU has FMA, separate otherwise (a libm call per operation
/// would be slower than both).
pub(super) trait Arith {
    fn mul_add(a: f64, b: f64, c: f64) -> f64;
}

struct Fused;
impl Arith for Fused {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

#[allow(dead_code)] // Used on targets and CPUs without FMA.
struct Separate;
impl Arith for Separate {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

/// A kernel as a function of `r^2`, for the vectorized loops, up to a constant factor that
/// the weights take.
pub(super) trait Phi {
    /// `phi(r) = WEIGHT_SCALE * phi(r2)`.
    const WEIGHT_SCALE: f64 = 1.0;
    /// Whether this is `r^2 log r`, which has its own AVX-512 loop.
    const THIN_PLATE: bool = false;
    fn phi<A: Arith>(r2: f64) -> f64;
}

struct ThinPlate;
impl Phi for ThinPlate {
    const THIN_PLATE: bool = true;
    #[inline(always)]
    fn phi<A: Arith>(r2: f64) -> f64 {
        // ln(0) is -inf; clamping to the smallest normal gives 0 * -708 = 0 instead of NaN.
        let x = if r2 < f64::MIN_POSITIVE { f64::MIN_POSITIVE } else { r2 };
        0.5 * r2 * ln::<A>(x)
    }
}

struct Cubic;
impl Phi for Cubic {
    #[inline(always)]
    fn phi<A: Arith>(r2: f64) -> f64 {
        r2 * r2.sqrt()
    }
}

struct Linear;
impl Phi for Linear {
    #[inline(always)]
    fn phi<A: Arith>(r2: f64) -> f64 {
        r2.sqrt()
    }
}

/// Natural logarithm of a positive normal `x`, branch-free: `x = 2^k m` with `m` in
/// `[sqrt(2)/2, sqrt(2))`, `s = (m - 1) / (m + 1)` and `ln m = 2 atanh s = s Q(s^2)`, with `Q`
/// fdlibm's minimax series (`Q(z) = 2 + z (Lg1 + z (Lg2 + ...))`, `|s| < 0.172`). Within
/// 3 ulps of std's `f64::ln`, with and without fused multiply-adds (the largest errors are
/// near 1, where the result is small), with one division and no table, so that it vectorizes.
#[inline(always)]
fn ln<A: Arith>(x: f64) -> f64 {
    const LN2: f64 = std::f64::consts::LN_2;
    // fdlibm's published digits.
    #[allow(clippy::excessive_precision)]
    const LG: [f64; 7] = [
        6.666_666_666_666_735_130e-01,
        3.999_999_999_940_941_908e-01,
        2.857_142_874_366_239_149e-01,
        2.222_219_843_214_978_396e-01,
        1.818_357_216_161_805_012e-01,
        1.531_383_769_920_937_332e-01,
        1.479_819_860_511_658_591e-01,
    ];
    // High word of sqrt(2)/2: shifting by it puts the mantissa split at sqrt(2).
    const SPLIT: u64 = 0x3fe6_a09e_0000_0000;
    const TWO52: f64 = 4_503_599_627_370_496.0;
    let u = x.to_bits().wrapping_add(0x3ff0_0000_0000_0000 - SPLIT);
    // The unbiased exponent as an f64, exactly, without an integer conversion.
    let k = f64::from_bits((u >> 52) | TWO52.to_bits()) - (TWO52 + 1023.0);
    let m = f64::from_bits((u & 0x000f_ffff_ffff_ffff) + SPLIT);
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let mut q = LG[6];
    for &c in LG[..6].iter().rev() {
        q = A::mul_add(q, z, c);
    }
    q = A::mul_add(q, z, 2.0);
    A::mul_add(s, q, k * LN2)
}

/// The centres and weights a block loop reads.
pub(super) struct Centres<'a> {
    /// `centres[a * n + j]`.
    pub(super) centres: &'a [f64],
    pub(super) weights: &'a [f64],
}

/// The radial part `sum_j d_j phi(|x - c_j|)` for one block of points given per axis.
#[inline(always)]
fn block<const D: usize, K: Phi, A: Arith>(c: &Centres, x: &[[f64; LANES]; D]) -> [f64; LANES] {
    let n = c.weights.len();
    let axes: [&[f64]; D] = std::array::from_fn(|a| &c.centres[a * n..(a + 1) * n]);
    let mut acc = [0.0; LANES];
    for (j, &d) in c.weights.iter().enumerate() {
        let mut r2 = [0.0; LANES];
        for a in 0..D {
            let ca = axes[a][j];
            for l in 0..LANES {
                let t = x[a][l] - ca;
                r2[l] = A::mul_add(t, t, r2[l]);
            }
        }
        for l in 0..LANES {
            acc[l] = A::mul_add(d, K::phi::<A>(r2[l]), acc[l]);
        }
    }
    acc
}

/// Evaluates the radial part at `points` (normalized, per axis, a multiple of [`LANES`] long)
/// into `out`.
#[inline(always)]
fn run<const D: usize, K: Phi, A: Arith>(c: &Centres, points: &[Vec<f64>; D], out: &mut [f64]) {
    for (b, o) in out.chunks_mut(LANES).enumerate() {
        let x: [[f64; LANES]; D] = std::array::from_fn(|a| {
            points[a][b * LANES..(b + 1) * LANES].try_into().expect("whole blocks")
        });
        let v = block::<D, K, A>(c, &x);
        o.copy_from_slice(&v[..o.len()]);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
fn run_avx512<const D: usize, K: Phi>(c: &Centres, points: &[Vec<f64>; D], out: &mut [f64]) {
    run::<D, K, Fused>(c, points, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn run_avx2<const D: usize, K: Phi>(c: &Centres, points: &[Vec<f64>; D], out: &mut [f64]) {
    run::<D, K, Fused>(c, points, out)
}

pub(super) fn dispatch<const D: usize, K: Phi>(
    isa: Isa,
    c: &Centres,
    points: &[Vec<f64>; D],
    out: &mut [f64],
) {
    match isa.level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: an `Isa` of this level exists only where the CPU reported every feature
        // these loops enable (`IsaLevel::features`; `thin_plate_avx512` enables a subset).
        IsaLevel::Avx512 => unsafe {
            if K::THIN_PLATE {
                thin_plate_avx512::run::<D>(c, points, out)
            } else {
                run_avx512::<D, K>(c, points, out)
            }
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, for AVX2 and FMA.
        IsaLevel::Avx2 => unsafe { run_avx2::<D, K>(c, points, out) },
        _ => baseline::<D, K>(c, points, out),
    }
}

#[cfg(target_feature = "fma")]
fn baseline<const D: usize, K: Phi>(c: &Centres, points: &[Vec<f64>; D], out: &mut [f64]) {
    run::<D, K, Fused>(c, points, out)
}

#[cfg(not(target_feature = "fma"))]
fn baseline<const D: usize, K: Phi>(c: &Centres, points: &[Vec<f64>; D], out: &mut [f64]) {
    run::<D, K, Separate>(c, points, out)
}

/// How the radial sum is taken.
#[derive(Debug, Clone, Copy)]
pub(super) enum Summation {
    /// The treecode where it pays ([`treecode::pays`]), the direct sum elsewhere.
    Auto,
    /// The exact sum over every centre.
    Direct,
    /// The treecode with these parameters for three-dimensional functions, the direct sum for
    /// the others.
    #[cfg(test)]
    Treecode(treecode::Params),
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
    let p = &point;
    match (implicit.dim, implicit.kernel) {
        (2, Kernel::ThinPlate) => values_dim::<2, ThinPlate>(isa, sum, implicit, count, p),
        (2, Kernel::Cubic) => values_dim::<2, Cubic>(isa, sum, implicit, count, p),
        (2, Kernel::Linear) => values_dim::<2, Linear>(isa, sum, implicit, count, p),
        (3, Kernel::ThinPlate) => values_dim::<3, ThinPlate>(isa, sum, implicit, count, p),
        (3, Kernel::Cubic) => values_dim::<3, Cubic>(isa, sum, implicit, count, p),
        (3, Kernel::Linear) => values_dim::<3, Linear>(isa, sum, implicit, count, p),
        (_, Kernel::ThinPlate) => values_dim::<4, ThinPlate>(isa, sum, implicit, count, p),
        (_, Kernel::Cubic) => values_dim::<4, Cubic>(isa, sum, implicit, count, p),
        (_, Kernel::Linear) => values_dim::<4, Linear>(isa, sum, implicit, count, p),
    }
}

fn values_dim<const D: usize, K: Phi>(
    isa: Isa,
    sum: Summation,
    implicit: &Implicit,
    count: usize,
    point: &(impl Fn(usize, &mut [f64]) + Sync),
) -> Vec<f64> {
    let weights: Vec<f64> = implicit.weights.iter().map(|d| d * K::WEIGHT_SCALE).collect();
    let params = match sum {
        Summation::Auto => treecode::pays(implicit.len(), count).then_some(treecode::PARAMS),
        Summation::Direct => None,
        #[cfg(test)]
        Summation::Treecode(params) => Some(params),
    };
    if let Some(params) = params.filter(|_| D == 3)
        && let Some(values) = by_treecode::<K>(isa, &params, implicit, &weights, count, point)
    {
        return values;
    }
    let centres = Centres { centres: &implicit.centres, weights: &weights };
    in_chunks::<D, f64>(
        implicit,
        count,
        point,
        LANES,
        |x| x,
        |points, sums| dispatch::<D, K>(isa, &centres, points, sums),
    )
}

/// [`values`] of a three-dimensional function, with the radial part summed by the treecode:
/// every point normalized at once, the polynomial added in f64. `None` when a coordinate is
/// not finite (the direct sum confines such a point's NaN to its own value).
fn by_treecode<K: Phi>(
    isa: Isa,
    params: &treecode::Params,
    implicit: &Implicit,
    weights: &[f64],
    count: usize,
    point: &(impl Fn(usize, &mut [f64]) + Sync),
) -> Option<Vec<f64>> {
    let normalized: Vec<[f64; 3]> = (0..count)
        .into_par_iter()
        .map(|i| {
            let (mut raw, mut x) = ([0.0; 3], [0.0; 3]);
            point(i, &mut raw);
            implicit.normalization.apply(&raw, &mut x);
            x
        })
        .collect();
    if !normalized.par_iter().all(|x| x.iter().all(|v| v.is_finite())) {
        return None;
    }
    let axes: [Vec<f64>; 3] =
        std::array::from_fn(|a| normalized.par_iter().map(|x| x[a]).collect());
    let poly = &implicit.polynomial;
    let mut out: Vec<f64> = normalized
        .par_iter()
        .map(|x| poly[0] + poly[1] * x[0] + poly[2] * x[1] + poly[3] * x[2])
        .collect();
    let points = std::array::from_fn(|a| axes[a].as_slice());
    treecode::radial::<K>(isa, params, &implicit.centres, weights, points, &mut out);
    Some(out)
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

/// [`values`] with the radial sum in f32 where that is faster: the thin-plate kernel on
/// AVX-512 (16 lanes a vector instead of 8) and on AVX2 with FMA (8 instead of 4), elsewhere
/// the f64 loops. The error grows to about `1e-7 sum_j |d_j phi_j|` (see the module doc): for
/// the fit's volume passes, which need only each voxel's sign and the surface's position to a
/// small fraction of a voxel.
pub(super) fn values_f32(
    implicit: &Implicit,
    count: usize,
    point: impl Fn(usize, &mut [f64]) + Sync,
) -> Vec<f64> {
    #[cfg(target_arch = "x86_64")]
    if implicit.kernel == Kernel::ThinPlate {
        let isa = Isa::selected();
        return match implicit.dim {
            2 => values_dim_f32::<2>(isa, implicit, count, &point),
            3 => values_dim_f32::<3>(isa, implicit, count, &point),
            _ => values_dim_f32::<4>(isa, implicit, count, &point),
        };
    }
    values(implicit, count, point)
}

/// [`values_f32`] by the f32 loop of `isa`'s level (the f64 loops on the baseline).
#[cfg(target_arch = "x86_64")]
fn values_dim_f32<const D: usize>(
    isa: Isa,
    implicit: &Implicit,
    count: usize,
    point: &(impl Fn(usize, &mut [f64]) + Sync),
) -> Vec<f64> {
    let centres: Vec<f32> = implicit.centres.iter().map(|&c| c as f32).collect();
    let weights: Vec<f32> = implicit.weights.iter().map(|&d| d as f32).collect();
    let (centres, weights) = (&centres, &weights);
    let narrow = |x: f64| x as f32;
    match isa.level() {
        IsaLevel::Avx512 => {
            in_chunks::<D, f32>(implicit, count, point, thin_plate_avx512::LANES_F32, narrow, {
                // SAFETY: an `Isa` of this level exists only where the CPU reported AVX-512
                // (`Isa::detect`).
                |points, sums| unsafe {
                    thin_plate_avx512::run_f32::<D>(centres, weights, points, sums)
                }
            })
        }
        IsaLevel::Avx2 => {
            in_chunks::<D, f32>(implicit, count, point, thin_plate_avx2::LANES_F32, narrow, {
                // SAFETY: as above, for AVX2 and FMA.
                |points, sums| unsafe {
                    thin_plate_avx2::run_f32::<D>(centres, weights, points, sums)
                }
            })
        }
        IsaLevel::Baseline => values(implicit, count, point),
    }
}

/// The radial sums `sum_j d_j phi(|x_i - c_j|)` of `weights` at the centres `centres` (both
/// normalized, one axis after another) for the points `points` (normalized, one axis after
/// another, `points.len() / dim` of them): the matrix-vector product of the iterative solve,
/// by the same vectorized loops as evaluation, in parallel over blocks of points.
pub(super) fn radial_sums(
    dim: usize,
    kernel: Kernel,
    centres: &[f64],
    weights: &[f64],
    points: &[f64],
) -> Vec<f64> {
    match (dim, kernel) {
        (2, Kernel::ThinPlate) => radial_sums_dim::<2, ThinPlate>(centres, weights, points),
        (2, Kernel::Cubic) => radial_sums_dim::<2, Cubic>(centres, weights, points),
        (2, Kernel::Linear) => radial_sums_dim::<2, Linear>(centres, weights, points),
        (3, Kernel::ThinPlate) => radial_sums_dim::<3, ThinPlate>(centres, weights, points),
        (3, Kernel::Cubic) => radial_sums_dim::<3, Cubic>(centres, weights, points),
        (3, Kernel::Linear) => radial_sums_dim::<3, Linear>(centres, weights, points),
        (_, Kernel::ThinPlate) => radial_sums_dim::<4, ThinPlate>(centres, weights, points),
        (_, Kernel::Cubic) => radial_sums_dim::<4, Cubic>(centres, weights, points),
        (_, Kernel::Linear) => radial_sums_dim::<4, Linear>(centres, weights, points),
    }
}

fn radial_sums_dim<const D: usize, K: Phi>(
    centres: &[f64],
    weights: &[f64],
    points: &[f64],
) -> Vec<f64> {
    let isa = Isa::selected();
    let m = points.len() / D;
    let scaled: Vec<f64> = weights.iter().map(|d| d * K::WEIGHT_SCALE).collect();
    let sources = Centres { centres, weights: &scaled };
    let mut out = vec![0.0; m];
    out.par_chunks_mut(CHUNK).enumerate().for_each(|(chunk, out)| {
        let start = chunk * CHUNK;
        let padded = out.len().div_ceil(LANES) * LANES;
        let block: [Vec<f64>; D] = std::array::from_fn(|a| {
            let mut axis = points[a * m + start..a * m + start + out.len()].to_vec();
            axis.resize(padded, 0.0);
            axis
        });
        let mut sums = vec![0.0; padded];
        dispatch::<D, K>(isa, &sources, &block, &mut sums);
        out.copy_from_slice(&sums[..out.len()]);
    });
    out
}

/// Fills the kernel block of the interpolation matrix, `phi(|c_i - c_j|)` for the `n`
/// normalized `centres` (one axis after another), into the first `n` entries of each of the
/// first `n` columns of `columns` (column-major, `stride` entries a column), with the same
/// vectorized loops as evaluation: column `j` is the function of the one centre `c_j`, weighted
/// so that its values are `phi` itself, at every centre.
pub(super) fn kernel_columns(
    dim: usize,
    kernel: Kernel,
    centres: &[f64],
    columns: &mut [f64],
    stride: usize,
) {
    match (dim, kernel) {
        (2, Kernel::ThinPlate) => kernel_columns_dim::<2, ThinPlate>(centres, columns, stride),
        (2, Kernel::Cubic) => kernel_columns_dim::<2, Cubic>(centres, columns, stride),
        (2, Kernel::Linear) => kernel_columns_dim::<2, Linear>(centres, columns, stride),
        (3, Kernel::ThinPlate) => kernel_columns_dim::<3, ThinPlate>(centres, columns, stride),
        (3, Kernel::Cubic) => kernel_columns_dim::<3, Cubic>(centres, columns, stride),
        (3, Kernel::Linear) => kernel_columns_dim::<3, Linear>(centres, columns, stride),
        (_, Kernel::ThinPlate) => kernel_columns_dim::<4, ThinPlate>(centres, columns, stride),
        (_, Kernel::Cubic) => kernel_columns_dim::<4, Cubic>(centres, columns, stride),
        (_, Kernel::Linear) => kernel_columns_dim::<4, Linear>(centres, columns, stride),
    }
}

fn kernel_columns_dim<const D: usize, K: Phi>(centres: &[f64], columns: &mut [f64], stride: usize) {
    let isa = Isa::selected();
    let n = centres.len() / D;
    let padded = n.div_ceil(LANES) * LANES;
    let points: [Vec<f64>; D] = std::array::from_fn(|a| {
        let mut axis = centres[a * n..(a + 1) * n].to_vec();
        axis.resize(padded, 0.0);
        axis
    });
    let weight = [K::WEIGHT_SCALE];
    columns.par_chunks_mut(stride).take(n).enumerate().for_each(|(j, col)| {
        let centre: [f64; D] = std::array::from_fn(|a| centres[a * n + j]);
        let one = Centres { centres: &centre, weights: &weight };
        let mut out = vec![0.0; padded];
        dispatch::<D, K>(isa, &one, &points, &mut out);
        col[..n].copy_from_slice(&out[..n]);
    });
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

    /// The largest error of [`ln`] against std's `f64::ln`, in units in the last place, that
    /// the docs state.
    const LN_MAX_ULPS: f64 = 3.0;

    /// The distance from `got` to `want` in units in the last place of `want`.
    fn ulps(got: f64, want: f64) -> f64 {
        let ulp = f64::from_bits(want.abs().to_bits() + 1) - want.abs();
        (got - want).abs() / ulp
    }

    /// The logarithm is within [`LN_MAX_ULPS`] of std's (itself within about half an ulp) over
    /// every binade of normal numbers, both sides of the mantissa split at sqrt(2), and the
    /// neighbourhood of 1 where the result is small.
    #[test]
    fn ln_is_within_its_stated_ulps_of_std() {
        let mut xs = Vec::new();
        let mut x = f64::MIN_POSITIVE;
        let split = std::f64::consts::SQRT_2;
        while x < 1e300 {
            xs.extend([x, x * 1.1, x * split * (1.0 - 1e-12), x * split * (1.0 + 1e-12), x * 1.99]);
            x *= 3.7;
        }
        for i in 1..20_000 {
            let t = f64::from(i) / 20_000.0;
            xs.extend([1.0 + 0.45 * t, 1.0 - 0.3 * t, 1.0 + t * 1e-6, 1.0 - t * 1e-9]);
        }
        let mut worst = 0.0f64;
        for y in xs {
            let want = y.ln();
            if want == 0.0 {
                continue;
            }
            worst = worst.max(ulps(ln::<Separate>(y), want)).max(ulps(ln::<Fused>(y), want));
        }
        assert!(worst <= LN_MAX_ULPS, "{worst} ulps");
        assert_eq!(ln::<Separate>(1.0), 0.0);
    }

    #[test]
    fn thin_plate_is_zero_at_zero() {
        assert_eq!(ThinPlate::phi::<Separate>(0.0), 0.0);
        assert_eq!(Kernel::ThinPlate.phi_of_r2(0.0), 0.0);
    }
}

#[cfg(test)]
mod isa_tests {
    use super::*;
    use crate::rbf::Constraint;

    /// The loops of `level` give the same values as the scalar formula, for every kernel.
    fn agrees_with_the_scalar_formula(level: IsaLevel) {
        let isa = Isa::supported(level).unwrap_or_else(|| {
            panic!("this CPU cannot run {}: run without --ignored", level.name())
        });
        let mut constraints = Vec::new();
        for i in 0..60 {
            let t = i as f64 * 0.7;
            let p = [t.cos() * (1.0 + 0.1 * t.sin()), t.sin(), (0.3 * t).cos() * 0.8];
            constraints.push(Constraint::new(
                &p,
                if i % 3 == 0 { 0.5 } else { 0.0 } - 0.1 * (i % 2) as f64,
            ));
        }
        for kernel in [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear] {
            let implicit = Implicit::solve(3, kernel, &constraints).unwrap();
            let points: Vec<[f64; 3]> =
                (0..37).map(|i| [0.05 * i as f64 - 0.9, 0.3, -0.2 + 0.01 * i as f64]).collect();
            let scalar: Vec<f64> = points.iter().map(|p| scalar_value(&implicit, p)).collect();
            let got = values_with(isa, Summation::Direct, &implicit, points.len(), |i, out| {
                out.copy_from_slice(&points[i])
            });
            for (g, s) in got.iter().zip(&scalar) {
                assert!(
                    (g - s).abs() <= 1e-12 * (1.0 + s.abs()),
                    "{level:?} {kernel:?}: {g} vs {s}"
                );
            }
        }
    }

    #[test]
    fn the_baseline_loops_agree_with_the_scalar_formula() {
        agrees_with_the_scalar_formula(IsaLevel::Baseline);
    }

    #[test]
    #[cfg_attr(not(host_has_avx2), ignore = "this CPU has no AVX2 and FMA")]
    fn the_avx2_loops_agree_with_the_scalar_formula() {
        agrees_with_the_scalar_formula(IsaLevel::Avx2);
    }

    #[test]
    #[cfg_attr(not(host_has_avx512), ignore = "this CPU has no AVX-512")]
    fn the_avx512_loops_agree_with_the_scalar_formula() {
        agrees_with_the_scalar_formula(IsaLevel::Avx512);
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
