//! `implicitize solve`: the variational implicit function through constraints (paper 3.1).

use std::path::PathBuf;
use std::time::Instant;

use super::common::{Progress, check_outputs};
use anyhow::Context;
use clap::Args;
use implicitize::rbf::read_constraints;
use implicitize::{Aabb, DVec3, model::Model, rbf::Implicit, rbf::Kernel};

/// Arguments of `solve`.
#[derive(Debug, Args)]
pub struct SolveArgs {
    /// Constraints as CSV: a header line `x,y,z,value` (or `x,y,value` in 2D, `x,y,z,t,value`
    /// in 4D), then one constraint a line; values 0 on the surface, positive inside, negative
    /// outside.
    pub constraints: PathBuf,
    /// The model file to write: the binary format, or JSON for a name ending in .json.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The radial basis function: r2logr (r^2 log r, the paper's), r3 or r.
    #[arg(long, default_value = "r2logr", value_parser = parse_kernel)]
    pub kernel: Kernel,
}

fn parse_kernel(name: &str) -> Result<Kernel, String> {
    Kernel::from_name(name)
        .ok_or_else(|| format!("unknown kernel {name:?}: expected r2logr, r3 or r"))
}

/// Reads the constraints, solves, and writes the model.
pub fn run(args: &SolveArgs, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output], &[])?;
    let (dim, constraints) = read_constraints(&args.constraints)?;
    let start = Instant::now();
    let implicit = Implicit::solve(dim, args.kernel, &constraints).with_context(|| {
        format!("{} (constraints are numbered by data row)", args.constraints.display())
    })?;
    let seconds = start.elapsed().as_secs_f64();
    let point = |p: &[f64]| DVec3::new(p[0], p[1], p.get(2).copied().unwrap_or(0.0));
    let positions: Vec<DVec3> = constraints.iter().map(|c| point(c.position())).collect();
    let bounds = Aabb::of_points(&positions).context("no constraints")?;
    let residual = implicit.residual();
    Model::from_implicit(implicit, bounds, None).save(&args.output)?;
    progress.line(format!(
            "solved {} constraints in {dim}D with {} in {seconds:.3} s, relative residual {residual:.2e}; wrote {}",
            constraints.len(),
            args.kernel,
            args.output.display()
        ));
    Ok(())
}
