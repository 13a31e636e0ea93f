//! `implicitize voxelize` and `implicitize sdf`: the goal volumes of paper 4.1 and 4.2.

use std::path::PathBuf;

use clap::Args;
use implicitize::memory::Estimate;
use implicitize::{pipeline, voxelize};

use super::common::{GridArgs, Progress, check_outputs, read_mesh, warn_if_open};

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

/// Which volume to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VolumeKind {
    /// Densities in [0, 1], 1 inside.
    Density,
    /// Signed Euclidean distance in voxels, inside positive.
    SignedDistance,
}

/// Voxelizes the mesh and writes the densities or the signed distance.
pub fn run(args: &VolumeArgs, kind: VolumeKind, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output, &args.output.with_extension("json")], &[])?;
    let mesh = read_mesh(&args.mesh, progress)?;
    let grid = args.grid.checked_grid(&mesh, &args.mesh, Estimate::volume)?;
    progress.stage(format!("voxelizing on {} x {} x {}", grid.dims[0], grid.dims[1], grid.dims[2]));
    let options = voxelize::VoxelizeOptions::default();
    let source = args.mesh.display().to_string();
    let (volume, ambiguity) = match kind {
        VolumeKind::Density => voxelize::voxelize_reporting(&mesh, &grid, &options)?,
        VolumeKind::SignedDistance => {
            pipeline::signed_distance_reporting(&mesh, args.grid.resolution(), &options, &source)?
        }
    };
    warn_if_open(&source, &ambiguity);
    volume.save_npy(&args.output)?;
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
