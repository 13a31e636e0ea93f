//! `implicitize render`: a picture of a model or a mesh, the paper's figures 3, 4 and 5.
//!
//! A model is drawn from its function ([`render_field`]), a mesh by the rasterizer
//! ([`render_mesh`]), both through one camera framed on the shape's bounds, so `--compare`
//! puts a mesh and an implicit surface side by side in the same frame (mesh left, implicit
//! right, as figures 4 and 5). `--color rreg` colours a mesh's goal surface by its radius of
//! regularity (figure 3). The pictures of a fit's iterations (figure 1) are drawn by
//! [`snapshot`], which `fit --snapshots` calls.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use implicitize::fit::Goal;
use implicitize::fit::RegularityOptions;
use implicitize::memory::Estimate;
use implicitize::model::Model;
use implicitize::pipeline::{MeshFitOptions, Prepared};
use implicitize::render::{
    Camera, Coloring, Image, March, Shading, grid_box, march_bounds, render_field, render_mesh,
};
use implicitize::{Aabb, Field, grid::Grid, mesh::Mesh};

use super::common::{GridArgs, Progress, check_outputs, memory_limit, read_mesh};
use crate::figure3::figure3;

/// How the surface is coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ColorArg {
    /// A light material lit from the upper left.
    Plain,
    /// The outward normal as a colour, unlit.
    Normals,
    /// The goal surface of a mesh coloured by its radius of regularity: red where small, green
    /// where large (paper figure 3).
    Rreg,
}

/// Arguments of `implicitize render`.
#[derive(Debug, Args)]
pub struct RenderCommand {
    /// A model (.json, from `fit` or `solve`) or a mesh (.obj, .ply, .stl or .off).
    pub input: PathBuf,
    /// The picture to write (PNG).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The picture's width and height in pixels (each half's, with --compare).
    #[arg(long, num_args = 2, value_names = ["W", "H"], default_values_t = Camera::DEFAULT_SIZE)]
    pub size: Vec<usize>,
    /// The view direction in degrees: azimuth about the vertical +y axis (0 looks from +z,
    /// 90 from +x) and elevation above the horizon.
    #[arg(long, num_args = 2, value_names = ["AZIMUTH", "ELEVATION"],
          allow_negative_numbers = true, default_values_t = Camera::DEFAULT_VIEW)]
    pub view: Vec<f64>,
    /// How the surface is coloured.
    #[arg(long, value_enum, default_value_t = ColorArg::Plain)]
    pub color: ColorArg,
    /// Draw this mesh on the left and INPUT on the right, through one camera framed on both.
    #[arg(long, value_name = "MESH")]
    pub compare: Option<PathBuf>,
    /// The grid the goal is computed on for --color rreg.
    #[command(flatten, next_help_heading = "Goal grid, for --color rreg")]
    pub grid: GridArgs,
}

/// What is drawn: a model's function or a mesh's triangles.
enum Shape {
    Model(Box<Model>),
    Mesh(Mesh),
}

impl Shape {
    /// Reads a mesh (by its extension: .obj, .ply, .stl or .off) or else a model file (binary
    /// or JSON, whatever its name).
    fn read(path: &Path, progress: Progress) -> anyhow::Result<Shape> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if let Some("obj" | "ply" | "stl" | "off") = ext.as_deref() {
            return Ok(Shape::Mesh(read_mesh(path, progress)?));
        }
        let model = Model::load(path)?;
        if model.implicit().is_some_and(|f| f.dim() == 2) {
            bail!("{}: a 2D model has no surface to draw in 3D", path.display());
        }
        Ok(Shape::Model(Box::new(model)))
    }

    /// The box the camera frames: the shape's bounds (for a fitted model, those of the mesh it
    /// was fitted to), so a mesh and its fit are framed alike.
    fn bounds(&self, path: &Path) -> anyhow::Result<Aabb> {
        match self {
            Shape::Model(model) => Ok(model.bounds()),
            Shape::Mesh(mesh) => mesh
                .bounds()
                .with_context(|| format!("{}: the mesh has no triangles", path.display())),
        }
    }
}

