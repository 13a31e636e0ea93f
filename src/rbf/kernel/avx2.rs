//! The thin-plate loop `sum_j d_j r_j^2 ln r_j` in f32 with AVX2 and FMA intrinsics, for the
//! fit's volume passes on CPUs without AVX-512 (see [`super::ThinPlateF32`]).
//!
//! Eight f32 lanes a vector against the f64 loop's four, and a logarithm without division:
//! * `x = 2^e m` with `m` in `[1, 2)` from the bits of `x` (exponent field minus the bias, and
//!   the fraction under the exponent of 1);
//! * the top 3 bits of `m`'s fraction pick one of 8 points `c_i` (in a register, by
//!   `vpermps`, no memory gather), with `1 / c_i` and `ln c_i` tabulated:
//!   `m = c_i (1 + r)`, `|r| < 1/16`;
//! * `ln(1 + r)` by its Taylor series to `r^5 / 5` (remainder below `7e-9`, a seventeenth of
//!   f32's epsilon), five FMAs.
//!
//! Below the smallest normal (0 included) `x` counts as the smallest normal, so `0 ln 0` is 0.
//! The logarithm of a NaN or an infinity is not: the loop multiplies it by `d r^2`, which is
//! then NaN or infinite itself, so the sum is NaN or infinite either way.

use std::arch::x86_64::*;

/// Points per block: two vectors of 8.
pub(super) const LANES_F32: usize = 16;

/// The radial sums at `points` (per axis, whole blocks of [`LANES_F32`]) of the centres
/// `centres` (f32, one axis after another) with weights `weights`, written to `out`.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn run_f32<const D: usize>(
    centres: &[f32],
    weights: &[f32],
    points: &[Vec<f32>; D],
    out: &mut [f64],
) {
    let n = weights.len();
    let axes: [&[f32]; D] = std::array::from_fn(|a| &centres[a * n..(a + 1) * n]);
    let log = Log::new();
    for (b, o) in out.chunks_mut(LANES_F32).enumerate() {
        let x: [[__m256; 2]; D] =
            std::array::from_fn(|a| load(&points[a][b * LANES_F32..(b + 1) * LANES_F32]));
        let mut acc = [_mm256_setzero_ps(); 2];
        for (j, &weight) in weights.iter().enumerate() {
            let mut r2 = [_mm256_setzero_ps(); 2];
            for (xa, axis) in x.iter().zip(&axes) {
                let ca = _mm256_set1_ps(axis[j]);
                for h in 0..2 {
                    let t = _mm256_sub_ps(xa[h], ca);
                    r2[h] = _mm256_fmadd_ps(t, t, r2[h]);
                }
            }
            let d = _mm256_set1_ps(0.5 * weight);
            for h in 0..2 {
                acc[h] = _mm256_fmadd_ps(_mm256_mul_ps(d, r2[h]), log.ln(r2[h]), acc[h]);
            }
        }
        for (o, v) in o.iter_mut().zip(store(acc)) {
            *o = f64::from(v);
        }
    }
}

/// Two vectors from 16 values.
#[inline]
#[target_feature(enable = "avx2,fma")]
fn load(values: &[f32]) -> [__m256; 2] {
    let values: &[f32; 16] = values.try_into().expect("16 values");
    // SAFETY: both reads are of 8 values inside the 16 of `values`.
    unsafe { [_mm256_loadu_ps(values.as_ptr()), _mm256_loadu_ps(values[8..].as_ptr())] }
}

/// The 16 values of two vectors.
#[inline]
#[target_feature(enable = "avx2,fma")]
fn store(v: [__m256; 2]) -> [f32; 16] {
    let mut values = [0.0; 16];
    // SAFETY: both writes are of 8 values inside the 16 of `values`.
    unsafe {
        _mm256_storeu_ps(values.as_mut_ptr(), v[0]);
        _mm256_storeu_ps(values[8..].as_mut_ptr(), v[1]);
    }
    values
}

/// The logarithm's tables, one register each.
struct Log {
    inv: __m256,
    ln_c: __m256,
}

