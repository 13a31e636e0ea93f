//! The thin-plate loop `sum_j d_j r_j^2 ln r_j` written with AVX-512 intrinsics.
//!
//! The auto-vectorized loop ([`super::portable`]) is bound both by the division of its logarithm
//! (one `vdivpd` per 8 lanes) and by its count of vector operations. This loop removes the
//! division and a third of the operations, by a table-driven logarithm that the compiler cannot
//! derive from scalar code:
//! * `x = 2^e m` with `m` in `[1, 2)` by `vgetexppd` and `vgetmantpd` (one instruction each);
//! * the top 4 bits of `m`'s fraction pick one of 16 points `c_i` (in registers, by `vpermt2pd`,
//!   no memory gather), with `1 / c_i` and `ln c_i` tabulated: `m = c_i (1 + r)`, `|r| < 1/32`;
//! * `ln(1 + r)` by its Taylor series to `r^9 / 9` (remainder below `7e-17`), eight FMAs.
//!
//! The error of `ln x` is within a few units in the last place of `max(1, |ln x|)`: an absolute
//! error, which is what the sum needs (each term's error is `d_j r_j^2` times it), though not a
//! relative one next to `x = 1`. `r^2 ln r = (d_j / 2) r^2 ln(r^2)`
//! with the halving done once per centre.

use std::arch::x86_64::*;

use super::{Centres, LANES};

/// Points one call of the inner loop handles: two vectors of 8.
const _: () = assert!(LANES == 16);

/// `1 / c_i` and `ln c_i` for the midpoints `c_i = 1 + (2 i + 1) / 32` of the 16 intervals of
/// `[1, 2)` that the top 4 fraction bits select. `ln c_i` is taken as `-ln(1 / c_i)` of the
/// rounded reciprocal, so that `m (1 / c_i) = 1 + r` holds exactly in the reals.
fn tables() -> ([f64; 16], [f64; 16]) {
    let inv: [f64; 16] = std::array::from_fn(|i| 1.0 / (1.0 + (2 * i + 1) as f64 / 32.0));
    let ln_c = inv.map(|v| -v.ln());
    (inv, ln_c)
}

/// The radial part at `points` (per axis, whole blocks of [`LANES`]) into `out`.
///
/// # Safety
/// The CPU must support AVX-512 F.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn run<const D: usize>(c: &Centres, points: &[Vec<f64>; D], out: &mut [f64]) {
    let n = c.weights.len();
    let axes: [&[f64]; D] = std::array::from_fn(|a| &c.centres[a * n..(a + 1) * n]);
    let log = Log::new();
    for (b, o) in out.chunks_mut(LANES).enumerate() {
        let x: [[__m512d; 2]; D] =
            std::array::from_fn(|a| load(&points[a][b * LANES..(b + 1) * LANES]));
        let mut acc = [_mm512_setzero_pd(); 2];
        for (j, &weight) in c.weights.iter().enumerate() {
            let mut r2 = [_mm512_setzero_pd(); 2];
            for (xa, axis) in x.iter().zip(&axes) {
                let ca = _mm512_set1_pd(axis[j]);
                for h in 0..2 {
                    let t = _mm512_sub_pd(xa[h], ca);
                    r2[h] = _mm512_fmadd_pd(t, t, r2[h]);
                }
            }
            let d = _mm512_set1_pd(0.5 * weight);
            for h in 0..2 {
                acc[h] = _mm512_fmadd_pd(_mm512_mul_pd(d, r2[h]), log.ln(r2[h]), acc[h]);
            }
        }
        let v = store(acc);
        o.copy_from_slice(&v[..o.len()]);
    }
}

/// Two vectors from 16 values.
#[inline]
#[target_feature(enable = "avx512f")]
fn load(values: &[f64]) -> [__m512d; 2] {
    let values: &[f64; 16] = values.try_into().expect("16 values");
    // SAFETY: both reads are of 8 values inside the 16 of `values`.
    unsafe { [_mm512_loadu_pd(values.as_ptr()), _mm512_loadu_pd(values[8..].as_ptr())] }
}

/// The 16 values of two vectors.
#[inline]
#[target_feature(enable = "avx512f")]
fn store(v: [__m512d; 2]) -> [f64; 16] {
    let mut values = [0.0; 16];
    // SAFETY: both writes are of 8 values inside the 16 of `values`.
    unsafe {
        _mm512_storeu_pd(values.as_mut_ptr(), v[0]);
        _mm512_storeu_pd(values[8..].as_mut_ptr(), v[1]);
    }
    values
}

