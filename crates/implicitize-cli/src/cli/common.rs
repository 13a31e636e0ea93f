//! Pieces several subcommands share: the grid options, mesh loading and progress output.

use std::io::IsTerminal;
use std::path::Path;
use std::sync::OnceLock;

use clap::Args;
use implicitize::memory::{Estimate, MemoryLimit};
use implicitize::{grid::Resolution, mesh, mesh::Mesh, output};

/// The size of the voxel grid placed around the mesh.
#[derive(Debug, Args)]
pub struct GridArgs {
    /// Voxels along the mesh's longest axis, margins included (the paper's volumes: bunny 220,
    /// horse 337, triceratops 320).
    #[arg(long, default_value_t = Resolution::DEFAULT_LONGEST_AXIS, conflicts_with = "dims")]
    pub resolution: usize,
    /// An exact volume size instead of --resolution.
    #[arg(long, num_args = 3, value_names = ["NX", "NY", "NZ"])]
    pub dims: Option<Vec<usize>>,
}

impl GridArgs {
    /// The requested resolution.
    pub fn resolution(&self) -> Resolution {
        match self.dims.as_deref() {
            Some(&[nx, ny, nz]) => Resolution::Dims([nx, ny, nz]),
            _ => Resolution::LongestAxis(self.resolution),
        }
    }
}

/// The memory limit of `--memory-limit`, or else what the machine has available; set once,
/// before the subcommand runs.
static MEMORY_LIMIT: OnceLock<MemoryLimit> = OnceLock::new();

/// Sets the memory limit from `--memory-limit` (bytes), or to the available memory when `None`.
pub fn set_memory_limit(limit: Option<u64>) {
    MEMORY_LIMIT.get_or_init(|| limit.map_or(MemoryLimit::Available, MemoryLimit::Bytes));
}

/// The memory limit the library's jobs take.
pub fn memory_limit() -> MemoryLimit {
    MEMORY_LIMIT.get().copied().unwrap_or_default()
}

/// Refuses `estimate` above the memory limit, naming the largest `--resolution` whose
/// estimate (`at_resolution`, `None` where there is no such grid) fits.
pub fn check_memory(
    estimate: &Estimate,
    at_resolution: impl Fn(usize) -> Option<u64>,
) -> anyhow::Result<()> {
    Ok(estimate.check_grid(memory_limit().bytes(), at_resolution)?)
}

/// Progress lines on stderr, unless --quiet.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    quiet: bool,
}

impl Progress {
    /// Progress that prints unless `quiet`.
    pub fn new(quiet: bool) -> Self {
        Progress { quiet }
    }

    /// Whether progress is off.
    pub fn is_quiet(&self) -> bool {
        self.quiet
    }

    /// Prints a line on stderr unless quiet.
    pub fn line(&self, message: impl AsRef<str>) {
        if !self.quiet {
            eprintln!("{}", message.as_ref());
        }
    }

    /// Prints a stage's start on stderr when it is a terminal and not quiet, for long stages.
    pub fn stage(&self, message: impl AsRef<str>) {
        if !self.quiet && std::io::stderr().is_terminal() {
            eprintln!("{}...", message.as_ref());
        }
    }
}

/// Checks, before any work, that every file in `files` can be written (its folder exists and
/// takes files) and that every mesh in `meshes` also has a mesh file's extension.
pub fn check_outputs(files: &[&Path], meshes: &[&Path]) -> anyhow::Result<()> {
    for path in meshes {
        mesh::Format::from_path(path)?;
    }
    for path in files.iter().chain(meshes) {
        output::check_destination(path)?;
    }
    Ok(())
}

/// Writes a fit report as pretty JSON, atomically.
pub fn write_report(path: &Path, report: &implicitize::fit::FitReport) -> anyhow::Result<()> {
    let json = serde_json::to_string_pretty(report)?;
    Ok(output::write_bytes(path, (json + "\n").as_bytes())?)
}

/// Warns on stderr (even with --quiet) when much of the grid around the mesh `source` has a
/// winding number near one half: no trustworthy inside there.
pub fn warn_if_open(source: &str, ambiguity: &implicitize::voxelize::Ambiguity) {
    if let Some(warning) = ambiguity.warning() {
        warn(source, &warning);
    }
}

/// Prints a library warning about `source` on stderr (even with --quiet), its settings worded
/// as flags.
pub fn warn(source: &str, warning: &str) {
    let warning = implicitize::worded(warning, implicitize::FrontEnd::Cli);
    eprintln!("warning: {source}: {warning}");
}

/// Reads a mesh and reports what was repaired.
pub fn read_mesh(path: &Path, progress: Progress) -> anyhow::Result<Mesh> {
    progress.stage(format!("reading {}", path.display()));
    let (mesh, report) = mesh::read(path)?;
    progress.line(format!(
        "{}: {} triangles, {} vertices{}",
        path.display(),
        mesh.triangles.len(),
        mesh.vertices.len(),
        if report.degenerate_dropped > 0 {
            format!(", {} degenerate triangles dropped", report.degenerate_dropped)
        } else {
            String::new()
        }
    ));
    Ok(mesh)
}
