//! `implicitize sample`: points near a mesh's surface and uniform around it, with the exact
//! signed distance at each, in an `.npz` (the library's `sample` module says how they are
//! drawn).

use std::path::PathBuf;
use std::time::Instant;

use super::common::{Progress, check_outputs, memory_limit, read_mesh};
use clap::Args;
use implicitize::pipeline::{self, SampleOptions};

/// Arguments of `sample`.
#[derive(Debug, Args)]
pub struct SampleArgs {
    /// The mesh file (OBJ, PLY, STL or OFF).
    pub mesh: PathBuf,
    /// The number of points, near and uniform together.
    #[arg(short)]
    pub n: usize,
    /// The .npz to write: `points` (N x 3 float64), `sdf` (N float64, mesh units, positive
    /// inside) and DeepSDF's `pos` and `neg` (rows x, y, z, sdf as float32, negative inside;
    /// `pos` outside).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Standard deviations of the Gaussian noise moving surface points off the surface, as
    /// fractions of the bounding box's diagonal; the near points are split evenly among them.
    #[arg(long, value_delimiter = ',', num_args = 1.., value_name = "SIGMAS",
          default_values_t = SampleOptions::default().near_surface)]
    pub near_surface: Vec<f64>,
    /// The fraction of the points uniform in the bounding box padded by 10% of its size.
    #[arg(long, default_value_t = SampleOptions::default().uniform)]
    pub uniform: f64,
    /// Seed of the random choices (same seed, same samples).
    #[arg(long, default_value_t = SampleOptions::default().seed)]
    pub seed: u64,
}

/// Reads the mesh, draws and measures the samples, and writes them.
pub fn run(args: &SampleArgs, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output], &[])?;
    let mut options = SampleOptions::default();
    options.near_surface = args.near_surface.clone();
    options.uniform = args.uniform;
    options.seed = args.seed;
    options.memory_limit = memory_limit();
    options.check()?;
    let mesh = read_mesh(&args.mesh, progress)?;
    let source = args.mesh.display().to_string();
    let start = Instant::now();
    let samples = pipeline::sample(&mesh, &source, args.n, &options)?;
    let seconds = start.elapsed().as_secs_f64();
    samples.save_npz(&args.output)?;
    let near: usize = samples.near.iter().sum();
    let inside = samples.sdf.iter().filter(|&&s| s > 0.0).count();
    progress.line(format!(
        "sampled {} points ({near} near the surface, {} uniform; {inside} inside) in \
         {seconds:.3} s; wrote {}",
        samples.points.len(),
        samples.uniform,
        args.output.display()
    ));
    Ok(())
}
