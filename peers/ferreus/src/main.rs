//! `ferreus-peer`: the benchmark peer of `implicitize solve` and `implicitize eval`, built on
//! the `ferreus_rbf` crate (FGMRES preconditioned by domain decomposition, matrix-vector
//! products by a black-box fast multipole method), for `scripts/bench-solve-20k.sh`.
//!
//! Usage: `ferreus-peer CONSTRAINTS.csv [--points POINTS.npy --out VALUES.npy] [--order N]
//! [--tolerance T] [--no-direct]`
//!
//! Reads constraints as `implicitize solve` does (CSV `x,y,z,value` or `x,y,value`, header
//! first), checks them (finite numbers, no repeated position, not all on one plane or line),
//! fits the thin-plate spline `r^2 log r` with a degree-1 polynomial, and prints one JSON
//! object a line on stdout:
//! - `input`: the constraint count, dimension and value range (`max h - min h`);
//! - `solve`: wall seconds of the fit, the FMM order and epsilon, the FGMRES iterations and its
//!   last relative residual estimate;
//! - `residual` from `ferreus`: `max |f(c_i) - h_i| / (max h - min h)` with `f` evaluated by the
//!   crate (FMM) at the constraint positions;
//! - `residual` from `direct` (unless `--no-direct`): the same from the crate's weights and
//!   polynomial coefficients, summed exactly in f64 here (O(N^2)), and the largest difference
//!   between the crate's values and these, relative to the value range;
//! - `eval` (with `--points`): wall seconds of evaluating at the points (an N x dim float32 or
//!   float64 `.npy`), whose values go to `--out` as a float64 `.npy` of length N.
//!
//! `--order` sets the FMM's Chebyshev interpolation order (the crate's default for this kernel
//! is 9) and, as the crate's defaults do, its compression epsilon to `10^-order`. `--tolerance`
//! is the FGMRES stopping tolerance relative to the initial residual's 2-norm (default 1e-6,
//! the crate's). Below 4,096 constraints the crate solves directly instead.
//!
//! The kernel convention, read from `ferreus_rbf` 0.2.2 and `ferreus_rbf_utils` 0.2.0:
//! `f(x) = sum_j w_j phi(|x - x_j|) + c_0 + sum_d c_d (x_d - t_d) / s_d`, `phi(r) = r^2 ln r`
//! on the raw coordinates, `t` and `s` the centre and half-size of the constraints' bounding
//! box (an axis of zero size gets `s = 1`).

mod input;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use faer::Mat;
use ferreus_rbf::RBFInterpolator;
use ferreus_rbf::config::{FmmParams, Params};
use ferreus_rbf::interpolant_config::{
    Drift, FittingAccuracy, FittingAccuracyType, InterpolantSettings, RBFKernelType,
};
use ferreus_rbf::progress::{ProgressMsg, ProgressSink};

use input::{read_constraints, read_points, write_values};

const USAGE: &str = "usage: ferreus-peer CONSTRAINTS.csv [--points POINTS.npy --out VALUES.npy] \
                     [--order N] [--tolerance T] [--no-direct]";

/// The command line.
struct Args {
    constraints: PathBuf,
    points: Option<(PathBuf, PathBuf)>,
    order: Option<usize>,
    tolerance: f64,
    direct: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args_os().skip(1);
    let (mut constraints, mut points, mut out, mut order) = (None, None, None, None);
    let (mut tolerance, mut direct) = (FittingAccuracy::default().tolerance, true);
    while let Some(arg) = args.next() {
        let mut value =
            |name: &str| args.next().ok_or_else(|| format!("{name} needs a value\n{USAGE}"));
        match arg.to_str() {
            Some("--points") => points = Some(PathBuf::from(value("--points")?)),
            Some("--out") => out = Some(PathBuf::from(value("--out")?)),
            Some("--order") => {
                let v = value("--order")?;
                let n = v
                    .to_str()
                    .and_then(|s| s.parse::<usize>().ok())
                    .filter(|n| (2..=20).contains(n));
                order = Some(n.ok_or_else(|| format!("--order: expected 2 to 20, found {v:?}"))?);
            }
            Some("--tolerance") => {
                let v = value("--tolerance")?;
                let t = v.to_str().and_then(|s| s.parse::<f64>().ok());
                tolerance =
                    t.filter(|t| t.is_finite() && *t > 0.0 && *t < 1.0).ok_or_else(|| {
                        format!("--tolerance: expected a number in (0, 1), found {v:?}")
                    })?;
            }
            Some("--no-direct") => direct = false,
            Some("-h" | "--help") => return Err(USAGE.to_string()),
            Some(s) if s.starts_with('-') => return Err(format!("unknown option {s}\n{USAGE}")),
            _ if constraints.is_none() => constraints = Some(PathBuf::from(arg)),
            _ => return Err(format!("unexpected argument {arg:?}\n{USAGE}")),
        }
    }
    let constraints = constraints.ok_or_else(|| USAGE.to_string())?;
    let points = match (points, out) {
        (Some(p), Some(o)) => Some((p, o)),
        (None, None) => None,
        _ => return Err(format!("--points and --out go together\n{USAGE}")),
    };
    Ok(Args { constraints, points, order, tolerance, direct })
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(args) => args,
        Err(message) => {
            eprintln!("ferreus-peer: {message}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("ferreus-peer: {message}");
            ExitCode::FAILURE
        }
    }
}

