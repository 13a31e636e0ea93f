//! `implicitize export`: a model's function and gradient as GLSL or WGSL source
//! ([`implicitize::shader`]), to paste into a shader.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use implicitize::model::Model;
use implicitize::{output, shader};

use super::common::{Progress, check_outputs};

/// The shading language written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// GLSL: `float implicitize_value(vec3 p)`, `vec3 implicitize_gradient(vec3 p)`.
    Glsl,
    /// WGSL: `fn implicitize_value(p: vec3<f32>) -> f32`, `fn implicitize_gradient(...)`.
    Wgsl,
}

/// Arguments of `implicitize export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The model file (binary or JSON, from `fit`, `solve` or `csg`); it must be 3D.
    pub model: PathBuf,
    /// The shading language.
    #[arg(long, value_enum)]
    pub format: Format,
    /// The source file to write.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Loads the model and writes its shader source.
pub fn run(args: &ExportArgs, progress: Progress) -> anyhow::Result<()> {
    check_outputs(&[&args.output], &[])?;
    let model = Model::load(&args.model)?;
    let language = match args.format {
        Format::Glsl => shader::Language::Glsl,
        Format::Wgsl => shader::Language::Wgsl,
    };
    let name = args.model.display().to_string();
    let source = shader::source(&model, &name, language)?;
    output::write_bytes(&args.output, source.as_bytes())?;
    progress.line(format!("wrote {} ({} bytes)", args.output.display(), source.len()));
    Ok(())
}
