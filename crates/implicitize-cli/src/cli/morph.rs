//! `implicitize morph`: the frames of a morph between two models, as meshes and a picture strip.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use implicitize::memory::Estimate;
use implicitize::model::Model;
use implicitize::morph::{self, Method, Morph, MorphOptions};
use implicitize::render::{self, Camera, Coloring, Image, March};
use implicitize::{grid::Grid, grid::Resolution, mesh, output, polygonize};

use super::common::{Progress, check_memory};

/// The morph method, as typed on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum MethodArg {
    /// A linear blend of the two functions, each scaled to approximate a signed distance.
    Blend,
    /// Turk and O'Brien's shape transformation: one 4D variational function through both
    /// models' constraints, sliced in time.
    Variational,
}

/// Arguments of `implicitize morph`.
#[derive(Debug, Args)]
pub struct MorphArgs {
    /// The model at the start (binary or JSON).
    pub a: PathBuf,
    /// The model at the end (binary or JSON).
    pub b: PathBuf,
    /// The number of frames, the two ends included (at least 2).
    #[arg(long)]
    pub steps: usize,
    /// The folder for frame-000.ply, frame-001.ply, ... and strip.png (made if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// How the in-between shapes are made.
    #[arg(long, value_enum, default_value_t = MethodArg::Blend)]
    pub method: MethodArg,
    /// Move and uniformly scale B onto A's bounding box first.
    #[arg(long)]
    pub align: bool,
    /// The variational method's time between the two shapes, as a fraction of the largest side
    /// of their bounds: smaller keeps more detail in the in-between shapes.
    #[arg(long, default_value_t = 0.25)]
    pub time_scale: f64,
    /// Voxels along the longest axis of the polygonization grid (over both shapes' bounds).
    #[arg(long, default_value_t = 100)]
    pub resolution: usize,
    /// The width in pixels of each frame's picture in strip.png; 0 writes no strip.
    #[arg(long, default_value_t = 160)]
    pub strip_width: usize,
}

/// The view of the strip's pictures: azimuth and elevation in degrees.
const VIEW: (f64, f64) = (30.0, 20.0);

/// Builds the morph, polygonizes every frame and draws the strip.
pub fn run(args: &MorphArgs, progress: Progress) -> anyhow::Result<()> {
    let times = morph::frame_times(args.steps)?;
    output::prepare_folder(&args.output)?;
    let a = Model::load(&args.a)?;
    let b = Model::load(&args.b)?;
    let method = match args.method {
        MethodArg::Blend => Method::Blend,
        MethodArg::Variational => Method::Variational,
    };
    progress.stage("preparing the morph");
    let options = MorphOptions {
        method,
        align: args.align,
        time_scale: args.time_scale,
        ..MorphOptions::default()
    };
    let morph = Morph::new(&a, &b, &options)
        .with_context(|| format!("morphing {} into {}", args.a.display(), args.b.display()))?;
    let bounds = morph.bounds();
    let grid = Grid::around(&bounds, Resolution::LongestAxis(args.resolution))?;
    let strip = |grid: &Grid| {
        let width = args.strip_width.saturating_mul(times.len());
        Estimate::polygonize(grid.dims, false).plus(&Estimate::picture(width, args.strip_width))
    };
    check_memory(&strip(&grid), |n| {
        Some(strip(&Grid::around(&bounds, Resolution::LongestAxis(n)).ok()?).bytes)
    })
    .with_context(|| format!("morphing {} into {}", args.a.display(), args.b.display()))?;
    let camera = (args.strip_width > 0)
        .then(|| {
            Camera::framing(&bounds, VIEW.0, VIEW.1, args.strip_width, args.strip_width * 3 / 4)
        })
        .transpose()?;
    let mut pictures = Vec::new();
    for (i, &t) in times.iter().enumerate() {
        let frame = morph.frame(t);
        progress.stage(format!("frame {} of {}", i + 1, times.len()));
        let surface = polygonize::polygonize_field(&frame, &grid);
        let path = args.output.join(format!("frame-{i:03}.ply"));
        mesh::write(&path, &surface)?;
        progress.line(format!(
            "t = {t:.3}: wrote {} ({} triangles)",
            path.display(),
            surface.triangles.len()
        ));
        if let Some(camera) = &camera {
            pictures.push(render::render_field(
                &frame,
                &bounds,
                camera,
                Coloring::Plain,
                March::default(),
            )?);
        }
    }
    if !pictures.is_empty() {
        let path = args.output.join("strip.png");
        Image::side_by_side(&pictures).save_png(&path)?;
        progress.line(format!("wrote {}", path.display()));
    }
    Ok(())
}
