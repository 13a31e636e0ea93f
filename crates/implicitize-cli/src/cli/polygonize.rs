//! `implicitize mesh`: the zero set of a model as a triangle mesh.

use std::path::PathBuf;

use clap::Args;
use implicitize::model::Model;
use implicitize::pipeline::{self, PolygonizeOptions};
use implicitize::{grid::Resolution, mesh};

use super::common::{Progress, check_outputs, memory_limit};

/// Arguments of `implicitize mesh`.
#[derive(Debug, Args)]
pub struct MeshCommand {
    /// The model file (binary or JSON, from `fit`, `solve` or `csg`).
    pub model: PathBuf,
    /// The mesh to write: .obj, .ply (binary) or .stl (binary).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Voxels along the longest axis of the model's bounds, margins included.
    #[arg(long, default_value_t = Resolution::DEFAULT_LONGEST_AXIS)]
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
    let mut options = PolygonizeOptions::default();
    options.resolution = Resolution::LongestAxis(args.resolution);
    options.dense = args.dense;
    options.memory_limit = memory_limit();
    progress.stage(format!("polygonizing {}", args.model.display()));
    let source = args.model.display().to_string();
    let surface = pipeline::polygonize(&model, &model.bounds(), &source, &options)?;
    mesh::write(&args.output, &surface)?;
    progress.line(format!(
        "wrote {}: {} triangles, {} vertices",
        args.output.display(),
        surface.triangles.len(),
        surface.vertices.len()
    ));
    Ok(())
}
