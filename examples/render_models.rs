//! Draws model files (fitted or composite) side by side with one camera, for the figures of
//! `scripts/morph-csg-figures.sh`.
//!
//! Usage: `render_models OUT.png WIDTH HEIGHT AZIMUTH ELEVATION MODEL.json...`
//!
//! The camera frames the union of the models' bounds from the given direction (degrees), and
//! each model is drawn from its function by `render::render_field` within its own bounds.

use std::path::Path;

use anyhow::Context;
use implicitize::Aabb;
use implicitize::model::Model;
use implicitize::render::{Camera, Coloring, Image, March, render_field};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let [_, out, width, height, azimuth, elevation, models @ ..] = args.as_slice() else {
        anyhow::bail!("usage: render_models OUT.png WIDTH HEIGHT AZIMUTH ELEVATION MODEL.json...");
    };
    anyhow::ensure!(!models.is_empty(), "no model files given");
    let models = models.iter().map(|m| Model::load(m.as_ref())).collect::<Result<Vec<_>, _>>()?;
    let all = models
        .iter()
        .map(Model::bounds)
        .reduce(|a, b| Aabb { min: a.min.min(b.min), max: a.max.max(b.max) });
    let all = all.context("no models")?;
    let camera = Camera::framing(
        &all,
        azimuth.parse()?,
        elevation.parse()?,
        width.parse()?,
        height.parse()?,
    )?;
    let march = March { cells: 256 };
    let pictures = models
        .iter()
        .map(|m| render_field(m, &m.bounds(), &camera, Coloring::Plain, march))
        .collect::<Result<Vec<Image>, _>>()?;
    Image::side_by_side(&pictures).save_png(Path::new(out))?;
    Ok(())
}
