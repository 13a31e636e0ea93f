//! `implicitize eval`: a model's values at points.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::common::{Progress, check_outputs};
use clap::Args;
use implicitize::{DVec3, Field, model::Model, npy, rbf};

/// Arguments of `eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// The model file (binary or JSON), as written by `solve` or `fit`.
    pub model: PathBuf,
    /// The points: a .npy array of N x 3 (N x 2 for a 2D model) float32 or float64 values, or a
    /// CSV file with a header line `x,y,z` (or `x,y`).
    #[arg(long)]
    pub points: PathBuf,
    /// The values to write: a float64 .npy array of length N, positive inside, negative outside.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// The points of a .npy (N x columns) or CSV file, flat, and their number of columns.
pub(super) fn read_points(path: &Path) -> anyhow::Result<(Vec<f64>, usize)> {
    let csv = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    Ok(if csv {
        let (columns, points) = rbf::read_points(path)?;
        (points, columns)
    } else {
        npy::read_rows(path)?
    })
}

/// Loads the model and the points, evaluates, and writes the values.
pub fn run(args: &EvalArgs, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output], &[])?;
    let model = Model::load(&args.model)?;
    let (points, columns) = read_points(&args.points)?;
    let dim = model.dim();
    if columns != dim {
        anyhow::bail!(
            "{}: {columns} coordinates per point, but {} is a {dim}D model",
            args.points.display(),
            args.model.display()
        );
    }
    let start = Instant::now();
    let values = match model.implicit() {
        Some(implicit) => implicit.values_flat(&points),
        None => model.values(
            &points
                .chunks_exact(dim)
                .map(|p| DVec3::new(p[0], p[1], p.get(2).copied().unwrap_or(0.0)))
                .collect::<Vec<_>>(),
        ),
    };
    let seconds = start.elapsed().as_secs_f64();
    npy::write(&args.output, &[values.len() as u64], &values)?;
    progress.line(format!(
        "evaluated {} points in {seconds:.3} s; wrote {}",
        values.len(),
        args.output.display()
    ));
    Ok(())
}
