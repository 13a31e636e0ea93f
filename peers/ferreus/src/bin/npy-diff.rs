//! `npy-diff`: compares two value arrays, as written by `implicitize eval` and `ferreus-peer`,
//! for `scripts/bench-solve-20k.sh`.
//!
//! Usage: `npy-diff A.npy B.npy [--scale S]`
//!
//! Both files hold N values (float32 or float64, any shape with N elements). Prints one JSON
//! line: N, the largest `|a_i - b_i|`, that divided by S (default 1; the bench passes the
//! constraints' value range), the index where it occurs, and the fraction of points where the
//! two signs (inside / outside) disagree.

use std::path::Path;
use std::process::ExitCode;

const USAGE: &str = "usage: npy-diff A.npy B.npy [--scale S]";

fn read(path: &Path) -> Result<Vec<f64>, String> {
    let file = path.display();
    let bytes = std::fs::read(path).map_err(|e| format!("{file}: {e}"))?;
    let npy = npyz::NpyFile::new(&bytes[..])
        .map_err(|e| format!("{file}: not a NumPy .npy file: {e}"))?;
    let bad = |e: std::io::Error| format!("{file}: damaged array data: {e}");
    let dtype = npy.dtype().descr();
    match dtype.trim_matches('\'') {
        "<f8" => npy.into_vec::<f64>().map_err(bad),
        "<f4" => Ok(npy.into_vec::<f32>().map_err(bad)?.into_iter().map(f64::from).collect()),
        other => Err(format!("{file}: expected float32 or float64 values, found dtype {other}")),
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (a, b, scale) = match args.as_slice() {
        [a, b] => (a, b, 1.0),
        [a, b, flag, s] if flag == "--scale" => {
            let s: f64 = s.parse().map_err(|_| format!("--scale is not a number: {s:?}"))?;
            if !(s.is_finite() && s > 0.0) {
                return Err(format!("--scale must be positive, found {s}"));
            }
            (a, b, s)
        }
        _ => return Err(USAGE.to_string()),
    };
    let (va, vb) = (read(Path::new(a))?, read(Path::new(b))?);
    if va.len() != vb.len() {
        return Err(format!("{a} holds {} values but {b} holds {}", va.len(), vb.len()));
    }
    let (mut max, mut at, mut sign_differs, mut nan) = (0.0f64, 0usize, 0usize, 0usize);
    for (i, (x, y)) in va.iter().zip(&vb).enumerate() {
        let d = (x - y).abs();
        if d.is_nan() {
            nan += 1;
        } else if d > max {
            (max, at) = (d, i);
        }
        if (*x > 0.0 && *y < 0.0) || (*x < 0.0 && *y > 0.0) {
            sign_differs += 1;
        }
    }
    let n = va.len();
    println!(
        "{{\"n\":{n},\"max_abs_diff\":{max:e},\"max_rel\":{:e},\"at\":{at},\
         \"sign_disagree_fraction\":{:e},\"nan\":{nan}}}",
        max / scale,
        if n == 0 { 0.0 } else { sign_differs as f64 / n as f64 }
    );
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("npy-diff: {message}");
            ExitCode::FAILURE
        }
    }
}
