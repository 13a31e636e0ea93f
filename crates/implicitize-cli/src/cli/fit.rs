//! `implicitize fit` and `implicitize demo`: the iterative fit of paper 5 on a mesh file, or on
//! the built-in triceratops.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use implicitize::fit::{self, ErrorMeasure, FitOptions};
use implicitize::memory::Estimate;
use implicitize::pipeline::{self, MeshFitOptions, Prepared};
use implicitize::{Mesh, mesh, output, polygonize};

use super::common::{GridArgs, Progress, check_outputs, read_mesh, warn_if_open, write_report};
use super::render::{Snapshots, compare_picture};

/// How the constraints are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// The paper's iterative method (section 5).
    Iterative,
    /// The paper's simple method (section 3.2): mesh vertices and normal offsets.
    Naive,
}

/// The iterative fit's own settings, shared by `fit`, `demo` and `fit2d`.
#[derive(Debug, Args)]
pub struct LoopArgs {
    /// Seed of the random choice of initial constraints (same seed, same model).
    #[arg(long, default_value_t = FitOptions::default().seed)]
    pub seed: u64,
    /// Stop after this many iterations.
    #[arg(long, default_value_t = FitOptions::default().max_iterations)]
    pub max_iterations: usize,
    /// Stop once the max error E is at most this many voxels (pixels in 2D); errors above it
    /// are corrected however flat the surface is there.
    #[arg(long, default_value_t = FitOptions::default().target_error)]
    pub target_error: f32,
    /// Measure E from points on the surfaces rather than from voxel centres, for the target,
    /// the choice of the best model and the candidates above the target: the measure for
    /// targets of a voxel or less (a voxel-centre E is never below 0.5 and moves in steps)
    #[arg(long)]
    pub subvoxel: bool,
    /// Never use more constraints than this [default: 50000; 2000 with --method naive, which
    /// uses half of them as mesh vertices]
    #[arg(long)]
    pub max_constraints: Option<usize>,
}

impl LoopArgs {
    /// The fit's options: these settings, the defaults for the rest.
    pub fn options(&self) -> FitOptions {
        FitOptions {
            seed: self.seed,
            max_iterations: self.max_iterations,
            target_error: self.target_error,
            error_measure: if self.subvoxel { ErrorMeasure::SubVoxel } else { ErrorMeasure::Voxel },
            max_constraints: self.max_constraints.unwrap_or(FitOptions::default().max_constraints),
            ..FitOptions::default()
        }
    }
}

/// The options of the fit itself, shared by `fit` and `demo`.
#[derive(Debug, Args)]
pub struct FitArgs {
    #[command(flatten)]
    pub grid: GridArgs,
    #[command(flatten)]
    pub settings: LoopArgs,
    /// How the constraints are made.
    #[arg(long, value_enum, default_value_t = Method::Iterative)]
    pub method: Method,
    /// Run every iteration on the full grid: no start at half the resolution (which the fit
    /// makes on grids of 128 voxels or more along their longest axis).
    #[arg(long)]
    pub full_resolution: bool,
}

impl FitArgs {
    /// The library's options for these flags.
    pub fn options(&self) -> MeshFitOptions {
        let mut options = self.settings.options();
        if self.method == Method::Naive && self.settings.max_constraints.is_none() {
            options.max_constraints = fit::naive::DEFAULT_CONSTRAINTS;
        }
        if self.full_resolution {
            options.coarse_start_min_axis = usize::MAX;
        }
        let method = match self.method {
            Method::Iterative => pipeline::Method::Iterative,
            Method::Naive => pipeline::Method::Naive,
        };
        MeshFitOptions {
            resolution: self.grid.resolution(),
            method,
            fit: options,
            ..Default::default()
        }
    }
}

/// Arguments of `implicitize fit`.
#[derive(Debug, Args)]
pub struct FitCommand {
    /// The mesh (OBJ, PLY, STL or OFF).
    pub mesh: PathBuf,
    /// The model file to write (JSON).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the fit report (JSON: the paper's Table 1 and 2 columns, per iteration too).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Also write the polygonized implicit surface (OBJ, PLY or STL).
    #[arg(long)]
    pub mesh_out: Option<PathBuf>,
    /// Also draw each iteration's surface to DIR/iteration-NN.png and all of them side by side
    /// to DIR/strip.png (paper figure 1).
    #[arg(long, value_name = "DIR")]
    pub snapshots: Option<PathBuf>,
    #[command(flatten)]
    pub fit: FitArgs,
}

/// Where a fit's results go.
struct Outputs<'a> {
    model: &'a Path,
    report: Option<&'a Path>,
    mesh: Option<&'a Path>,
    snapshots: Option<&'a Path>,
    compare: Option<&'a Path>,
}

