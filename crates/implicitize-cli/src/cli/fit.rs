//! `implicitize fit` and `implicitize demo`: the iterative fit of paper 5 on a mesh file, or on
//! the built-in triceratops.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use implicitize::fit::{ErrorMeasure, FitOptions, IterationReport};
use implicitize::pipeline::settings::FitSettings;
use implicitize::pipeline::{self, FitObserver, FitOutputs, MeshFitOptions, MeshSource, Prepared};
use implicitize::{mesh, model::ModelFormat, output, rbf::Implicit};

use super::common::{Progress, memory_limit, read_mesh, warn};
use super::render::{Snapshots, compare_picture};
use super::settings::{SettingsArgs, own_default};

/// The formats of a model file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelFileFormat {
    /// The compact binary model (numbers on a lattice, entropy-coded; no report).
    Binary,
    /// Versioned JSON with the fit report embedded.
    Json,
}

impl From<ModelFileFormat> for ModelFormat {
    fn from(format: ModelFileFormat) -> ModelFormat {
        match format {
            ModelFileFormat::Binary => ModelFormat::Binary,
            ModelFileFormat::Json => ModelFormat::Json,
        }
    }
}

/// The `--max-constraints` help, with the library's limits.
fn max_constraints_help() -> String {
    format!(
        "Never use more constraints than this [default: {}; {} with --method naive, which uses \
         half of them as mesh vertices]",
        pipeline::Method::Iterative.default_max_constraints(),
        pipeline::Method::Naive.default_max_constraints()
    )
}

/// The iterative fit's own settings in `fit2d`; each default is the library's. (The fit of a
/// mesh takes its settings from the library's table: [`SettingsArgs`].)
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
    #[arg(long, help = max_constraints_help())]
    pub max_constraints: Option<usize>,
}

impl LoopArgs {
    /// Sets these settings on `options`.
    pub fn apply(&self, options: &mut FitOptions) {
        options.seed = self.seed;
        options.max_iterations = self.max_iterations;
        options.target_error = self.target_error;
        options.error_measure =
            if self.subvoxel { ErrorMeasure::SubVoxel } else { ErrorMeasure::Voxel };
        options.max_constraints = self.max_constraints;
    }
}

/// The options of the fit itself, shared by `fit`, `demo` and `batch`: every setting of the
/// library's table as a flag ([`SettingsArgs`]), and a settings file.
#[derive(Debug, Args)]
pub struct FitArgs {
    #[command(flatten)]
    pub settings: SettingsArgs,
    /// Read the fit's settings from FILE (TOML, or JSON for a name ending in .json; the keys
    /// are these flags' names with _ for -, as Python's keywords): the flags given on the
    /// command line override the file's
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
}

impl FitArgs {
    /// The flags' settings with `--config`'s file over those the command line did not give:
    /// a value the file sets replaces a default of the command's own, a flag given on the
    /// command line wins over the file. Of two settings that exclude each other (`resolution`
    /// and `dims`, `shell` and `solid`), the one the file sets clears the other unless the
    /// command line gave it.
    ///
    /// # Errors
    /// A settings file that cannot be read, holds an unknown key or a value out of range.
    pub fn merged_settings(&self) -> implicitize::Result<FitSettings> {
        let SettingsArgs { settings: flags, given } = &self.settings;
        let Some(path) = &self.config else { return Ok(flags.clone()) };
        let file = serde_json::to_value(FitSettings::read(path)?).expect("settings serialize");
        let mut merged = serde_json::to_value(flags).expect("settings serialize");
        let unset = serde_json::to_value(FitSettings::default()).expect("settings serialize");
        let given = |name: &str| given.iter().any(|g| g == name);
        for setting in FitSettings::table() {
            let (name, value) = (setting.name, &file[setting.name]);
            let set = !(value.is_null() || value == &serde_json::Value::Bool(false));
            if !set || given(name) {
                continue;
            }
            if let Some(other) = setting.excludes {
                if given(other) {
                    continue;
                }
                merged[other] = unset[other].clone();
            }
            merged[name] = value.clone();
        }
        Ok(serde_json::from_value(merged).expect("merged settings are settings"))
    }

    /// The library's options for these flags (and `--config`'s file), under the memory limit.
    ///
    /// # Errors
    /// A setting out of its range (a `--shell` that is not a thickness, ...), or a settings
    /// file that cannot be read.
    pub fn options(&self) -> implicitize::Result<MeshFitOptions> {
        self.merged_settings()?.options("options", memory_limit())
    }
}

/// Arguments of `implicitize fit`.
#[derive(Debug, Args)]
pub struct FitCommand {
    /// The mesh (OBJ, PLY, STL or OFF).
    pub mesh: PathBuf,
    /// The model file to write: the compact binary format, or JSON for a name ending in .json
    /// (or with --format json); every command reads both.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The model file's format, whatever its name [default: json for a name ending in .json,
    /// binary otherwise].
    #[arg(long, value_enum)]
    pub format: Option<ModelFileFormat>,
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

/// What the command line shows of a fit as it runs: the open-mesh warning, a line per
/// iteration, and the pictures of `--snapshots` (what the fit's outcome warns of is printed
/// after it: [`pipeline::outcome_warnings`]).
struct Watch<'a> {
    progress: Progress,
    source: String,
    snapshots_dir: Option<&'a Path>,
    snapshots: Option<Snapshots<'a>>,
}

