//! `implicitize batch`: many meshes fitted in parallel into one folder, with a manifest
//! (see the library's `batch` module for the files, resuming and atomic writes).

use std::io::IsTerminal;
use std::path::PathBuf;

use clap::Args;
use implicitize::batch::{self, BatchOptions, Entry, Status};
use indicatif::{ProgressBar, ProgressStyle};

use super::common::Progress;
use super::fit::FitArgs;

/// Arguments of `implicitize batch`.
#[derive(Debug, Args)]
pub struct BatchCommand {
    /// Mesh files, folders (searched for .obj, .ply, .stl and .off files) and @LIST files (one
    /// path a line, relative to the list's folder).
    #[arg(required = true, value_name = "INPUTS")]
    pub inputs: Vec<String>,
    /// The output folder: NAME.json, NAME.report.json (and NAME.sdf.npy, NAME.samples.npz) per
    /// mesh, and manifest.jsonl.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Meshes converted at once [default: the number of CPUs].
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Also write each mesh's signed distance volume (as `implicitize sdf`) on the fit's grid
    /// (above 512 voxels with detail levels, on its goal's coarser grid, named in its `.json`).
    #[arg(long)]
    pub sdf: bool,
    /// Also write N samples of each mesh's exact signed distance (as `implicitize sample` with
    /// its defaults and the fit's --seed) to NAME.samples.npz.
    #[arg(long, value_name = "N")]
    pub samples: Option<usize>,
    #[command(flatten)]
    pub fit: FitArgs,
}

/// Runs the batch; fails (after writing the manifest) when any mesh failed.
pub fn run(args: &BatchCommand, progress: Progress) -> anyhow::Result<()> {
    let jobs = batch::plan(&args.inputs)?;
    if jobs.is_empty() {
        anyhow::bail!("no mesh files in {}", args.inputs.join(" "));
    }
    let threads = match args.jobs {
        Some(0) => anyhow::bail!("--jobs 0: at least one job must run"),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    if args.samples == Some(0) {
        anyhow::bail!("--samples 0: give at least one point, or leave --samples out");
    }
    let mut options = BatchOptions::default();
    options.fit = args.fit.options()?;
    options.sdf = args.sdf;
    options.samples = args.samples;
    let bar = progress_bar(jobs.len() as u64, progress);
    let entries = batch::run(&jobs, &args.output, &options, threads, |entry| {
        report(entry, &bar, progress);
    })?;
    bar.finish_and_clear();
    let summary = batch::finish(&args.output, &entries)?;
    let failed = entries.iter().filter(|e| e.status == Status::Failed).count();
    let reused = entries.iter().filter(|e| e.reused).count();
    progress.line(format!(
        "{} of {} meshes converted ({reused} reused from an earlier run of the same input and \
         options); wrote {}",
        entries.len() - failed,
        entries.len(),
        args.output.join(batch::MANIFEST).display()
    ));
    for line in summary {
        progress.line(line);
    }
    if failed > 0 {
        anyhow::bail!(
            "{failed} of {} meshes failed; see {}",
            entries.len(),
            args.output.join(batch::MANIFEST).display()
        );
    }
    Ok(())
}

/// A bar on a terminal (hidden when quiet or when stderr is not one).
fn progress_bar(len: u64, progress: Progress) -> ProgressBar {
    if progress.is_quiet() || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    if let Ok(style) =
        ProgressStyle::with_template("{bar:40} {pos}/{len} meshes, {elapsed} elapsed, ETA {eta}")
    {
        bar.set_style(style);
    }
    bar
}

/// One line per mesh as it finishes, above the bar.
fn report(entry: &Entry, bar: &ProgressBar, progress: Progress) {
    let line = match (&entry.status, &entry.error) {
        (Status::Failed, Some(error)) => format!("{}: failed: {error}", entry.input),
        _ if entry.reused => format!("{}: reused from an earlier run", entry.input),
        _ => format!(
            "{}: E {:.2} voxels, {} constraints, {:.1} s",
            entry.input,
            entry.max_error_voxels.unwrap_or(f32::NAN),
            entry.constraints.unwrap_or(0),
            entry.seconds
        ),
    };
    if bar.is_hidden() {
        progress.line(line);
    } else {
        bar.println(line);
    }
    bar.inc(1);
}