/// The smallest box holding both.
fn union(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb { min: a.min.min(b.min), max: a.max.max(b.max) }
}

/// Runs `implicitize render`.
pub fn run(args: &RenderCommand, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output], &[])?;
    let (width, height) = size(&args.size)?;
    let panels = if args.compare.is_some() { 2 } else { 1 };
    Estimate::picture(width * panels, height)
        .check(memory_limit().bytes(), || None)
        .with_context(|| args.output.display().to_string())?;
    let [azimuth, elevation] = view(&args.view)?;
    let shape = Shape::read(&args.input, progress)?;
    let mut bounds = shape.bounds(&args.input)?;
    let compare = match &args.compare {
        Some(path) => {
            if args.color == ColorArg::Rreg {
                bail!(
                    "--color rreg colours one mesh's goal surface; it does not go with --compare"
                );
            }
            let mesh = read_mesh(path, progress)?;
            let mesh_bounds = mesh
                .bounds()
                .with_context(|| format!("{}: the mesh has no triangles", path.display()))?;
            bounds = union(&bounds, &mesh_bounds);
            Some(mesh)
        }
        None => None,
    };
    let camera = Camera::framing(&bounds, azimuth, elevation, width, height)?;
    let mut picture = draw(&shape, &args.input, &camera, args, progress)?;
    if let Some(mesh) = compare {
        let left = render_mesh(&mesh, &camera, coloring(args.color), Shading::Smooth);
        picture = Image::side_by_side(&[left, picture]);
    }
    picture.save_png(&args.output)?;
    progress.line(format!(
        "wrote {} ({} x {})",
        args.output.display(),
        picture.width,
        picture.height
    ));
    Ok(())
}

/// The picture of INPUT through `camera`.
fn draw(
    shape: &Shape,
    path: &Path,
    camera: &Camera,
    args: &RenderCommand,
    progress: Progress,
) -> anyhow::Result<Image> {
    match (shape, args.color) {
        (Shape::Model(_), ColorArg::Rreg) => bail!(
            "{}: --color rreg needs a mesh: it colours the goal surface of a voxelized mesh",
            path.display()
        ),
        (Shape::Model(model), color) => {
            progress.stage(format!("ray marching {}", path.display()));
            let bounds = march_bounds(model);
            Ok(render_field(model.as_ref(), &bounds, camera, coloring(color), March::default())
                .with_context(|| path.display().to_string())?)
        }
        (Shape::Mesh(mesh), ColorArg::Rreg) => {
            let regularity = RegularityOptions::default();
            let goal = goal_of(mesh, path, &args.grid, &regularity, progress)?;
            progress.stage("radii of regularity");
            Ok(figure3(&goal, &regularity, camera)?)
        }
        (Shape::Mesh(mesh), color) => {
            Ok(render_mesh(mesh, camera, coloring(color), Shading::Smooth))
        }
    }
}

/// The library's colouring for a plain or normals picture.
fn coloring(color: ColorArg) -> Coloring {
    match color {
        ColorArg::Normals => Coloring::Normals,
        ColorArg::Plain | ColorArg::Rreg => Coloring::Plain,
    }
}

/// Checks `--size`.
fn size(size: &[usize]) -> anyhow::Result<(usize, usize)> {
    match *size {
        [w, h] if (1..=Camera::MAX_SIDE).contains(&w) && (1..=Camera::MAX_SIDE).contains(&h) => {
            Ok((w, h))
        }
        _ => bail!(
            "--size {}: each side must be 1 to {} pixels",
            size.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(" "),
            Camera::MAX_SIDE
        ),
    }
}

/// Checks `--view`.
fn view(view: &[f64]) -> anyhow::Result<[f64; 2]> {
    match *view {
        [azimuth, elevation] if azimuth.is_finite() && elevation.is_finite() => {
            Ok([azimuth, elevation])
        }
        _ => bail!(
            "--view {}: the azimuth and elevation must be finite numbers of degrees",
            view.iter().map(|a| a.to_string()).collect::<Vec<_>>().join(" ")
        ),
    }
}

