//! `implicitize fit2d`: the iterative fit of paper 5 on a 2D goal shape read from a PNG image,
//! and the paper's figure 2 drawn from the run.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use implicitize::fit::{self, Goal};
use implicitize::goal2d::{self, ImageOptions};
use implicitize::memory::Estimate;
use implicitize::model::Model;
use implicitize::rbf::Implicit;

use super::common::{Progress, check_outputs, memory_limit, write_report};
use super::fit::LoopArgs;
use crate::figure2::{self, Snapshots};

/// Arguments of `implicitize fit2d`.
#[derive(Debug, Args)]
pub struct Fit2dCommand {
    /// The goal image (PNG; grey, RGB, RGBA or palette, 8 or 16 bits). Pixel (x, y) is the point
    /// (x, height - 1 - y) of the model, in pixels.
    pub image: PathBuf,
    /// The model file to write: the binary format, or JSON for a name ending in .json.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the fit report (JSON: the paper's Table 1 and 2 columns, in pixels).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Also draw the paper's figure 2 from the run (PNG, 3 x 2 panels).
    #[arg(long)]
    pub figure: Option<PathBuf>,
    /// Picture pixels per image pixel in the figure (default: panels at least 240 pixels).
    #[arg(long)]
    pub figure_scale: Option<usize>,
    /// Luminance in [0, 1] below which a pixel is inside (above which with --invert).
    #[arg(long, default_value_t = ImageOptions::default().threshold)]
    pub threshold: f32,
    /// Blur the image by a Gaussian of this standard deviation (pixels) before thresholding.
    #[arg(long, default_value_t = ImageOptions::default().blur)]
    pub blur: f64,
    /// Light pixels are inside instead of dark ones.
    #[arg(long)]
    pub invert: bool,
    #[command(flatten)]
    pub settings: LoopArgs,
}

/// The least side of a figure panel the default scale gives, in picture pixels.
const MIN_PANEL: usize = 240;

/// Runs `implicitize fit2d`.
pub fn run(args: &Fit2dCommand, progress: Progress) -> anyhow::Result<()> {
    let files: Vec<&Path> =
        [Some(args.output.as_path()), args.report.as_deref(), args.figure.as_deref()]
            .into_iter()
            .flatten()
            .collect();
    check_outputs(&files, &[])?;
    let image_options =
        ImageOptions { threshold: args.threshold, blur: args.blur, invert: args.invert };
    let (density, bounds) = goal2d::read_density(&args.image, &image_options)?;
    let grid = density.grid;
    Estimate::fit(grid.dims, 0)
        .check(memory_limit().bytes(), || None)
        .with_context(|| args.image.display().to_string())?;
    let figure_scale = args.figure_scale.unwrap_or_else(|| default_scale(grid.dims));
    if args.figure.is_some() {
        figure2::check(&grid, figure_scale).context("--figure-scale")?;
    }
    progress.line(format!(
        "{}: {} x {} pixels with margins",
        args.image.display(),
        grid.dims[0],
        grid.dims[1]
    ));
    let mut options = implicitize::fit::FitOptions::default();
    args.settings.apply(&mut options);
    let goal = Goal::from_density(density, &options.regularity);
    let mut early: Vec<Implicit> = Vec::new();
    let fitted = fit::fit(&goal, &options, |line, implicit| {
        progress.line(line.line());
        if args.figure.is_some() && early.len() < 4 {
            early.push(implicit.clone());
        }
    })?;
    let mut report = fitted.report;
    if let Some(path) = &args.figure {
        let (b, c) = figure2::early_iterations(report.iterations);
        let snapshots = Snapshots {
            early: &early[b.min(early.len()) - 1],
            next: &early[c.min(early.len()) - 1],
            last: &fitted.implicit,
        };
        figure2::draw(&goal, &snapshots, figure_scale)?.save_png(path)?;
    }
    let mut model = Model::from_implicit(fitted.implicit, bounds, Some(grid));
    model.save(&args.output)?;
    report.model_bytes = std::fs::metadata(&args.output).ok().map(|m| m.len());
    model.set_report(serde_json::to_value(&report)?);
    model.save(&args.output)?;
    if let Some(path) = &args.report {
        write_report(path, &report)?;
    }
    let name = args.image.file_stem().map_or("image".into(), |s| s.to_string_lossy().into_owned());
    progress.line(report.table(&name));
    Ok(())
}

/// The figure scale that makes each panel's longer side at least [`MIN_PANEL`] pixels.
fn default_scale(dims: [usize; 3]) -> usize {
    MIN_PANEL.div_ceil(dims[0].max(dims[1]).max(1)).max(1)
}
