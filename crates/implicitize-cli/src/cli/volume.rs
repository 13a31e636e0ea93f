//! `implicitize voxelize` and `implicitize sdf`: the goal volumes of paper 4.1 and 4.2.

use std::path::PathBuf;

use clap::Args;
use implicitize::pipeline::{self, VolumeOptions};

use super::common::{GridArgs, Progress, check_outputs, memory_limit, read_mesh, warn_if_open};

/// Arguments of `voxelize` and `sdf`.
#[derive(Debug, Args)]
pub struct VolumeArgs {
    /// The mesh (OBJ, PLY, STL or OFF).
    pub mesh: PathBuf,
    #[command(flatten)]
    pub grid: GridArgs,
    /// The output volume (.npy, float32, indexed [i, j, k]); the grid is written beside it as
    /// .json: {"dims", "origin", "voxel_size"}, voxel (i, j, k) centred at origin + h (i, j, k).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Voxelizes the mesh and writes the densities or the signed distance.
pub fn run(
    args: &VolumeArgs,
    kind: pipeline::VolumeKind,
    progress: Progress,
) -> anyhow::Result<()> {
    check_outputs(&[&args.output, &args.output.with_extension("json")], &[])?;
    let mesh = read_mesh(&args.mesh, progress)?;
    progress.stage(format!("voxelizing {}", args.mesh.display()));
    let mut options = VolumeOptions::default();
    options.resolution = args.grid.resolution();
    options.memory_limit = memory_limit();
    let source = args.mesh.display().to_string();
    let (volume, inside) = pipeline::volume(&mesh, &source, kind, &options)?;
    warn_if_open(&source, &inside.ambiguity);
    volume.save_npy(&args.output)?;
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