/// The goal of `mesh` on the grid of `--resolution` or `--dims`, its radii of regularity
/// measured as `regularity` says (paper 4.3).
fn goal_of(
    mesh: &Mesh,
    path: &Path,
    grid_args: &GridArgs,
    regularity: &RegularityOptions,
    progress: Progress,
) -> anyhow::Result<Goal> {
    let source = path.display().to_string();
    progress.stage(format!("voxelizing {source}"));
    let mut options = MeshFitOptions::default();
    options.resolution = grid_args.resolution();
    options.fit.regularity = *regularity;
    options.memory_limit = memory_limit();
    Ok(Prepared::new(mesh, &source, &options)?.into_goal())
}

/// The picture of one fit iteration's implicit surface (paper figure 1): `field` marched over
/// `march` and seen from the default view framed on `frame`.
fn snapshot<F: Field + ?Sized>(
    field: &F,
    frame: &Aabb,
    march: &Aabb,
    (width, height): (usize, usize),
) -> implicitize::Result<Image> {
    let [azimuth, elevation] = Camera::DEFAULT_VIEW;
    let camera = Camera::framing(frame, azimuth, elevation, width, height)?;
    render_field(field, march, &camera, Coloring::Plain, March::default())
}

/// The mesh on the left and the model on the right, through one camera framed on both, the
/// default view (paper figures 4 and 5). Written by `demo`.
pub fn compare_picture(
    mesh: &Mesh,
    model: &Model,
    width: usize,
    height: usize,
) -> implicitize::Result<Image> {
    let bounds = mesh.bounds().map_or(model.bounds(), |b| union(&b, &model.bounds()));
    let [azimuth, elevation] = Camera::DEFAULT_VIEW;
    let camera = Camera::framing(&bounds, azimuth, elevation, width, height)?;
    let left = render_mesh(mesh, &camera, Coloring::Plain, Shading::Smooth);
    let right =
        render_field(model, &march_bounds(model), &camera, Coloring::Plain, March::default())?;
    Ok(Image::side_by_side(&[left, right]))
}

/// The size of one iteration's picture in a fit's snapshots.
const SNAPSHOT_SIZE: (usize, usize) = (240, 180);

/// The pictures of a fit's iterations (`fit --snapshots DIR`, paper figure 1): each
/// iteration's surface to `DIR/iteration-NN.png` as it comes, then all of them side by side to
/// `DIR/strip.png`.
pub struct Snapshots<'a> {
    dir: &'a Path,
    frame: Aabb,
    march: Aabb,
    pictures: Vec<Image>,
    /// The first failure, reported once the fit is done.
    error: Option<anyhow::Error>,
}

impl<'a> Snapshots<'a> {
    /// Snapshots into `dir` (made beforehand by `output::prepare_folder`) of surfaces fitted on
    /// `grid`, framed on `bounds` (the mesh's) and marched through the grid's box.
    pub fn new(dir: &'a Path, bounds: Aabb, grid: &Grid) -> Snapshots<'a> {
        let march = grid_box(grid);
        Snapshots { dir, frame: bounds, march, pictures: Vec::new(), error: None }
    }

    /// Draws iteration `iteration`'s surface and writes its picture.
    pub fn take<F: Field + ?Sized>(&mut self, iteration: usize, field: &F) {
        if self.error.is_some() {
            return;
        }
        let path = self.dir.join(format!("iteration-{iteration:02}.png"));
        match snapshot(field, &self.frame, &self.march, SNAPSHOT_SIZE).and_then(|p| {
            p.save_png(&path)?;
            Ok(p)
        }) {
            Ok(picture) => self.pictures.push(picture),
            Err(e) => self.error = Some(e.into()),
        }
    }

    /// Writes the strip of every picture taken, or reports the first failure.
    pub fn finish(self) -> anyhow::Result<()> {
        if let Some(e) = self.error {
            return Err(e);
        }
        Image::side_by_side(&self.pictures).save_png(&self.dir.join("strip.png"))?;
        Ok(())
    }
}
