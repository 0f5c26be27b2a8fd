//! Command-line interface: argument parsing (clap), progress bars (indicatif) and output.
//! All numerics live in the library; this module only renders.

mod args;
mod bench;
mod bench_modes;
mod demo;
mod done;
mod evaluate;
mod export;
mod generate;
mod import;
mod info;
mod modes;
mod progress;
mod reduce;
mod report;
mod sweep;
mod tradeoff;

use clap::{Parser, Subcommand};
use done::Done;
use sparsemor::engine::Cluster;
use std::path::PathBuf;
use std::sync::Arc;

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
  sparsemor demo
  sparsemor generate bar --out bar
  sparsemor generate bracket --out bracket
  sparsemor info bar
  sparsemor import job_STIF1.mtx job_MASS1.mtx job.inp --inputs 17:x,17:y --out job
  sparsemor sweep bar --band 1:1000 --points 500 --part elastic --out frf.csv
  sparsemor reduce bar --method linefit --extra-interface 5 --ref-freqs 50,100,200,400,800 --out rom
  sparsemor reduce bar --method serep --modes 9 --out rom9
  sparsemor reduce bar --method craig-bampton --extra-interface 1 --modes 4 --out cb14
  sparsemor evaluate bar rom --csv eps.csv
  sparsemor export rom --model bar --format exudyn --out rom_exudyn
  sparsemor reduce bar --method linefit --extra-interface 5 --tol 1e-3 --max-order 24 --out rom3
  sparsemor tradeoff bar --tols 1e-1,1e-2,1e-3,1e-4 --csv tradeoff.csv --svg tradeoff.svg
  sparsemor modes bar --band 0:1000
  sparsemor report bar rom rom9 --tradeoff tradeoff.csv --tol 1e-2 --out report
  sparsemor bench sweep

Exit status:
  0  done (and the requested tolerance, if any, was met)
  1  error: nothing was written
  2  bad command line
  3  the ROM was written but the requested tolerance was NOT met
     (rom.toml [sampling] records the tolerance, the error reached and why the loop stopped)";

