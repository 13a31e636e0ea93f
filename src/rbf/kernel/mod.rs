//! The radial basis functions `phi` of paper 3.1 and the loops that sum them: the layer under
//! evaluation (5.2), the treecode and both solves.
//!
//! [`Kernel`] names a kernel and gives its scalar formulas. The loops take the kernel as a type
//! ([`Phi`]) and the dimension as a const parameter, so that each pair is compiled on its own;
//! [`specialize`] is the one place where a dimension and a kernel known at run time choose the
//! compiled code. A new kernel comes in there: a variant of [`Kernel`] with its formulas, a type
//! implementing [`Phi`], and an arm of [`specialize`].
//!
//! ## The loops
//! A loop sums `sum_j d_j phi(|x - c_j|)` for a block of points (normalized coordinates, given
//! per axis) against centres stored axis by axis ([`Centres`]).
//! * The f64 loop in plain Rust ([`portable`]) sums every kernel. It is compiled for AVX-512,
//!   for AVX2 with FMA and for the target's baseline.
//! * On AVX-512, `r^2 log r` has an f64 loop of its own written with intrinsics ([`avx512`]):
//!   a table-driven logarithm without a division, a third fewer vector operations per pair.
//! * `r^2 log r` has f32 loops on AVX-512 ([`avx512`], 16 lanes a vector), on AVX2 with FMA
//!   ([`avx2`], 8 lanes a vector) and in plain Rust for the target's baseline ([`portable`]:
//!   SSE2's 4 lanes on x86-64, NEON's on aarch64), for the fit's volume passes
//!   ([`SinglePrecision`](crate::rbf::SinglePrecision)).
//!
//! [`sum`] and [`ThinPlateF32`] choose the loop of an instruction set ([`Isa`]), which only
//! exists for instruction sets the CPU runs. [`radial_sums`] and [`kernel_columns`] are the
//! solves' entry points: the product with the kernel block and the block itself.
//!
//! ## Guarantees
//! * Every f64 loop agrees with the scalar formula ([`Kernel::phi_of_r2`], std's logarithm)
//!   within `1e-14` of `sum_j |d_j phi_j|`, the size of the terms; the f32 loops, on the same
//!   inputs rounded to f32, within `1e-6` of it. A test holds both on every instruction set
//!   the CPU runs.
//! * `phi(0) = 0` for every kernel and loop, so a point on a centre gets no NaN from it.
//! * The result depends only on the centres, weights and points: every sum runs over the
//!   centres in their order, whatever the number of threads.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::isa::{Isa, IsaLevel};

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
mod portable;

use portable::Arith;

/// The radial basis function `phi(r)` of a variational implicit function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum Kernel {
    /// `phi(r) = r^2 log r`, the thin-plate spline: the paper's kernel and the default.
    #[default]
    #[serde(rename = "r2logr")]
    ThinPlate,
    /// `phi(r) = r^3`, the triharmonic spline in 3D.
    #[serde(rename = "r3")]
    Cubic,
    /// `phi(r) = r`, the biharmonic spline in 3D.
    #[serde(rename = "r")]
    Linear,
}

impl Kernel {
    /// The kernel's name in model files and on the command line: `r2logr`, `r3` or `r`.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::ThinPlate => "r2logr",
            Kernel::Cubic => "r3",
            Kernel::Linear => "r",
        }
    }

    /// The kernel named `name` (`r2logr`, `r3` or `r`).
    pub fn from_name(name: &str) -> Option<Kernel> {
        [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear].into_iter().find(|k| k.name() == name)
    }

    /// `phi(r)`, written as a function of `r^2` so that no square root is needed for
    /// `r^2 log r = 0.5 r^2 ln(r^2)`. Zero at `r = 0` for every kernel.
    #[inline]
    pub fn phi_of_r2(self, r2: f64) -> f64 {
        match self {
            Kernel::ThinPlate if r2 > 0.0 => 0.5 * r2 * r2.ln(),
            Kernel::ThinPlate => 0.0,
            Kernel::Cubic => r2 * r2.sqrt(),
            Kernel::Linear => r2.sqrt(),
        }
    }

    /// `phi'(r) / r` as a function of `r^2`: the gradient of `phi(|x - c|)` is this times
    /// `x - c`. Zero at `r = 0`, where the product with `x - c` vanishes (or, for `r`, where the
    /// gradient is undefined and zero is reported).
    #[inline]
    pub fn dphi_over_r(self, r2: f64) -> f64 {
        match self {
            Kernel::ThinPlate if r2 > 0.0 => r2.ln() + 1.0,
            Kernel::Cubic => 3.0 * r2.sqrt(),
            Kernel::Linear if r2 > 0.0 => 1.0 / r2.sqrt(),
            Kernel::ThinPlate | Kernel::Linear => 0.0,
        }
    }
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A kernel as the loops compute it: a function of `r^2`.
pub(super) trait Phi {
    /// Whether this is `r^2 log r`, which has loops of its own written with intrinsics.
    const THIN_PLATE: bool = false;
    /// `phi` at `r^2`, with the multiply-adds of `A`.
    fn phi<A: Arith>(r2: f64) -> f64;
}

