//! `implicitize distance`: the exact distance from points to a mesh, signed by the winding
//! number, and the closest points.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::common::{Progress, check_outputs, memory_limit, read_mesh};
use super::eval::read_points;
use clap::Args;
use implicitize::DVec3;
use implicitize::npy;
use implicitize::pipeline::{self, DistanceOptions};

/// Arguments of `distance`.
#[derive(Debug, Args)]
pub struct DistanceArgs {
    /// The mesh file (OBJ, PLY, STL or OFF).
    pub mesh: PathBuf,
    /// The points: a .npy array of N x 3 float32 or float64 values, or a CSV file with a
    /// header line `x,y,z`.
    #[arg(long)]
    pub points: PathBuf,
    /// The distances to write: a float64 .npy array of length N, in the mesh's units,
    /// positive inside and negative outside (inside where the winding number is at least 1/2).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write each point's closest point of the surface: a float64 .npy array of N x 3.
    #[arg(long)]
    pub closest: Option<PathBuf>,
    /// Write unsigned distances (and skip the winding number).
    #[arg(long)]
    pub unsigned: bool,
}

/// Reads the mesh and the points, measures, and writes the distances (and closest points).
pub fn run(args: &DistanceArgs, progress: Progress) -> anyhow::Result<()> {
    let outputs: Vec<&Path> = [Some(&args.output), args.closest.as_ref()]
        .into_iter()
        .flatten()
        .map(|p| p.as_path())
        .collect();
    check_outputs(&outputs, &[])?;
    let (points, columns) = read_points(&args.points)?;
    if columns != 3 {
        anyhow::bail!("{}: {columns} coordinates per point, not 3", args.points.display());
    }
    let points: Vec<DVec3> = points.chunks_exact(3).map(DVec3::from_slice).collect();
    let mesh = read_mesh(&args.mesh, progress)?;
    let mut options = DistanceOptions::default();
    options.signed = !args.unsigned;
    options.memory_limit = memory_limit();
    let source = args.mesh.display().to_string();
    let start = Instant::now();
    let found = pipeline::distance(&mesh, &source, &points, &options)?;
    let seconds = start.elapsed().as_secs_f64();
    npy::write(&args.output, &[found.values.len() as u64], &found.values)?;
    if let Some(closest) = &args.closest {
        let flat: Vec<f64> = found.nearest.iter().flat_map(|n| n.point.to_array()).collect();
        npy::write(closest, &[found.nearest.len() as u64, 3], &flat)?;
    }
    progress.line(format!(
        "measured {} points in {seconds:.3} s; wrote {}",
        found.values.len(),
        args.output.display()
    ));
    Ok(())
}
