//! The command-line front end: parse the arguments, call the library, print.
//!
//! Each subcommand lives in its own file. Errors print as one line on stderr and the process
//! exits with status 1; stdout carries only machine-readable output.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod eval;
mod solve;

/// Turn polygon meshes into compact, smooth variational implicit surfaces, and use them.
#[derive(Debug, Parser)]
#[command(name = "implicitize", version, about, long_about = None)]
pub struct Cli {
    /// Print no progress on stderr.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Solve for the implicit function through constraints in a CSV file, and save the model.
    Solve(solve::SolveArgs),
    /// Evaluate a model at points (inside positive, outside negative).
    Eval(eval::EvalArgs),
}


/// Parses the command line and runs it.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let result: anyhow::Result<()> = match &cli.command {
        Command::Solve(args) => solve::run(args, cli.quiet),
        Command::Eval(args) => eval::run(args, cli.quiet),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
