//! `implicitize mesh`: the zero set of a model as a triangle mesh.

use std::path::PathBuf;

use clap::Args;
use implicitize::memory::Estimate;
use implicitize::model::Model;
use implicitize::{Grid, Resolution, mesh, polygonize};

use super::common::{Progress, check_memory, check_outputs};

/// Arguments of `implicitize mesh`.
#[derive(Debug, Args)]
pub struct MeshCommand {
    /// The model file (JSON, from `fit`, `solve` or `csg`).
    pub model: PathBuf,
    /// The mesh to write: .obj, .ply (binary) or .stl (binary).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Voxels along the longest axis of the model's bounds, margins included.
    #[arg(long, default_value_t = 200)]
    pub resolution: usize,
    /// Evaluate the model at every voxel rather than follow its surface from its boundary
    /// constraints: slower, and also shows small or thin detached pieces far from them.
    #[arg(long)]
    pub dense: bool,
}

/// Polygonizes the model over its bounds and writes the mesh.
pub fn run(args: &MeshCommand, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[], &[&args.output])?;
    let model = Model::load(&args.model)?;
    let bounds = model.bounds();
    let grid = Grid::around(&bounds, Resolution::LongestAxis(args.resolution))?;
    check_memory(&Estimate::polygonize(grid.dims, args.dense), |n| {
        let grid = Grid::around(&bounds, Resolution::LongestAxis(n)).ok()?;
        Some(Estimate::polygonize(grid.dims, args.dense).bytes)
    })
    .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    progress
        .stage(format!("polygonizing on {} x {} x {}", grid.dims[0], grid.dims[1], grid.dims[2]));
    let surface = if args.dense {
        polygonize::polygonize_field_dense(&model, &grid)
    } else {
        polygonize::polygonize_field(&model, &grid)
    };
    mesh::write(&args.output, &surface)?;
    progress.line(format!(
        "wrote {}: {} triangles, {} vertices",
        args.output.display(),
        surface.triangles.len(),
        surface.vertices.len()
    ));
    Ok(())
}
