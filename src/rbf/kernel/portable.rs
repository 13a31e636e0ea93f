//! The f64 block loop in plain Rust, which the compiler vectorizes: every kernel, on every
//! instruction set (compiled three times, for AVX-512, for AVX2 with FMA and for the target's
//! baseline), and the logarithm it uses for `r^2 log r`; and the f32 thin-plate loop of the
//! target's baseline (SSE2 on x86-64, NEON on aarch64), for the fit's volume passes where the
//! CPU has no AVX2 (see [`super::ThinPlateF32`]).
//!
//! * Points go in blocks of [`LANES`]; for each centre the block's distances and kernel values
//!   are computed lane by lane in straight-line f64 code that the compiler turns into vector
//!   instructions, and accumulated per lane (no horizontal sums).
//! * `r^2 log r = 0.5 r^2 ln(r^2)` needs no square root; the logarithm is the classic
//!   fdlibm/musl `log`'s reduction and series (exponent split, one division and a degree-14 odd
//!   series) without fdlibm's extra-precision correction terms, written without branches or
//!   table lookups so that it vectorizes: within 3 ulps of std's `f64::ln` (a test holds it).

use super::{Centres, LANES, Phi};

/// Points per block of the f32 loop.
pub(super) const LANES_F32: usize = 16;

/// Multiply-add: fused where the CPU has FMA, separate otherwise (a libm call per operation
/// would be slower than both).
pub(in crate::rbf) trait Arith {
    /// `a b + c`.
    fn mul_add(a: f64, b: f64, c: f64) -> f64;
}