/// Collects the crate's progress messages: solver iterations and removed duplicates.
#[derive(Debug, Default)]
struct Progress {
    iterations: Mutex<Vec<f64>>,
    duplicates_removed: Mutex<usize>,
}

impl ProgressSink for Progress {
    fn emit(&self, msg: ProgressMsg) {
        match msg {
            ProgressMsg::SolverIteration { residual, .. } => {
                if let Ok(mut v) = self.iterations.lock() {
                    v.push(residual);
                }
            }
            ProgressMsg::DuplicatesRemoved { num_duplicates } => {
                if let Ok(mut d) = self.duplicates_removed.lock() {
                    *d += num_duplicates;
                }
            }
            _ => {}
        }
    }
}

/// Runs `f`, turning a panic inside the crate into an error that says what was being done.
fn guarded<T>(what: &str, f: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("(no message)");
        format!("ferreus_rbf panicked while {what}: {message}")
    })
}

/// A number as JSON (non-finite numbers as null).
fn num(x: f64) -> String {
    if x.is_finite() { format!("{x:e}") } else { "null".to_string() }
}

/// A path as a JSON string.
fn string(path: &std::path::Path) -> String {
    let mut s = String::from('"');
    for c in path.display().to_string().chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            c if (c as u32) < 0x20 => s.push_str(&format!("\\u{:04x}", c as u32)),
            c => s.push(c),
        }
    }
    s.push('"');
    s
}

fn run(args: &Args) -> Result<(), String> {
    let input = read_constraints(&args.constraints)?;
    let targets = match &args.points {
        Some((points, _)) => Some(read_points(points, input.dim)?),
        None => None,
    };
    let n = input.values.len();
    let (lo, hi) = input
        .values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &h| (lo.min(h), hi.max(h)));
    let range = hi - lo;
    // All values equal: report absolute residuals instead.
    let scale = if range > 0.0 { range } else { 1.0 };
    println!(
        "{{\"event\":\"input\",\"file\":{},\"constraints\":{n},\"dim\":{},\"value_range\":{},\
         \"residual_scale\":{}}}",
        string(&args.constraints),
        input.dim,
        num(range),
        num(scale)
    );

    let kernel = RBFKernelType::ThinPlateSpline;
    let mut fmm = FmmParams::new_defaults(kernel);
    if let Some(order) = args.order {
        fmm.interpolation_order = order;
        fmm.epsilon = 10f64.powi(-(order as i32));
    }
    let settings = InterpolantSettings::builder(kernel)
        .drift(Drift::Linear)
        .fitting_accuracy(FittingAccuracy {
            tolerance: args.tolerance,
            tolerance_type: FittingAccuracyType::Relative,
        })
        .build();
    let params = Params::builder(kernel).fmm_params(fmm).build();
    let progress = Arc::new(Progress::default());
    let sink: Arc<dyn ProgressSink> = progress.clone();

    let points = Mat::from_fn(n, input.dim, |i, j| input.positions[i * input.dim + j]);
    let values = Mat::from_fn(n, 1, |i, _| input.values[i]);
    let start = Instant::now();
    let rbf = guarded("solving", || {
        RBFInterpolator::builder(points.clone(), values, settings)
            .params(params)
            .progress_callback(sink)
            .build()
    })?;
    let solve_s = start.elapsed().as_secs_f64();
    let residuals = progress.iterations.lock().map(|v| v.clone()).unwrap_or_default();
    let dropped = progress.duplicates_removed.lock().map(|d| *d).unwrap_or(0);
    let kept = rbf.points.nrows();
    println!(
        "{{\"event\":\"solve\",\"seconds\":{},\"method\":\"{}\",\"fmm_order\":{},\
         \"fmm_epsilon\":{},\"tolerance\":{},\"iterations\":{},\"last_relative_residual\":{},\
         \"duplicates_dropped_by_ferreus\":{dropped},\"centres\":{kept}}}",
        num(solve_s),
        if n < rbf.params.naive_solve_threshold { "direct" } else { "fgmres" },
        fmm.interpolation_order,
        num(fmm.epsilon),
        num(args.tolerance),
        residuals.len(),
        residuals.last().map_or("null".to_string(), |&r| num(r)),
    );

    // The residual as the crate evaluates it, at every constraint (also those it dropped).
    let start = Instant::now();
    let fitted = guarded("evaluating at the constraints", || rbf.evaluate(points.as_ref()))?;
    let fitted: Vec<f64> = (0..n).map(|i| fitted[(i, 0)]).collect();
    let seconds = start.elapsed().as_secs_f64();
    let max_residual = max_abs_diff(&fitted, &input.values);
    println!(
        "{{\"event\":\"residual\",\"source\":\"ferreus\",\"max_abs\":{},\"max_rel_range\":{},\
         \"seconds\":{}}}",
        num(max_residual),
        num(max_residual / scale),
        num(seconds)
    );

    if args.direct {
        let start = Instant::now();
        let direct = direct_values(&rbf, input.dim, &input.positions)?;
        let seconds = start.elapsed().as_secs_f64();
        let max_residual = max_abs_diff(&direct, &input.values);
        let fmm_error = max_abs_diff(&direct, &fitted);
        println!(
            "{{\"event\":\"residual\",\"source\":\"direct\",\"max_abs\":{},\"max_rel_range\":{},\
             \"ferreus_vs_direct_rel_range\":{},\"seconds\":{}}}",
            num(max_residual),
            num(max_residual / scale),
            num(fmm_error / scale),
            num(seconds)
        );
    }

    if let (Some(targets), Some((points_path, out))) = (targets, &args.points) {
        let m = targets.len() / input.dim;
        let targets = Mat::from_fn(m, input.dim, |i, j| targets[i * input.dim + j]);
        let start = Instant::now();
        let values = guarded("evaluating at the points", || rbf.evaluate(targets.as_ref()))?;
        let seconds = start.elapsed().as_secs_f64();
        let values: Vec<f64> = (0..m).map(|i| values[(i, 0)]).collect();
        write_values(out, &values)?;
        println!(
            "{{\"event\":\"eval\",\"points\":{m},\"file\":{},\"seconds\":{},\"out\":{}}}",
            string(points_path),
            num(seconds),
            string(out)
        );
    }
    Ok(())
}

