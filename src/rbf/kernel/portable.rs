//! The f64 block loop in plain Rust, which the compiler vectorizes: every kernel, on every
//! instruction set (compiled three times, for AVX-512, for AVX2 with FMA and for the target's
//! baseline), and the logarithm it uses for `r^2 log r`.
//!
//! * Points go in blocks of [`LANES`]; for each centre the block's distances and kernel values
//!   are computed lane by lane in straight-line f64 code that the compiler turns into vector
//!   instructions, and accumulated per lane (no horizontal sums).
//! * `r^2 log r = 0.5 r^2 ln(r^2)` needs no square root; the logarithm is the classic
//!   fdlibm/musl `log`'s reduction and series (exponent split, one division and a degree-14 odd
//!   series) without fdlibm's extra-precision correction terms, written without branches or
//!   table lookups so that it vectorizes: within 3 ulps of std's `f64::ln` (a test holds it).

use super::{Centres, LANES, Phi};

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
}
