//! Pieces several subcommands share: the grid options, mesh loading and progress output.

use std::io::IsTerminal;
use std::path::Path;
use std::sync::OnceLock;

use clap::Args;
use implicitize::memory::{self, Estimate};
use implicitize::{Grid, Mesh, Resolution, mesh, output, pipeline};

/// The size of the voxel grid placed around the mesh.
#[derive(Debug, Args)]
pub struct GridArgs {
    /// Voxels along the mesh's longest axis, margins included (the paper's volumes: bunny 220,
    /// horse 337, triceratops 320).
    #[arg(long, default_value_t = 200, conflicts_with = "dims")]
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

    /// The grid around `mesh`, whose file is `path`.
    pub fn grid_around(&self, mesh: &Mesh, path: &Path) -> anyhow::Result<Grid> {
        Ok(pipeline::grid_around(mesh, self.resolution(), &path.display().to_string())?)
    }

    /// The grid around `mesh`, whose file is `path`, once `estimate` of the work on it (from
    /// the grid's dimensions and the mesh's triangles) fits in the memory limit.
    pub fn checked_grid(
        &self,
        mesh: &Mesh,
        path: &Path,
        estimate: fn([usize; 3], usize) -> Estimate,
    ) -> anyhow::Result<Grid> {
        let grid = self.grid_around(mesh, path)?;
        let triangles = mesh.triangles.len();
        check_memory(&estimate(grid.dims, triangles), |n| {
            let grid = pipeline::grid_around(mesh, Resolution::LongestAxis(n), "").ok()?;
            Some(estimate(grid.dims, triangles).bytes)
        })
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Ok(grid)
    }
}

/// The memory limit of `--memory-limit`, or else what the machine has available.
static MEMORY_LIMIT: OnceLock<u64> = OnceLock::new();

/// Sets the memory limit from `--memory-limit`, or to the available memory when `None`.
pub fn set_memory_limit(limit: Option<u64>) {
    let limit = limit.or_else(memory::available).unwrap_or(u64::MAX);
    MEMORY_LIMIT.get_or_init(|| limit);
}

/// The memory limit.
pub fn memory_limit() -> u64 {
    *MEMORY_LIMIT.get().unwrap_or(&u64::MAX)
}

/// Refuses `estimate` above the memory limit, naming the largest `--resolution` whose
/// estimate (`at_resolution`, `None` where there is no such grid) fits.
pub fn check_memory(
    estimate: &Estimate,
    at_resolution: impl Fn(usize) -> Option<u64>,
) -> anyhow::Result<()> {
    let limit = memory_limit();
    Ok(estimate.check(limit, || {
        memory::largest_fitting(2 * Grid::MARGIN + 2..=Grid::MAX_AXIS, limit, at_resolution)
            .map(|n| format!("--resolution {n}"))
    })?)
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
        eprintln!("warning: {source}: {warning}");
    }
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