impl FitObserver for Watch<'_> {
    fn prepared(&mut self, prepared: &Prepared<'_>) {
        for warning in prepared.warnings() {
            warn(&self.source, &warning);
        }
        self.snapshots =
            self.snapshots_dir.map(|dir| Snapshots::new(dir, prepared.bounds(), prepared.grid()));
    }

    fn iteration(&mut self, report: &IterationReport, implicit: &Implicit) {
        self.progress.line(report.line());
        if let Some(snapshots) = self.snapshots.as_mut() {
            snapshots.take(report.iteration, implicit);
        }
    }
}

/// Runs `implicitize fit`.
pub fn run(args: &FitCommand, progress: Progress) -> anyhow::Result<()> {
    if args.snapshots.is_some() && args.fit.options()?.method != pipeline::Method::Iterative {
        anyhow::bail!("--snapshots draws the iterations of --method iterative only");
    }
    let mut outputs = FitOutputs::default();
    outputs.model = Some(args.output.clone());
    outputs.model_format = args.format.map(ModelFormat::from);
    outputs.report = args.report.clone();
    outputs.surface = args.mesh_out.clone();
    outputs.check()?;
    if let Some(dir) = &args.snapshots {
        output::prepare_folder(dir)?;
    }
    let mesh = read_mesh(&args.mesh, progress)?;
    let name = args.mesh.file_stem().map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
    let bytes = std::fs::metadata(&args.mesh).ok().map(|m| m.len());
    let source = args.mesh.display().to_string();
    let from = MeshSource::Mesh { mesh: &mesh, name: &source, bytes };
    let snapshots = args.snapshots.as_deref();
    fit_and_write(from, &name, &args.fit, &outputs, snapshots, progress)?;
    Ok(())
}

/// The built-in default model, compiled into the binary (see data/README.md).
const TRICERATOPS_OBJ: &[u8] = include_bytes!("../../../../data/triceratops.obj");

/// The demo's grid: the fit's flags with their defaults, but for these two, which fit the
/// triceratops with detail levels at 512 so that the demo's picture keeps its brow horns,
/// toes and the scallops of its frill (about 10 s on 2 cores; see docs/results.md).
const DEMO_RESOLUTION: &str = "512";
/// The demo's target E, in voxels of [`DEMO_RESOLUTION`].
const DEMO_TARGET_ERROR: &str = "1";

/// Arguments of `implicitize demo`.
#[derive(Debug, Args)]
#[command(
    mut_arg("resolution", |a| own_default(a, "resolution", DEMO_RESOLUTION)),
    mut_arg("target_error", |a| own_default(a, "target_error", DEMO_TARGET_ERROR))
)]
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
    let mut outputs = FitOutputs::default();
    outputs.model = Some(args.output.join("model.imp"));
    outputs.report = Some(args.output.join("report.json"));
    outputs.surface = Some(args.output.join("surface.ply"));
    let compare = args.output.join("compare.png");
    let name = source.display().to_string();
    let bytes = Some(TRICERATOPS_OBJ.len() as u64);
    let from = MeshSource::Mesh { mesh: &mesh, name: &name, bytes };
    let fitted = fit_and_write(from, "triceratops", &args.fit, &outputs, None, progress)?;
    let [width, height] = implicitize::render::Camera::DEFAULT_SIZE;
    compare_picture(&mesh, &fitted.model, width, height)?.save_png(&compare)?;
    let written = [&outputs.model, &outputs.report, &outputs.surface]
        .map(|p| p.as_ref().map_or(String::new(), |p| p.display().to_string()));
    progress.line(format!(
        "wrote {}, {}, {} and {}",
        written[0],
        written[1],
        written[2],
        compare.display()
    ));
    Ok(())
}

/// Runs the library's fit on `from` and prints its table under `name`.
fn fit_and_write(
    from: MeshSource<'_>,
    name: &str,
    args: &FitArgs,
    outputs: &FitOutputs,
    snapshots: Option<&Path>,
    progress: Progress,
) -> anyhow::Result<pipeline::Fitted> {
    let source = match from {
        MeshSource::Mesh { name, .. } => name.to_string(),
        MeshSource::File(path) => path.display().to_string(),
    };
    progress.stage(format!("voxelizing {source}"));
    let mut watch =
        Watch { progress, source: source.clone(), snapshots_dir: snapshots, snapshots: None };
    let fitted = pipeline::fit(from, &args.options()?, outputs, &mut watch)?;
    if let Some(snapshots) = watch.snapshots {
        snapshots.finish()?;
    }
    progress.line(fitted.report.table(name));
    for warning in pipeline::outcome_warnings(&fitted.report) {
        warn(&source, &warning);
    }
    Ok(fitted)
}