/// The largest `|a_i - b_i|` (NaN if any difference is NaN).
fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, |m, d| if d > m || d.is_nan() { d } else { m })
}

/// The fitted function at `positions` (`dim` coordinates each), from the crate's weights and
/// polynomial coefficients by an exact direct sum in f64 (compensated), on all cores.
fn direct_values(rbf: &RBFInterpolator, dim: usize, positions: &[f64]) -> Result<Vec<f64>, String> {
    let centres: Vec<f64> =
        (0..rbf.points.nrows()).flat_map(|i| (0..dim).map(move |j| rbf.points[(i, j)])).collect();
    let weights = &rbf.coefficients.point_coefficients;
    if weights.nrows() != rbf.points.nrows() || weights.ncols() != 1 {
        return Err(format!(
            "unexpected weights: {} x {} for {} centres",
            weights.nrows(),
            weights.ncols(),
            rbf.points.nrows()
        ));
    }
    let weights: Vec<f64> = (0..weights.nrows()).map(|i| weights[(i, 0)]).collect();
    let poly = rbf.coefficients.poly_coefficients.as_ref().ok_or("no polynomial coefficients")?;
    if poly.nrows() != dim + 1 || poly.ncols() != 1 {
        return Err(format!("unexpected polynomial: {} x {}", poly.nrows(), poly.ncols()));
    }
    let poly: Vec<f64> = (0..=dim).map(|i| poly[(i, 0)]).collect();
    // The crate's polynomial scaling: the centres' bounding box mapped onto [-1, 1]^dim.
    let (mut centre, mut half) = (vec![0.0; dim], vec![1.0; dim]);
    for d in 0..dim {
        let (lo, hi) = centres
            .chunks_exact(dim)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p[d]), a.1.max(p[d])));
        centre[d] = (hi + lo) / 2.0;
        half[d] = if hi > lo { (hi - lo) / 2.0 } else { 1.0 };
    }
    let value = |x: &[f64]| -> f64 {
        // Neumaier's compensated sum.
        let (mut sum, mut carry) = (0.0f64, 0.0f64);
        let mut add = |term: f64| {
            let t = sum + term;
            carry += if sum.abs() >= term.abs() { (sum - t) + term } else { (term - t) + sum };
            sum = t;
        };
        for (c, w) in centres.chunks_exact(dim).zip(&weights) {
            let r2: f64 = x.iter().zip(c).map(|(a, b)| (a - b) * (a - b)).sum();
            if r2 > 0.0 {
                add(w * 0.5 * r2 * r2.ln()); // r^2 ln r = r^2 ln(r^2) / 2
            }
        }
        add(poly[0]);
        for d in 0..dim {
            add(poly[d + 1] * (x[d] - centre[d]) / half[d]);
        }
        sum + carry
    };
    let n = positions.len() / dim;
    let mut out = vec![0.0; n];
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
    let chunk = n.div_ceil(threads).max(1);
    std::thread::scope(|s| {
        for (block, targets) in out.chunks_mut(chunk).zip(positions.chunks(chunk * dim)) {
            let value = &value;
            s.spawn(move || {
                for (o, x) in block.iter_mut().zip(targets.chunks_exact(dim)) {
                    *o = value(x);
                }
            });
        }
    });
    Ok(out)
}
