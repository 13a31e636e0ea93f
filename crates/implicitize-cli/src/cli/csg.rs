//! `implicitize csg`: a union, intersection or difference of models, as a model file.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use implicitize::model::Model;
use implicitize::shape::csg::{Child, Composite, Operation};

use super::common::{Progress, check_outputs};

/// The operation, as typed on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Op {
    /// Inside either shape.
    Union,
    /// Inside both shapes.
    Intersection,
    /// Inside the first shape and outside the second.
    Difference,
}

impl From<Op> for Operation {
    fn from(op: Op) -> Operation {
        match op {
            Op::Union => Operation::Union,
            Op::Intersection => Operation::Intersection,
            Op::Difference => Operation::Difference,
        }
    }
}

/// Arguments of `implicitize csg`.
#[derive(Debug, Args)]
pub struct CsgArgs {
    /// The operation.
    #[arg(value_enum)]
    pub op: Op,
    /// The first model file (JSON, from `fit`, `solve` or `csg`).
    pub a: PathBuf,
    /// The second model file.
    pub b: PathBuf,
    /// The composite model to write (the binary format, or JSON for a name ending in .json); `eval`, `mesh` and `render` read it like any model.
    #[arg(short, long)]
    pub output: PathBuf,
    /// A smooth fillet of about this radius in mesh units where the surfaces meet (0: sharp).
    #[arg(long, default_value_t = 0.0)]
    pub blend: f64,
}

/// Loads both models, combines them and writes the composite.
pub fn run(args: &CsgArgs, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output], &[])?;
    let a = Model::load(&args.a)?;
    let b = Model::load(&args.b)?;
    let context = format!("{} {} {}", args.a.display(), args.op_name(), args.b.display());
    let (a, b) = (Child::from(a), Child::from(b));
    let scales = (a.scale(), b.scale());
    let composite = Composite::new(&context, args.op.into(), args.blend, vec![a, b])?;
    let model = Model::from_composite(composite).map_err(|e| anyhow::anyhow!("{context}: {e}"))?;
    model.save(&args.output)?;
    progress.line(format!(
        "wrote {}: {} (distance scales {:.4e} and {:.4e}{})",
        args.output.display(),
        args.op_name(),
        scales.0,
        scales.1,
        if args.blend > 0.0 { format!(", blend radius {}", args.blend) } else { String::new() }
    ));
    Ok(())
}

impl CsgArgs {
    fn op_name(&self) -> &'static str {
        Operation::from(self.op).name()
    }
}
