//! Command-line interface: argument parsing (clap), progress bars (indicatif) and output.
//! All numerics live in the library; this module only renders.

mod bench;
mod commands;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Model order reduction of large sparse structural FE models (line-fitting, SEREP).
#[derive(Parser)]
#[command(name = "sparsemor", version, about, long_about = None, after_help = EXAMPLES)]
pub struct Cli {
    /// More log output on stderr.
    #[arg(short, long, global = true)]
    pub verbose: bool,
    #[command(subcommand)]
    command: Command,
}

const EXAMPLES: &str = "Examples:
  sparsemor generate bar --out bar
  sparsemor info bar
  sparsemor sweep bar --band 1:1000 --points 500 --part elastic --out frf.csv
  sparsemor bench sweep";

#[derive(Subcommand)]
enum Command {
    /// Write a built-in FE model (hex8 elasticity box) as a model directory.
    Generate {
        /// Which model: `bar` (the paper's bar; other sizes with --elements/--size).
        kind: String,
        /// Elements NXxNYxNZ (default 2x3x45).
        #[arg(long)]
        elements: Option<String>,
        /// Box size XxYxZ in metres (default 0.006x0.008x0.3).
        #[arg(long)]
        size: Option<String>,
        /// Output directory (must not exist or be empty).
        #[arg(long)]
        out: PathBuf,
    },
    /// Print N, nnz, symmetry, nodes, rigid modes and the memory of one factorization.
    Info {
        /// Model directory (with model.toml).
        model: PathBuf,
    },
    /// Transfer functions H(iω) over a band or a list of frequencies, written as CSV.
    Sweep(commands::SweepArgs),
    /// Performance tables (markdown): `bench sweep`.
    Bench(bench::BenchArgs),
}

/// Parses the command line and runs the command.
pub fn run() -> sparsemor::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Generate {
            kind,
            elements,
            size,
            out,
        } => commands::generate(&kind, elements.as_deref(), size.as_deref(), &out),
        Command::Info { model } => commands::info(&model),
        Command::Sweep(args) => commands::sweep(&args, cli.verbose),
        Command::Bench(args) => bench::run(&args),
    }
}