/// `r^2 log r` ([`Kernel::ThinPlate`]).
pub(super) struct ThinPlate;
impl Phi for ThinPlate {
    const THIN_PLATE: bool = true;
    #[inline(always)]
    fn phi<A: Arith>(r2: f64) -> f64 {
        // ln(0) is -inf; clamping to the smallest normal gives 0 * -708 = 0 instead of NaN.
        let x = if r2 < f64::MIN_POSITIVE { f64::MIN_POSITIVE } else { r2 };
        0.5 * r2 * portable::ln::<A>(x)
    }
}

/// `r^3` ([`Kernel::Cubic`]).
pub(super) struct Cubic;
impl Phi for Cubic {
    #[inline(always)]
    fn phi<A: Arith>(r2: f64) -> f64 {
        r2 * r2.sqrt()
    }
}

/// `r` ([`Kernel::Linear`]).
pub(super) struct Linear;
impl Phi for Linear {
    #[inline(always)]
    fn phi<A: Arith>(r2: f64) -> f64 {
        r2.sqrt()
    }
}

/// Work generic over the dimension and the kernel, which [`specialize`] runs for a dimension
/// and a kernel known at run time.
pub(super) trait Specialized {
    /// What the work gives.
    type Output;
    /// The work in dimension `D` with the kernel `K`.
    fn run<const D: usize, K: Phi>(self) -> Self::Output;
}

/// Runs `work` compiled for `dim` (2, 3 or 4; any other value counts as 4) and `kernel`.
pub(super) fn specialize<W: Specialized>(dim: usize, kernel: Kernel, work: W) -> W::Output {
    match kernel {
        Kernel::ThinPlate => in_dimension::<ThinPlate, W>(dim, work),
        Kernel::Cubic => in_dimension::<Cubic, W>(dim, work),
        Kernel::Linear => in_dimension::<Linear, W>(dim, work),
    }
}

/// [`specialize`] once the kernel is chosen.
fn in_dimension<K: Phi, W: Specialized>(dim: usize, work: W) -> W::Output {
    match dim {
        2 => work.run::<2, K>(),
        3 => work.run::<3, K>(),
        _ => work.run::<4, K>(),
    }
}

/// Points evaluated together against each centre by the f64 loops: two AVX-512 vectors, four
/// AVX2 ones (more independent work per centre than one vector; 32 spills registers).
pub(super) const LANES: usize = 16;

/// Points per parallel task.
pub(super) const CHUNK: usize = 512;

/// The centres and weights a loop reads.
pub(super) struct Centres<'a> {
    /// `centres[a * n + j]`: normalized, one axis after another.
    pub(super) centres: &'a [f64],
    /// `d_j`, one per centre.
    pub(super) weights: &'a [f64],
}