/// Runs `implicitize fit`.
pub fn run(args: &FitCommand, progress: Progress) -> anyhow::Result<()> {
    if args.snapshots.is_some() && args.fit.method != Method::Iterative {
        anyhow::bail!("--snapshots draws the iterations of --method iterative only");
    }
    let files: Vec<&Path> =
        [Some(args.output.as_path()), args.report.as_deref()].into_iter().flatten().collect();
    let meshes: Vec<&Path> = args.mesh_out.iter().map(PathBuf::as_path).collect();
    check_outputs(&files, &meshes)?;
    if let Some(dir) = &args.snapshots {
        output::prepare_folder(dir)?;
    }
    let mesh = read_mesh(&args.mesh, progress)?;
    let mesh_bytes = std::fs::metadata(&args.mesh).ok().map(|m| m.len());
    let name = args.mesh.file_stem().map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    let outputs = Outputs {
        model: &args.output,
        report: args.report.as_deref(),
        mesh: args.mesh_out.as_deref(),
        snapshots: args.snapshots.as_deref(),
        compare: None,
    };
    fit_and_write(&mesh, &args.mesh, &name, mesh_bytes, &args.fit, &outputs, progress)
}

/// The built-in default model, compiled into the binary (see data/README.md).
const TRICERATOPS_OBJ: &[u8] = include_bytes!("../../../../data/triceratops.obj");

/// Arguments of `implicitize demo`.
#[derive(Debug, Args)]
pub struct DemoCommand {
    /// The folder to write into.
    #[arg(short, long, default_value = "implicitize-demo")]
    pub output: PathBuf,
    #[command(flatten)]
    pub fit: FitArgs,
}

/// Runs `implicitize demo`: the fit on the built-in triceratops, everything written to a folder.
pub fn demo(args: &DemoCommand, progress: Progress) -> anyhow::Result<()> {
    let source = Path::new("triceratops.obj (built in)");
    let (mesh, _) = mesh::read_bytes(TRICERATOPS_OBJ, mesh::Format::Obj, source)?;
    output::prepare_folder(&args.output)?;
    let model = args.output.join("model.json");
    let report = args.output.join("report.json");
    let surface = args.output.join("surface.ply");
    let compare = args.output.join("compare.png");
    let outputs = Outputs {
        model: &model,
        report: Some(&report),
        mesh: Some(&surface),
        snapshots: None,
        compare: Some(&compare),
    };
    let mesh_bytes = Some(TRICERATOPS_OBJ.len() as u64);
    fit_and_write(&mesh, source, "triceratops", mesh_bytes, &args.fit, &outputs, progress)?;
    progress.line(format!(
        "wrote {}, {}, {} and {}",
        model.display(),
        report.display(),
        surface.display(),
        compare.display()
    ));
    Ok(())
}

/// Voxelizes, fits, and writes the model, the report and the surface.
fn fit_and_write(
    mesh: &Mesh,
    source: &Path,
    name: &str,
    mesh_bytes: Option<u64>,
    args: &FitArgs,
    outputs: &Outputs,
    progress: Progress,
) -> anyhow::Result<()> {
    let options = args.options();
    let grid = args.grid.checked_grid(mesh, source, Estimate::fit)?;
    progress.stage(format!("voxelizing on {} x {} x {}", grid.dims[0], grid.dims[1], grid.dims[2]));
    let prepared = Prepared::new(mesh, &source.display().to_string(), &options)?;
    warn_if_open(&source.display().to_string(), &prepared.ambiguity());
    let mut snapshots =
        outputs.snapshots.map(|dir| Snapshots::new(dir, prepared.bounds(), prepared.grid()));
    let mut fitted = prepared.fit(|line, implicit| {
        progress.line(line.line());
        if let Some(snapshots) = snapshots.as_mut() {
            snapshots.take(line.iteration, implicit);
        }
    })?;
    if let Some(snapshots) = snapshots {
        snapshots.finish()?;
    }
    fitted.report.mesh_bytes = mesh_bytes;
    fitted.save(outputs.model)?;
    if let Some(path) = outputs.report {
        write_report(path, &fitted.report)?;
    }
    if let Some(path) = outputs.mesh {
        let surface = polygonize::polygonize_field(&fitted.model, &grid);
        mesh::write(path, &surface)?;
    }
    if let Some(path) = outputs.compare {
        compare_picture(mesh, &fitted.model, 800, 600)?.save_png(path)?;
    }
    progress.line(fitted.report.table(name));
    Ok(())
}