impl Log {
    /// `1 / c_i` for the midpoints `c_i = 1 + (2 i + 1) / 16` of the 8 intervals of `[1, 2)`,
    /// rounded to f32, and `ln c_i` as `-ln` of that rounded reciprocal, so that
    /// `m (1 / c_i) = 1 + r` holds exactly in the reals.
    #[target_feature(enable = "avx2,fma")]
    fn new() -> Log {
        let inv: [f32; 8] =
            std::array::from_fn(|i| (1.0 / (1.0 + (2 * i + 1) as f64 / 16.0)) as f32);
        let ln_c = inv.map(|v| -(f64::from(v).ln()) as f32);
        // SAFETY: each read is of the 8 values of an array.
        unsafe { Log { inv: _mm256_loadu_ps(inv.as_ptr()), ln_c: _mm256_loadu_ps(ln_c.as_ptr()) } }
    }

    /// `ln x` for finite `x >= 0` to f32 precision (see the module doc for the rest).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn ln(&self, x: __m256) -> __m256 {
        let x = _mm256_max_ps(x, _mm256_set1_ps(f32::MIN_POSITIVE));
        let bits = _mm256_castps_si256(x);
        let exponent = _mm256_sub_epi32(_mm256_srli_epi32::<23>(bits), _mm256_set1_epi32(127));
        let e = _mm256_cvtepi32_ps(exponent);
        let fraction = _mm256_and_si256(bits, _mm256_set1_epi32(0x007f_ffff));
        let m = _mm256_castsi256_ps(_mm256_or_si256(fraction, _mm256_set1_epi32(0x3f80_0000)));
        // The index sits in bits 20..23; vpermps reads the low 3 bits of each lane.
        let i = _mm256_srli_epi32::<20>(bits);
        let inv = _mm256_permutevar8x32_ps(self.inv, i);
        let ln_c = _mm256_permutevar8x32_ps(self.ln_c, i);
        let r = _mm256_fmsub_ps(m, inv, _mm256_set1_ps(1.0));
        // ln(1 + r) = r (1 - r/2 + r^2/3 - r^3/4 + r^4/5).
        let mut p = _mm256_set1_ps(0.2);
        for coefficient in [-0.25, 1.0 / 3.0, -0.5, 1.0] {
            p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(coefficient));
        }
        let base = _mm256_fmadd_ps(e, _mm256_set1_ps(std::f32::consts::LN_2), ln_c);
        _mm256_fmadd_ps(p, r, base)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Log::ln` at `xs`, on a CPU with AVX2 and FMA.
    fn ln8(xs: [f32; 8]) -> [f32; 8] {
        assert!(
            std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma"),
            "this CPU has no AVX2 and FMA: run without --ignored"
        );
        // SAFETY: the CPU reported AVX2 and FMA just above.
        unsafe {
            let log = Log::new();
            let v = log.ln(_mm256_loadu_ps(xs.as_ptr()));
            let mut out = [0.0; 8];
            _mm256_storeu_ps(out.as_mut_ptr(), v);
            out
        }
    }

    #[test]
    #[cfg_attr(not(host_has_avx2), ignore = "this CPU has no AVX2 and FMA")]
    fn ln_is_within_a_few_f32_ulps_of_max_one_and_ln_x() {
        let mut xs = vec![f32::MIN_POSITIVE, 1.0, 2.0, 0.5, 1e-30, 1e30, f32::MAX];
        // Every table interval's ends and middle, over every binade, and a sweep of mantissas.
        for e in -126..128 {
            let scale = 2f32.powi(e);
            for i in 0..=16 {
                let m = 1.0 + i as f32 / 16.0;
                for y in [m, m * (1.0 - 1e-7), m * (1.0 + 1e-7), m + 1.0 / 32.0] {
                    xs.push(y * scale);
                }
            }
            xs.push(1.012_345_7 * scale * 1.7);
        }
        for chunk in xs.chunks(8) {
            let mut block = [1.0; 8];
            block[..chunk.len()].copy_from_slice(chunk);
            for (x, got) in block.iter().zip(ln8(block)) {
                if !x.is_finite() {
                    continue;
                }
                let want = f64::from(*x).ln();
                let tol = 4.0 * f64::from(f32::EPSILON) * want.abs().max(1.0);
                assert!((f64::from(got) - want).abs() <= tol, "ln({x:e}) = {got}, want {want}");
            }
        }
        let zero = f64::from(ln8([0.0; 8])[0]);
        assert!((zero - f64::from(f32::MIN_POSITIVE).ln()).abs() <= 1e-5, "ln 0 = {zero}");
    }
}