#[derive(Subcommand)]
enum Command {
    /// Write a built-in FE model (hex8 elasticity) as a model directory.
    Generate {
        /// Which model: `bar` (the paper's bar; other sizes with --elements/--size) or
        /// `bracket` (an L-shaped steel bracket; finer with --cell).
        kind: String,
        /// Elements NXxNYxNZ (default 2x3x45).
        #[arg(long)]
        elements: Option<String>,
        /// Box size XxYxZ in metres (default 0.006x0.008x0.3).
        #[arg(long)]
        size: Option<String>,
        /// Bracket cell size in metres (default 0.01; the legs, 20 mm thickness and 50 mm
        /// width must be whole numbers of cells).
        #[arg(long)]
        cell: Option<f64>,
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
    Sweep(sweep::SweepArgs),
    /// Reduce a model: line-fitting, SEREP or Craig–Bampton, written as a ROM directory.
    Reduce(reduce::ReduceArgs),
    /// Transfer-function error, eigenfrequency errors and MAC of a ROM against its model.
    Evaluate(evaluate::EvaluateArgs),
    /// A ROM (reduced with --keep-basis) as a flexible body for a multibody code (EXUDYN).
    Export(export::ExportArgs),
    /// Eigenfrequencies (partial, shift-invert Krylov; counted exactly up to a frequency).
    Modes(modes::ModesArgs),
    /// The paper's comparison on the built-in bar: line-fitting vs SEREP and Craig–Bampton.
    Demo {
        /// Worker threads (0 = all cores).
        #[arg(long, default_value_t = 0)]
        threads: usize,
    },
    /// Speed vs accuracy: the sampling loop per tolerance, SEREP and Craig–Bampton per mode
    /// count.
    Tradeoff(tradeoff::TradeoffArgs),
    /// A model directory from the files ANSYS or Abaqus wrote (.full, APDL Math, *MATRIX OUTPUT).
    Import(import::ImportArgs),
    /// One HTML page comparing ROMs with their model: |H|, ε(f), eigenfrequency errors, MAC.
    Report(report::ReportArgs),
    /// Performance tables (markdown): `bench sweep`.
    Bench(bench::BenchArgs),
}

/// Parses the command line and runs the command; with a cluster of more than one rank
/// (`mpirun`), rank 0 runs it and the other ranks solve their share of its frequencies.
pub fn run(cluster: Option<Arc<dyn Cluster>>) -> sparsemor::Result<Done> {
    let cli = Cli::parse();
    progress::handle_interrupts();
    match cluster.filter(|c| c.size() > 1) {
        None => command(cli, None),
        Some(c) => on_ranks(cli, c),
    }
}

fn met(r: sparsemor::Result<()>) -> sparsemor::Result<Done> {
    r.map(|()| Done::Met)
}

/// A command under `mpirun` (docs/design.md §9): rank 0 runs it with the cluster in its sweep
/// options and stops the other ranks at the end (with its exit status); the others read the
/// model and serve rank 0's frequency commands. A rank that cannot read the model still
/// serves, answering with its error, so rank 0 reports it.
fn on_ranks(cli: Cli, c: Arc<dyn Cluster>) -> sparsemor::Result<Done> {
    let setup = match &cli.command {
        Command::Sweep(a) => a.sweep_setup(),
        Command::Reduce(a) => a.sweep_setup(),
        Command::Evaluate(a) => Ok(a.sweep_setup()),
        _ => Err(sparsemor::Error::InvalidSetting(
            "under mpirun only `reduce --method linefit`, `sweep` and `evaluate` run \
             distributed; run this command without mpirun"
                .into(),
        )),
    };
    // the same decision on every rank (same command line); rank 0 alone says why a command is
    // refused, and every rank ends only when rank 0 stops it
    let setup = setup.map(|(path, opts)| (path.to_path_buf(), opts));
    #[cfg(feature = "mumps")]
    if matches!(&setup, Ok((_, o)) if o.backend == sparsemor::factor::Backend::Mumps) {
        return shared_factorizations(cli, &*c);
    }
    if c.rank() == 0 {
        let done = setup.and_then(|_| command(cli, Some(c.clone())));
        return lead(done, |code| sparsemor::engine::stop(&*c, code));
    }
    // the model is dropped once its body is built: the body holds the matrices
    let (body, opts) = match &setup {
        Ok((path, opts)) => (
            sparsemor::io::model_dir::read(path)
                .and_then(|(m, _, _)| sparsemor::body::Body::new(&m))
                .map_err(|e| e.to_string()),
            opts.clone(),
        ),
        // rank 0 refuses the command and only stops this rank
        Err(e) => (
            Err(e.to_string()),
            sparsemor::sweep::SweepOptions::default(),
        ),
    };
    let code = sparsemor::engine::serve(&*c, body.as_ref().map_err(|e| e.as_str()), &opts)?;
    Ok(Done::from_exit_code(code))
}

/// A command with `--backend mumps` under `mpirun` (docs/design.md §9): every rank holds and
/// computes a part of each factorization (`factor::mumps::share`), so a body whose factor
/// does not fit one process fits the job. Rank 0 runs the command as a single process would,
/// with every frequency factored; the other ranks serve MUMPS's jobs until rank 0 ends the run
/// with its exit status. They do not read the model: rank 0 holds the matrix.
#[cfg(feature = "mumps")]
fn shared_factorizations(cli: Cli, c: &dyn Cluster) -> sparsemor::Result<Done> {
    use sparsemor::factor::mumps;
    mumps::share()?;
    if c.rank() == 0 {
        return lead(command(cli, None), mumps::dismiss);
    }
    Ok(Done::from_exit_code(mumps::serve()?))
}

/// Rank 0's end of a run under `mpirun`: prints the error, if any, before `release` lets
/// the other ranks end with the run's exit code (mpirun ends the job at the first non-zero
/// exit, so the message comes first), then returns the outcome (a failure as
/// [`Done::Failed`], its message already shown).
fn lead(done: sparsemor::Result<Done>, release: impl FnOnce(i32)) -> sparsemor::Result<Done> {
    let code = done.as_ref().map_or(1, |d| d.exit_code());
    if let Err(e) = &done {
        eprintln!("error: {e}");
    }
    release(code);
    done.or(Ok(Done::Failed))
}

/// Runs one command; `cluster` for the commands that run distributed.
fn command(cli: Cli, cluster: Option<Arc<dyn Cluster>>) -> sparsemor::Result<Done> {
    match cli.command {
        Command::Generate {
            kind,
            elements,
            size,
            cell,
            out,
        } => met(generate::generate(
            &kind,
            elements.as_deref(),
            size.as_deref(),
            cell,
            &out,
        )),
        Command::Info { model } => met(info::info(&model)),
        Command::Sweep(args) => met(sweep::sweep(&args, cli.verbose, cluster)),
        Command::Reduce(args) => reduce::reduce(&args, cluster),
        Command::Evaluate(args) => met(evaluate::evaluate(&args, cluster)),
        Command::Export(args) => met(export::export(&args)),
        Command::Modes(args) => met(modes::modes(&args)),
        Command::Demo { threads } => met(demo::demo(threads)),
        Command::Tradeoff(args) => met(tradeoff::tradeoff(&args)),
        Command::Import(args) => met(import::import(&args)),
        Command::Report(args) => met(report::report(&args)),
        Command::Bench(args) => met(bench::run(&args)),
    }
}
