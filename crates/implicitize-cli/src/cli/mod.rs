//! The command-line front end: parse the arguments, call the library, print.
//!
//! Each subcommand lives in its own file. Errors print as one line on stderr and the process
//! exits with status 1; stdout carries only machine-readable output.

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use implicitize::FrontEnd;
use implicitize::pipeline::VolumeKind;

mod batch;
mod common;
mod csg;
mod distance;
mod eval;
mod export;
mod fit;
mod fit2d;
mod morph;
mod polygonize;
mod render;
mod sample;
mod settings;
mod solve;
mod view;
mod volume;

/// Turn polygon meshes into compact, smooth variational implicit surfaces, and use them.
#[derive(Debug, Parser)]
#[command(name = "implicitize", version, about, long_about = None)]
pub struct Cli {
    /// Print no progress on stderr.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// Refuse work estimated to need more memory than this (as 512M, 1G, 1.5G; units are
    /// powers of 1024) [default: the machine's available memory, within `ulimit -v`].
    #[arg(long, global = true, value_name = "SIZE", value_parser = parse_size)]
    pub memory_limit: Option<u64>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fit the built-in triceratops and write the model, report and surface to a folder.
    Demo(fit::DemoCommand),
    /// Fit a variational implicit surface to a mesh (paper 5).
    Fit(fit::FitCommand),
    /// Fit many meshes in parallel into one folder, with a manifest of the outcomes.
    Batch(batch::BatchCommand),
    /// Fit a 2D implicit curve to the shapes of a PNG image, and draw the paper's figure 2.
    Fit2d(fit2d::Fit2dCommand),
    /// Polygonize a model's zero set into a mesh file.
    Mesh(polygonize::MeshCommand),
    /// Voxelize a mesh: densities in [0, 1], 1 inside (paper 4.1).
    Voxelize(volume::VolumeArgs),
    /// The signed distance of a mesh's voxelization, in voxels, inside positive (paper 4.2);
    /// with --exact, the exact distance to the mesh at the voxel centres, in mesh units.
    Sdf(volume::SdfArgs),
    /// Solve for the implicit function through constraints in a CSV file, and save the model.
    Solve(solve::SolveArgs),
    /// Evaluate a model at points (inside positive, outside negative).
    Eval(eval::EvalArgs),
    /// The exact distance from points to a mesh, inside positive, and the closest points.
    Distance(distance::DistanceArgs),
    /// Points near a mesh's surface and uniform around it with their exact signed distances
    /// (inside positive), and DeepSDF's layout, in an .npz.
    Sample(sample::SampleArgs),
    /// Draw a model or a mesh to a PNG, or the two side by side (paper figures 1, 3-5).
    Render(render::RenderCommand),
    /// Combine two models: union, intersection or difference, sharp or blended (paper 1).
    Csg(csg::CsgArgs),
    /// Morph one model into another: a mesh per frame and a picture strip (paper 1, 7).
    Morph(morph::MorphArgs),
    /// Write a page that draws a model in a browser (WebGL2, offline), beside its mesh.
    View(view::ViewArgs),
    /// Write a model's function and gradient as GLSL or WGSL source.
    Export(export::ExportArgs),
}

/// Parses the command line and runs it.
pub fn run() -> ExitCode {
    let matches = Cli::command().get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let progress = common::Progress::new(cli.quiet);
    common::set_memory_limit(cli.memory_limit);
    let result = check_isa().and_then(|()| dispatch(&cli.command, progress));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let message = implicitize::worded(&format!("{e:#}"), FrontEnd::Cli);
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

/// Parses `--memory-limit`.
fn parse_size(text: &str) -> Result<u64, String> {
    implicitize::memory::parse_size(text).map_err(|e| e.to_string())
}

/// Refuses an `IMPLICITIZE_ISA` that names no instruction set or one this CPU lacks.
fn check_isa() -> anyhow::Result<()> {
    implicitize::rbf::Isa::from_env()?;
    Ok(())
}

/// Runs the subcommand.
fn dispatch(command: &Command, progress: common::Progress) -> anyhow::Result<()> {
    match command {
        Command::Demo(args) => fit::demo(args, progress),
        Command::Fit(args) => fit::run(args, progress),
        Command::Batch(args) => batch::run(args, progress),
        Command::Fit2d(args) => fit2d::run(args, progress),
        Command::Mesh(args) => polygonize::run(args, progress),
        Command::Voxelize(args) => volume::run(args, VolumeKind::Density, None, progress),
        Command::Sdf(args) => volume::run_sdf(args, progress),
        Command::Solve(args) => solve::run(args, progress),
        Command::Eval(args) => eval::run(args, progress),
        Command::Distance(args) => distance::run(args, progress),
        Command::Sample(args) => sample::run(args, progress),
        Command::Render(args) => render::run(args, progress),
        Command::Csg(args) => csg::run(args, progress),
        Command::Morph(args) => morph::run(args, progress),
        Command::View(args) => view::run(args, progress),
        Command::Export(args) => export::run(args, progress),
    }
}