/// The logarithm's tables, in registers.
struct Log {
    inv_lo: __m512d,
    inv_hi: __m512d,
    ln_c_lo: __m512d,
    ln_c_hi: __m512d,
}

impl Log {
    #[target_feature(enable = "avx512f")]
    fn new() -> Log {
        let (inv, ln_c) = tables();
        let [inv_lo, inv_hi] = load(&inv);
        let [ln_c_lo, ln_c_hi] = load(&ln_c);
        Log { inv_lo, inv_hi, ln_c_lo, ln_c_hi }
    }

    /// `ln x` for `x >= 0`; `x` below the smallest normal (0 included) is taken as the smallest
    /// normal, so that `0 ln 0` comes out 0; NaN stays NaN.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn ln(&self, x: __m512d) -> __m512d {
        const LN2: f64 = std::f64::consts::LN_2;
        let x = _mm512_max_pd(_mm512_set1_pd(f64::MIN_POSITIVE), x);
        let e = _mm512_getexp_pd(x);
        let m = _mm512_getmant_pd::<_MM_MANT_NORM_1_2, _MM_MANT_SIGN_ZERO>(x);
        // The index sits in bits 48..52; vpermt2pd reads the low 4 bits of each lane.
        let i = _mm512_srli_epi64::<48>(_mm512_castpd_si512(m));
        let inv = _mm512_permutex2var_pd(self.inv_lo, i, self.inv_hi);
        let ln_c = _mm512_permutex2var_pd(self.ln_c_lo, i, self.ln_c_hi);
        let r = _mm512_fmsub_pd(m, inv, _mm512_set1_pd(1.0));
        // ln(1 + r) = r (1 - r/2 + r^2/3 - ... - r^8/9).
        let mut p = _mm512_set1_pd(1.0 / 9.0);
        for k in (1..=8).rev() {
            let coefficient = if k % 2 == 1 { 1.0 } else { -1.0 } / k as f64;
            p = _mm512_fmadd_pd(p, r, _mm512_set1_pd(coefficient));
        }
        let base = _mm512_fmadd_pd(e, _mm512_set1_pd(LN2), ln_c);
        _mm512_fmadd_pd(p, r, base)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `Log::ln` at `xs`, on a CPU with AVX-512.
    fn ln8(xs: [f64; 8]) -> [f64; 8] {
        // SAFETY: only called after the CPU reported AVX-512 F.
        unsafe {
            let log = Log::new();
            let v = log.ln(_mm512_loadu_pd(xs.as_ptr()));
            let mut out = [0.0; 8];
            _mm512_storeu_pd(out.as_mut_ptr(), v);
            out
        }
    }

    #[test]
    #[cfg_attr(not(host_has_avx512), ignore = "this CPU has no AVX-512")]
    fn ln_is_within_a_few_ulps_of_max_one_and_ln_x() {
        assert!(
            std::is_x86_feature_detected!("avx512f"),
            "this CPU has no AVX-512: run without --ignored"
        );
        let mut xs = vec![f64::MIN_POSITIVE, 1.0, 2.0, 0.5, 1e-300, 1e300, f64::MAX];
        // Every table interval's ends and middle, over many binades, and a sweep of mantissas.
        for e in -1000..1000 {
            let scale = 2f64.powi(e);
            for i in 0..=16 {
                let m = 1.0 + i as f64 / 16.0;
                for y in [m, m * (1.0 - 1e-15), m * (1.0 + 1e-15), m + 1.0 / 32.0] {
                    xs.push(y * scale);
                }
            }
            xs.push(1.0123456789 * scale * 1.7);
        }
        for chunk in xs.chunks(8) {
            let mut block = [1.0; 8];
            block[..chunk.len()].copy_from_slice(chunk);
            for (x, got) in block.iter().zip(ln8(block)) {
                let want = x.ln();
                let tol = 4.0 * f64::EPSILON * want.abs().max(1.0);
                assert!((got - want).abs() <= tol, "ln({x:e}) = {got}, want {want}");
            }
        }
        assert!((ln8([0.0; 8])[0] - f64::MIN_POSITIVE.ln()).abs() <= 1e-12);
        assert!(ln8([f64::NAN; 8])[0].is_nan());
    }
}

/// Points per block of the f32 loop: two vectors of 16.
pub(super) const LANES_F32: usize = 32;