/// Writes `sum_j d_j phi(|x - c_j|)` of `c` at `points` (normalized, per axis, whole blocks of
/// [`LANES`]) into `out` (as long as the points or shorter), by the f64 loop of `isa`.
pub(super) fn sum<const D: usize, K: Phi>(
    isa: Isa,
    c: &Centres,
    points: &[Vec<f64>; D],
    out: &mut [f64],
) {
    match isa.level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: an `Isa` of this level exists only where the CPU reported every feature
        // these loops enable (`IsaLevel::features`; `avx512::run` enables a subset).
        IsaLevel::Avx512 => unsafe {
            if K::THIN_PLATE {
                avx512::run::<D>(c, points, out)
            } else {
                portable::run_avx512::<D, K>(c, points, out)
            }
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, for AVX2 and FMA.
        IsaLevel::Avx2 => unsafe { portable::run_avx2::<D, K>(c, points, out) },
        _ => portable::run_baseline::<D, K>(c, points, out),
    }
}

/// The f32 loop of `r^2 log r` of an instruction set: written with intrinsics for AVX-512 and
/// for AVX2 with FMA, in plain Rust that the compiler vectorizes for the target's baseline
/// (SSE2 on x86-64, NEON on aarch64). An error near `1e-7` of `sum_j |d_j phi_j|` instead of
/// f64's `1e-15`.
#[derive(Debug, Clone, Copy)]
pub(super) struct ThinPlateF32 {
    isa: Isa,
}

impl ThinPlateF32 {
    /// The f32 loop of `isa`.
    pub(super) fn of(isa: Isa) -> ThinPlateF32 {
        ThinPlateF32 { isa }
    }

    /// The points per block of the loop.
    pub(super) fn lanes(self) -> usize {
        match self.isa.level() {
            #[cfg(target_arch = "x86_64")]
            IsaLevel::Avx512 => avx512::LANES_F32,
            #[cfg(target_arch = "x86_64")]
            IsaLevel::Avx2 => avx2::LANES_F32,
            _ => portable::LANES_F32,
        }
    }

    /// Writes the sums of `centres` (f32, one axis after another) with `weights` at `points`
    /// (per axis, whole blocks of [`ThinPlateF32::lanes`]) into `out`.
    pub(super) fn sum<const D: usize>(
        self,
        centres: &[f32],
        weights: &[f32],
        points: &[Vec<f32>; D],
        out: &mut [f64],
    ) {
        match self.isa.level() {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: an `Isa` of this level exists only where the CPU reported AVX-512.
            IsaLevel::Avx512 => unsafe { avx512::run_f32::<D>(centres, weights, points, out) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above, for AVX2 and FMA.
            IsaLevel::Avx2 => unsafe { avx2::run_f32::<D>(centres, weights, points, out) },
            _ => portable::run_f32_baseline::<D>(centres, weights, points, out),
        }
    }
}

/// The radial sums `sum_j d_j phi(|x_i - c_j|)` of `weights` at the centres `centres` (both
/// normalized, one axis after another) for the points `points` (normalized, one axis after
/// another, `points.len() / dim` of them): the product with the kernel block in the iterative
/// solve, by the loops of evaluation, in parallel over blocks of points.
pub(super) fn radial_sums(
    dim: usize,
    kernel: Kernel,
    centres: &[f64],
    weights: &[f64],
    points: &[f64],
) -> Vec<f64> {
    specialize(dim, kernel, RadialSums { centres, weights, points })
}

/// The work of [`radial_sums`].
struct RadialSums<'a> {
    centres: &'a [f64],
    weights: &'a [f64],
    points: &'a [f64],
}

impl Specialized for RadialSums<'_> {
    type Output = Vec<f64>;

    fn run<const D: usize, K: Phi>(self) -> Vec<f64> {
        let isa = Isa::selected();
        let m = self.points.len() / D;
        let sources = Centres { centres: self.centres, weights: self.weights };
        let mut out = vec![0.0; m];
        out.par_chunks_mut(CHUNK).enumerate().for_each(|(chunk, out)| {
            let start = chunk * CHUNK;
            let padded = out.len().div_ceil(LANES) * LANES;
            let block: [Vec<f64>; D] = std::array::from_fn(|a| {
                let mut axis = self.points[a * m + start..a * m + start + out.len()].to_vec();
                axis.resize(padded, 0.0);
                axis
            });
            let mut sums = vec![0.0; padded];
            sum::<D, K>(isa, &sources, &block, &mut sums);
            out.copy_from_slice(&sums[..out.len()]);
        });
        out
    }
}