/// Fused multiply-adds, for CPUs with FMA.
pub(super) struct Fused;
impl Arith for Fused {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// A multiplication then an addition, for CPUs without FMA.
#[allow(dead_code)] // Used on targets and CPUs without FMA.
pub(super) struct Separate;
impl Arith for Separate {
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

/// Natural logarithm of a positive normal `x`, branch-free: `x = 2^k m` with `m` in
/// `[sqrt(2)/2, sqrt(2))`, `s = (m - 1) / (m + 1)` and `ln m = 2 atanh s = s Q(s^2)`, with `Q`
/// fdlibm's minimax series (`Q(z) = 2 + z (Lg1 + z (Lg2 + ...))`, `|s| < 0.172`). Within
/// 3 ulps of std's `f64::ln`, with and without fused multiply-adds (the largest errors are
/// near 1, where the result is small), with one division and no table, so that it vectorizes.
#[inline(always)]
pub(super) fn ln<A: Arith>(x: f64) -> f64 {
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

/// [`run`] compiled for AVX-512.
///
/// # Safety
/// The CPU must support AVX-512 F, DQ and VL, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma")]
pub(super) unsafe fn run_avx512<const D: usize, K: Phi>(
    c: &Centres,
    points: &[Vec<f64>; D],
    out: &mut [f64],
) {
    run::<D, K, Fused>(c, points, out)
}

/// [`run`] compiled for AVX2 with FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn run_avx2<const D: usize, K: Phi>(
    c: &Centres,
    points: &[Vec<f64>; D],
    out: &mut [f64],
) {
    run::<D, K, Fused>(c, points, out)
}

/// [`run`] compiled for the target's baseline, which has FMA.
#[cfg(target_feature = "fma")]
pub(super) fn run_baseline<const D: usize, K: Phi>(
    c: &Centres,
    points: &[Vec<f64>; D],
    out: &mut [f64],
) {
    run::<D, K, Fused>(c, points, out)
}

/// [`run`] compiled for the target's baseline, which has no FMA.
#[cfg(not(target_feature = "fma"))]
pub(super) fn run_baseline<const D: usize, K: Phi>(
    c: &Centres,
    points: &[Vec<f64>; D],
    out: &mut [f64],
) {
    run::<D, K, Separate>(c, points, out)
}

/// Natural logarithm of a positive normal `x` in f32, by the reduction of [`ln`]
/// (`x = 2^k m`, `m` in `[sqrt(2)/2, sqrt(2))`, `s = (m - 1) / (m + 1)`) and
/// `ln m = 2 atanh s = 2 s (1 + s^2/3 + s^4/5 + s^6/7 + s^8/9)`, whose next term is below
/// `1e-10` of the sum (`|s| < 0.172`), far below f32's rounding. Branch-free, with one division,
/// so that it vectorizes on any instruction set.
#[inline(always)]
fn ln_f32(x: f32) -> f32 {
    // The bits of sqrt(2)/2 in f32: adding the difference to 1.0's puts the split at sqrt(2).
    const SPLIT: u32 = 0x3f35_04f3;
    let u = x.to_bits().wrapping_add(0x3f80_0000 - SPLIT);
    let k = ((u >> 23) as i32 - 127) as f32;
    let m = f32::from_bits((u & 0x007f_ffff) + SPLIT);
    let f = m - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let q = 1.0 + z * (1.0 / 3.0 + z * (1.0 / 5.0 + z * (1.0 / 7.0 + z * (1.0 / 9.0))));
    2.0 * s * q + k * std::f32::consts::LN_2
}

/// The thin-plate sum `sum_j (d_j / 2) r_j^2 ln r_j^2` in f32 for one block of points given per
/// axis; below the smallest normal (0 included) `r^2` counts as the smallest normal in the
/// logarithm, so `0 ln 0` is 0.
#[inline(always)]
fn block_f32<const D: usize>(
    centres: &[f32],
    weights: &[f32],
    x: &[[f32; LANES_F32]; D],
) -> [f32; LANES_F32] {
    let n = weights.len();
    let axes: [&[f32]; D] = std::array::from_fn(|a| &centres[a * n..(a + 1) * n]);
    let mut acc = [0.0; LANES_F32];
    for (j, &weight) in weights.iter().enumerate() {
        let mut r2 = [0.0f32; LANES_F32];
        for a in 0..D {
            let ca = axes[a][j];
            for l in 0..LANES_F32 {
                let t = x[a][l] - ca;
                r2[l] += t * t;
            }
        }
        let d = 0.5 * weight;
        for l in 0..LANES_F32 {
            let clamped = if r2[l] < f32::MIN_POSITIVE { f32::MIN_POSITIVE } else { r2[l] };
            acc[l] += d * r2[l] * ln_f32(clamped);
        }
    }
    acc
}

/// The f32 thin-plate sums at `points` (per axis, whole blocks of [`LANES_F32`]) of the
/// centres `centres` (f32, one axis after another) with weights `weights`, written to `out`,
/// compiled for the target's baseline.
pub(super) fn run_f32_baseline<const D: usize>(
    centres: &[f32],
    weights: &[f32],
    points: &[Vec<f32>; D],
    out: &mut [f64],
) {
    for (b, o) in out.chunks_mut(LANES_F32).enumerate() {
        let x: [[f32; LANES_F32]; D] = std::array::from_fn(|a| {
            points[a][b * LANES_F32..(b + 1) * LANES_F32].try_into().expect("whole blocks")
        });
        for (o, v) in o.iter_mut().zip(block_f32::<D>(centres, weights, &x)) {
            *o = f64::from(v);
        }
    }
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

    /// The f32 logarithm is within a few f32 ulps of `max(1, |ln x|)` (an absolute error, as
    /// the sum needs) over every binade of normal f32 numbers, both sides of the split, and near
    /// 1.
    #[test]
    fn the_f32_ln_is_within_a_few_f32_ulps_of_max_one_and_ln_x() {
        let mut xs = vec![f32::MIN_POSITIVE, 1.0, 2.0, 0.5, f32::MAX];
        let split = std::f32::consts::SQRT_2;
        let mut x = f32::MIN_POSITIVE;
        while x < 1e37 {
            xs.extend([x, x * 1.1, x * split * (1.0 - 1e-6), x * split * (1.0 + 1e-6), x * 1.99]);
            x *= 3.7;
        }
        for i in 1..20_000 {
            let t = i as f32 / 20_000.0;
            xs.extend([1.0 + 0.45 * t, 1.0 - 0.3 * t, 1.0 + t * 1e-3]);
        }
        for x in xs {
            let want = f64::from(x).ln();
            let tol = 4.0 * f64::from(f32::EPSILON) * want.abs().max(1.0);
            let got = f64::from(ln_f32(x));
            assert!((got - want).abs() <= tol, "ln({x:e}) = {got}, want {want}");
        }
        assert_eq!(ln_f32(1.0), 0.0);
    }
}