/// The f32 counterpart of [`run`]: centres (one axis after another) and weights in f32,
/// points per axis in whole blocks of [`LANES_F32`], sums written to `out`.
///
/// # Safety
/// The CPU must support AVX-512 F.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn run_f32<const D: usize>(
    centres: &[f32],
    weights: &[f32],
    points: &[Vec<f32>; D],
    out: &mut [f64],
) {
    let n = weights.len();
    let axes: [&[f32]; D] = std::array::from_fn(|a| &centres[a * n..(a + 1) * n]);
    let log = LogF32::new();
    for (b, o) in out.chunks_mut(LANES_F32).enumerate() {
        let x: [[__m512; 2]; D] =
            std::array::from_fn(|a| load_f32(&points[a][b * LANES_F32..(b + 1) * LANES_F32]));
        let mut acc = [_mm512_setzero_ps(); 2];
        for (j, &weight) in weights.iter().enumerate() {
            let mut r2 = [_mm512_setzero_ps(); 2];
            for (xa, axis) in x.iter().zip(&axes) {
                let ca = _mm512_set1_ps(axis[j]);
                for h in 0..2 {
                    let t = _mm512_sub_ps(xa[h], ca);
                    r2[h] = _mm512_fmadd_ps(t, t, r2[h]);
                }
            }
            let d = _mm512_set1_ps(0.5 * weight);
            for h in 0..2 {
                acc[h] = _mm512_fmadd_ps(_mm512_mul_ps(d, r2[h]), log.ln(r2[h]), acc[h]);
            }
        }
        let v = store_f32(acc);
        for (o, v) in o.iter_mut().zip(v) {
            *o = f64::from(v);
        }
    }
}

/// Two vectors from 32 values.
#[inline]
#[target_feature(enable = "avx512f")]
fn load_f32(values: &[f32]) -> [__m512; 2] {
    let values: &[f32; 32] = values.try_into().expect("32 values");
    // SAFETY: both reads are of 16 values inside the 32 of `values`.
    unsafe { [_mm512_loadu_ps(values.as_ptr()), _mm512_loadu_ps(values[16..].as_ptr())] }
}

/// The 32 values of two vectors.
#[inline]
#[target_feature(enable = "avx512f")]
fn store_f32(v: [__m512; 2]) -> [f32; 32] {
    let mut values = [0.0; 32];
    // SAFETY: both writes are of 16 values inside the 32 of `values`.
    unsafe {
        _mm512_storeu_ps(values.as_mut_ptr(), v[0]);
        _mm512_storeu_ps(values[16..].as_mut_ptr(), v[1]);
    }
    values
}

/// The f32 logarithm's tables (the same 16 intervals), one register each.
struct LogF32 {
    inv: __m512,
    ln_c: __m512,
}

impl LogF32 {
    #[target_feature(enable = "avx512f")]
    fn new() -> LogF32 {
        let inv = tables().0.map(|v| v as f32);
        // -ln of the f32 reciprocal, so that m (1 / c_i) = 1 + r holds for the rounded one.
        let ln_c = inv.map(|v| -(f64::from(v).ln()) as f32);
        // SAFETY: each read is of the 16 values of an array.
        unsafe {
            LogF32 { inv: _mm512_loadu_ps(inv.as_ptr()), ln_c: _mm512_loadu_ps(ln_c.as_ptr()) }
        }
    }

    /// `ln x` for `x >= 0` to f32 precision; as [`Log::ln`], below the smallest normal counts
    /// as the smallest normal and NaN stays NaN. The series stops at `r^4 / 4` (remainder
    /// below `6e-9`, a tenth of f32's epsilon).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn ln(&self, x: __m512) -> __m512 {
        let x = _mm512_max_ps(_mm512_set1_ps(f32::MIN_POSITIVE), x);
        let e = _mm512_getexp_ps(x);
        let m = _mm512_getmant_ps::<_MM_MANT_NORM_1_2, _MM_MANT_SIGN_ZERO>(x);
        // The index sits in bits 19..23; vpermps reads the low 4 bits of each lane.
        let i = _mm512_srli_epi32::<19>(_mm512_castps_si512(m));
        let inv = _mm512_permutexvar_ps(i, self.inv);
        let ln_c = _mm512_permutexvar_ps(i, self.ln_c);
        let r = _mm512_fmsub_ps(m, inv, _mm512_set1_ps(1.0));
        let mut p = _mm512_set1_ps(-0.25);
        for coefficient in [1.0 / 3.0, -0.5, 1.0] {
            p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(coefficient));
        }
        let base = _mm512_fmadd_ps(e, _mm512_set1_ps(std::f32::consts::LN_2), ln_c);
        _mm512_fmadd_ps(p, r, base)
    }
}