/// Fills the kernel block of the interpolation matrix, `phi(|c_i - c_j|)` for the `n`
/// normalized `centres` (one axis after another), into the first `n` entries of each of the
/// first `n` columns of `columns` (column-major, `stride` entries a column), with the loops of
/// evaluation: column `j` is the sum of the one centre `c_j`, of weight 1, at every centre.
pub(super) fn kernel_columns(
    dim: usize,
    kernel: Kernel,
    centres: &[f64],
    columns: &mut [f64],
    stride: usize,
) {
    specialize(dim, kernel, KernelColumns { centres, columns, stride })
}

/// The work of [`kernel_columns`].
struct KernelColumns<'a> {
    centres: &'a [f64],
    columns: &'a mut [f64],
    stride: usize,
}

impl Specialized for KernelColumns<'_> {
    type Output = ();

    fn run<const D: usize, K: Phi>(self) {
        let isa = Isa::selected();
        let centres = self.centres;
        let n = centres.len() / D;
        let padded = n.div_ceil(LANES) * LANES;
        let points: [Vec<f64>; D] = std::array::from_fn(|a| {
            let mut axis = centres[a * n..(a + 1) * n].to_vec();
            axis.resize(padded, 0.0);
            axis
        });
        let weight = [1.0];
        self.columns.par_chunks_mut(self.stride).take(n).enumerate().for_each(|(j, col)| {
            let centre: [f64; D] = std::array::from_fn(|a| centres[a * n + j]);
            let one = Centres { centres: &centre, weights: &weight };
            let mut out = vec![0.0; padded];
            sum::<D, K>(isa, &one, &points, &mut out);
            col[..n].copy_from_slice(&out[..n]);
        });
    }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// The agreement of the f64 loops with the scalar formula that the module doc states,
    /// relative to `sum_j |d_j phi_j|`.
    const F64_TOLERANCE: f64 = 1e-14;

    /// The same for the f32 loops, on inputs rounded to f32.
    const F32_TOLERANCE: f64 = 1e-6;

    const KERNELS: [Kernel; 3] = [Kernel::ThinPlate, Kernel::Cubic, Kernel::Linear];

    /// Random centres (one axis after another) and weights of both signs, and random points
    /// (per axis), some of them on a centre; all in the normalized box `[-0.6, 0.6]^dim`.
    struct Inputs {
        centres: Vec<f64>,
        weights: Vec<f64>,
        points: Vec<Vec<f64>>,
    }

    impl Inputs {
        fn new(dim: usize, n: usize, m: usize, seed: u64) -> Inputs {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut coordinate = || 1.2 * rng.random::<f64>() - 0.6;
            let centres: Vec<f64> = (0..dim * n).map(|_| coordinate()).collect();
            let mut points: Vec<Vec<f64>> =
                (0..dim).map(|_| (0..m).map(|_| coordinate()).collect()).collect();
            for (i, j) in [(0, 0), (m / 2, n - 1)] {
                for a in 0..dim {
                    points[a][i] = centres[a * n + j];
                }
            }
            let weights = (0..n).map(|_| rng.random::<f64>() - 0.5).collect();
            Inputs { centres, weights, points }
        }

        /// The same inputs rounded to f32 (and back).
        fn rounded(&self) -> Inputs {
            let round = |v: &[f64]| v.iter().map(|&x| f64::from(x as f32)).collect::<Vec<_>>();
            Inputs {
                centres: round(&self.centres),
                weights: round(&self.weights),
                points: self.points.iter().map(|axis| round(axis)).collect(),
            }
        }

        /// At each point, the scalar formula's sum with std's logarithm, and the size
        /// `sum_j |d_j phi_j|` that the tolerances are relative to.
        fn scalar(&self, kernel: Kernel) -> Vec<(f64, f64)> {
            let (dim, n) = (self.points.len(), self.weights.len());
            (0..self.points[0].len())
                .map(|i| {
                    let (mut total, mut size) = (0.0, 0.0);
                    for (j, d) in self.weights.iter().enumerate() {
                        let r2: f64 = (0..dim)
                            .map(|a| (self.points[a][i] - self.centres[a * n + j]).powi(2))
                            .sum();
                        let phi = kernel.phi_of_r2(r2);
                        total += d * phi;
                        size += (d * phi).abs();
                    }
                    (total, size)
                })
                .collect()
        }

        /// The points per axis, zero-padded to whole blocks of `lanes`.
        fn padded<T: Copy + Default>(&self, lanes: usize, convert: fn(f64) -> T) -> Vec<Vec<T>> {
            let m = self.points[0].len();
            let mut axes: Vec<Vec<T>> =
                self.points.iter().map(|axis| axis.iter().map(|&x| convert(x)).collect()).collect();
            axes.iter_mut().for_each(|axis| axis.resize(m.div_ceil(lanes) * lanes, T::default()));
            axes
        }
    }

    /// The f64 loop of `isa` on `inputs`, in the dimension and kernel [`specialize`] chooses.
    struct F64Loop<'a> {
        isa: Isa,
        inputs: &'a Inputs,
    }

    impl Specialized for F64Loop<'_> {
        type Output = Vec<f64>;

        fn run<const D: usize, K: Phi>(self) -> Vec<f64> {
            let axes = self.inputs.padded(LANES, |x| x);
            let points: [Vec<f64>; D] = std::array::from_fn(|a| axes[a].clone());
            let c = Centres { centres: &self.inputs.centres, weights: &self.inputs.weights };
            let mut out = vec![0.0; self.inputs.points[0].len()];
            sum::<D, K>(self.isa, &c, &points, &mut out);
            out
        }
    }

    /// The f32 thin-plate loop on `inputs`.
    struct F32Loop<'a> {
        f32_loop: ThinPlateF32,
        inputs: &'a Inputs,
    }

    impl Specialized for F32Loop<'_> {
        type Output = Vec<f64>;

        fn run<const D: usize, K: Phi>(self) -> Vec<f64> {
            let axes = self.inputs.padded(self.f32_loop.lanes(), |x| x as f32);
            let points: [Vec<f32>; D] = std::array::from_fn(|a| axes[a].clone());
            let narrow = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
            let (centres, weights) = (narrow(&self.inputs.centres), narrow(&self.inputs.weights));
            let mut out = vec![0.0; self.inputs.points[0].len()];
            self.f32_loop.sum::<D>(&centres, &weights, &points, &mut out);
            out
        }
    }

    /// The largest error of `got` against the scalar sums, relative to their sizes.
    fn worst(got: &[f64], scalar: &[(f64, f64)]) -> f64 {
        got.iter().zip(scalar).map(|(g, (want, size))| (g - want).abs() / size).fold(0.0, f64::max)
    }

    /// Every loop of every instruction set this CPU runs (not only the one `IMPLICITIZE_ISA`
    /// or detection selects), in every dimension and for every kernel, agrees with the scalar
    /// formula within the tolerances of the module doc. Points run to a partial last block.
    #[test]
    fn every_loop_on_every_instruction_set_agrees_with_the_scalar_formula() {
        let levels: Vec<Isa> = IsaLevel::ALL.into_iter().filter_map(Isa::supported).collect();
        for (seed, dim) in (2..=4).enumerate() {
            let inputs = Inputs::new(dim, 150, 3 * LANES + 5, seed as u64);
            let rounded = inputs.rounded();
            for &isa in &levels {
                for kernel in KERNELS {
                    let got = specialize(dim, kernel, F64Loop { isa, inputs: &inputs });
                    let error = worst(&got, &inputs.scalar(kernel));
                    assert!(error <= F64_TOLERANCE, "{isa:?} f64 {kernel} {dim}D: {error:e}");
                }
                let work = F32Loop { f32_loop: ThinPlateF32::of(isa), inputs: &rounded };
                let got = specialize(dim, Kernel::ThinPlate, work);
                let error = worst(&got, &rounded.scalar(Kernel::ThinPlate));
                assert!(error <= F32_TOLERANCE, "{isa:?} f32 {dim}D: {error:e}");
            }
        }
    }

    /// The scalar formulas, and the loops' thin-plate kernel, give `phi(0) = 0`, not NaN.
    #[test]
    fn phi_is_zero_at_zero() {
        assert_eq!(ThinPlate::phi::<portable::Separate>(0.0), 0.0);
        for kernel in KERNELS {
            assert_eq!(kernel.phi_of_r2(0.0), 0.0);
        }
    }
}
