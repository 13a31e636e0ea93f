//! `implicitize voxelize` and `implicitize sdf`: the goal volumes of paper 4.1 and 4.2, and
//! the exact signed distance at the voxel centres (`sdf --exact`).

use std::path::PathBuf;

use clap::Args;
use implicitize::pipeline::{self, VolumeKind, VolumeOptions};

use super::common::{GridArgs, Progress, check_outputs, memory_limit, read_mesh, warn_if_open};

/// Arguments of `voxelize` and `sdf`.
#[derive(Debug, Args)]
pub struct VolumeArgs {
    /// The mesh (OBJ, PLY, STL or OFF).
    pub mesh: PathBuf,
    #[command(flatten)]
    pub grid: GridArgs,
    /// The output volume (.npy, float32, indexed [i, j, k]); the grid is written beside it as
    /// .json: {"dims", "origin", "voxel_size"}, voxel (i, j, k) centred at origin + h (i, j, k),
    /// and for `sdf` "units" ("voxels", or "mesh" with --exact) and "band" when given.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Arguments of `sdf`.
#[derive(Debug, Args)]
pub struct SdfArgs {
    #[command(flatten)]
    pub volume: VolumeArgs,
    /// The exact distance from each voxel centre to the mesh's triangles, in mesh units (f64,
    /// stored as float32), with the voxelization's sign, instead of the distance between voxel
    /// centres in voxels.
    #[arg(long)]
    pub exact: bool,
    /// With --exact: only voxels within K voxels of the surface are measured exactly; every
    /// value is clamped to plus or minus K voxels (in mesh units).
    #[arg(long, value_name = "K", requires = "exact")]
    pub band: Option<f64>,
}

/// `sdf`: the voxel signed distance, or the exact one with `--exact`.
pub fn run_sdf(args: &SdfArgs, progress: Progress) -> anyhow::Result<()> {
    let kind =
        if args.exact { VolumeKind::ExactSignedDistance } else { VolumeKind::SignedDistance };
    run(&args.volume, kind, args.band, progress)
}

/// Voxelizes the mesh and writes the densities or a signed distance (`band`: see
/// [`VolumeOptions::band`]).
pub fn run(
    args: &VolumeArgs,
    kind: VolumeKind,
    band: Option<f64>,
    progress: Progress,
) -> anyhow::Result<()> {
    check_outputs(&[&args.output, &args.output.with_extension("json")], &[])?;
    let mesh = read_mesh(&args.mesh, progress)?;
    progress.stage(format!("voxelizing {}", args.mesh.display()));
    let mut options = VolumeOptions::default();
    options.resolution = args.grid.resolution();
    options.band = band;
    options.memory_limit = memory_limit();
    let source = args.mesh.display().to_string();
    let (volume, inside) = pipeline::volume(&mesh, &source, kind, &options)?;
    warn_if_open(&source, &inside.ambiguity);
    volume.save_npy(&args.output, &options.values(kind))?;
    let grid = volume.grid;
    progress.line(format!(
        "wrote {} ({} x {} x {}, voxel size {})",
        args.output.display(),
        grid.dims[0],
        grid.dims[1],
        grid.dims[2],
        grid.voxel_size
    ));
    Ok(())
}
