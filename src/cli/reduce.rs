//! `sparsemor reduce`: line-fitting (explicit frequencies or a tolerance), SEREP or
//! Craig–Bampton, written
//! as a ROM directory; exit status 3 when a requested tolerance was not met.

use super::args::{hz_list, parse_list};
use super::done::Done;
use super::progress::{rank0_share, with_progress};
use sparsemor::body::Body;
use sparsemor::eigen::EigenOptions;
use sparsemor::engine::Cluster;
use sparsemor::io::model_dir::{self, DofNames};
use sparsemor::io::rom_dir;
use sparsemor::metrics::Stability;
use sparsemor::reduce::craig_bampton::CraigBamptonOptions;
use sparsemor::reduce::interface::Interface;
use sparsemor::reduce::linefit::{
    Growth, LineFitOptions, References, SamplingOptions, SamplingReport, Step,
};
use sparsemor::reduce::serep::{ModeChoice, SerepOptions};
use sparsemor::reduce::{self, Context, Reductor, Rom};
use sparsemor::scene::Scene;
use sparsemor::sweep::SweepOptions;
use sparsemor::sweep::{no_progress, ProgressFn};
use sparsemor::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

#[derive(clap::Args)]
pub struct ReduceArgs {
    /// Model directory.
    model: PathBuf,
    /// linefit, serep or craig-bampton.
    #[arg(long)]
    method: String,
    /// Interface DoFs D1,D2,... as 0-based indices or NODE:DIR, e.g. 17:x (line-fitting: must
    /// contain the outputs; Craig–Bampton: the boundary DoFs).
    #[arg(long, conflicts_with = "extra_interface")]
    interface: Option<String>,
    /// Interface = outputs + K DoFs spread along the body (line-fitting, Craig–Bampton's
    /// boundary; with --tol the default is K = ⌈outputs/2⌉).
    #[arg(long)]
    extra_interface: Option<usize>,
    /// Reference frequencies F1,F2,... in Hz (line-fitting; with --tol they are extra seeds).
    #[arg(long)]
    ref_freqs: Option<String>,
    /// Target accuracy: choose the reference frequencies automatically (line-fitting).
    #[arg(long)]
    tol: Option<f64>,
    /// Budget of full solves of --tol (default: 60 when every frequency is factored, 8 × the
    /// order cap when one shifted Krylov space answers them).
    #[arg(long)]
    max_points: Option<usize>,
    /// Largest order --tol may grow the interface to (default: min(max(3·n0, 40), N/2, memory)
    /// for the initial order n0; at most n0 keeps the order fixed).
    #[arg(long)]
    max_order: Option<usize>,
    /// Verification of --tol: full solves at P points spread over the band, their max error
    /// written to rom.toml (default ⌈F/3⌉ for F factorizations, ≈ 25 % of the run; 0 = none).
    #[arg(long, value_name = "P")]
    verify: Option<usize>,
    /// Interface growth rule of --tol: auto (qdeim in one process, residual over MPI ranks),
    /// residual or qdeim.
    #[arg(long, default_value = "auto")]
    growth: String,
    /// Number of modes c (SEREP: the c lowest deformation modes; Craig–Bampton: the c lowest
    /// fixed-interface modes, 0 = static condensation).
    #[arg(long)]
    modes: Option<usize>,
    /// Retained DoFs (SEREP; default: the outputs), as 0-based indices or NODE:DIR.
    #[arg(long)]
    retain: Option<String>,
    /// Also write V.mtx (N×n).
    #[arg(long)]
    keep_basis: bool,
    /// Largest accepted relative error of a factorization's probe solve (after refinement);
    /// above it a frequency is refused as numerically singular.
    #[arg(long, default_value_t = sparsemor::sweep::DEFAULT_PROBE_TOL)]
    probe_tol: f64,
    /// Factorization backend of line-fitting's full solves: auto, ldlt, faer-lblt, faer-lu,
    /// umfpack, mumps (under mpirun: every rank holds a part of each factorization).
    #[arg(long, default_value = "auto")]
    backend: String,
    /// Keep each factorization's factors in this directory instead of memory (backend mumps;
    /// every frequency is then factored); its files are deleted when the run ends.
    #[arg(long)]
    out_of_core: Option<PathBuf>,
    /// Memory budget of the run in GB. Line-fitting's per-frequency factorizations share it
    /// (default: half of what is available; backend mumps goes out of core when one
    /// exceeds it); a real factor (the shifted space's, Craig–Bampton's) that does not fit
    /// what the run has not used of it (default: half of what is available) is kept on
    /// disk, in the temporary directory.
    #[arg(long, value_parser = super::args::gigabytes)]
    memory_gb: Option<usize>,
    /// How line-fitting's responses are computed: auto (one Krylov space for every frequency,
    /// each response certified by its residual: shifted for proportional damping and dampers,
    /// linearized for any other; docs/design.md §3.10–§3.13) or factor (factor A(iω) at every
    /// frequency).
    #[arg(long, default_value = "auto")]
    solve: String,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Output ROM directory.
    #[arg(long)]
    out: PathBuf,
}

impl ReduceArgs {
    /// The model directory and the sweep options of line-fitting (the same on every rank of a
    /// distributed run), or why this reduction does not run distributed.
    pub fn sweep_setup(&self) -> Result<(&Path, SweepOptions)> {
        if self.method != "linefit" {
            return Err(Error::InvalidSetting(format!(
                "--method {}: only line-fitting runs distributed (its frequencies spread over \
                 the ranks); run {} without mpirun",
                self.method, self.method
            )));
        }
        let opts = SweepOptions {
            threads: self.threads,
            backend: self.backend.parse().map_err(|e| match e {
                Error::InvalidSetting(m) => Error::InvalidSetting(format!("--backend: {m}")),
                e => e,
            })?,
            out_of_core: self.out_of_core.clone(),
            memory_budget: self.memory_gb,
            probe_tol: self.probe_tol,
            method: self.solve.parse().map_err(|e| match e {
                Error::InvalidSetting(m) => Error::InvalidSetting(format!("--solve: {m}")),
                e => e,
            })?,
        };
        Ok((&self.model, opts))
    }
}

/// `cluster`: the ranks line-fitting's frequencies are spread over (rank 0 runs this).
pub fn reduce(a: &ReduceArgs, cluster: Option<Arc<dyn Cluster>>) -> Result<Done> {
    // before minutes of work, not after
    sparsemor::io::atomic::check_dir_free(&a.out)?;
    let model_dir::Loaded {
        model,
        scene,
        names,
        ..
    } = model_dir::load(&a.model)?;
    let body = Body::new(&model)?.with_memory_budget(a.memory_gb);
    drop(model); // the body holds the matrices (its pencil): 1.3 GB less on a 10⁶-DoF model
    let reductor = reductor(a, &names, &scene, cluster.clone())?;
    let t = Instant::now();
    let run = |progress: ProgressFn<'_>| {
        reduce::reduce(
            &body,
            &scene,
            &reductor,
            &Context {
                progress,
                ..Context::default()
            },
        )
    };
    let rom = match &reductor {
        Reductor::LineFit(opts) => {
            let share = |n| rank0_share(n, cluster.as_ref());
            let rom = match &opts.references {
                References::Explicit(f) => {
                    with_progress(share(f.len()), "reference frequencies", run)?
                }
                References::Tolerance(s) => {
                    with_progress(share(s.max_points.unwrap_or(0)), "full solves", run)?
                }
                References::Count(_) => run(&no_progress)?,
            };
            if let Some(s) = rom.sampling() {
                if let Some(c) = s.modes_in_band {
                    println!("modes in band    {c} elastic (inertia count)");
                }
                print_steps(&s.steps);
                println!("{}", sampling_message(s, &rom));
            }
            rom
        }
        Reductor::Serep(_) | Reductor::CraigBampton(_) => run(&no_progress)?,
    };
    let secs = t.elapsed().as_secs_f64();
    rom_dir::write_for_body(&a.out, &rom, &body)?;
    print_rom(&rom);
    eprintln!("reduced in {secs:.2} s -> {}", a.out.display());
    Ok(match rom.sampling() {
        Some(s) if !s.outcome.reached() => {
            eprintln!(
                "the ROM was written, but the tolerance {:.1e} was NOT met (error reached {:.2e}); exit status 3",
                s.tol, s.error
            );
            Done::RequestNotMet
        }
        _ => Done::Met,
    })
}

/// The method and options the arguments ask for.
fn reductor(
    a: &ReduceArgs,
    names: &DofNames,
    scene: &Scene,
    cluster: Option<Arc<dyn Cluster>>,
) -> Result<Reductor> {
    Ok(match a.method.as_str() {
        "linefit" => {
            let interface = match (&a.interface, a.extra_interface, a.tol) {
                (Some(i), _, _) => Interface::Explicit(names.indices(i, "--interface")?),
                (None, Some(k), _) => Interface::OutputsPlus(k),
                (None, None, Some(_)) => Interface::Auto,
                (None, None, None) => return Err(Error::InvalidSetting(
                    "linefit with --ref-freqs needs --interface D1,D2,... or --extra-interface K"
                        .into(),
                )),
            };
            let ref_freqs = a
                .ref_freqs
                .as_deref()
                .map(|f| parse_list(f, "--ref-freqs"))
                .transpose()?;
            let references = match (a.tol, ref_freqs) {
                (Some(tol), seeds) => {
                    let mut s = SamplingOptions::new(tol);
                    s.seeds_hz = seeds.unwrap_or_default();
                    s.max_points = a.max_points;
                    s.max_order = a.max_order;
                    s.verify_points = a.verify;
                    s.growth = parse_growth(&a.growth)?;
                    References::Tolerance(s)
                }
                (None, Some(f)) => References::Explicit(f),
                (None, None) => {
                    return Err(Error::InvalidSetting(
                        "linefit needs --ref-freqs F1,F2,... (Hz) or --tol".into(),
                    ))
                }
            };
            let mut opts = LineFitOptions::new(interface, references);
            opts.keep_basis = a.keep_basis;
            opts.sweep = a.sweep_setup()?.1;
            opts.cluster = cluster;
            Reductor::LineFit(opts)
        }
        "serep" => {
            let c = a
                .modes
                .ok_or_else(|| Error::InvalidSetting("serep needs --modes C".into()))?;
            Reductor::Serep(SerepOptions {
                modes: ModeChoice::LowestDeformation(c),
                retain: a
                    .retain
                    .as_deref()
                    .map(|r| names.indices(r, "--retain"))
                    .transpose()?,
                keep_basis: a.keep_basis,
                eigen: EigenOptions::for_band(scene.band_hz[1]),
            })
        }
        "craig-bampton" => {
            let c = a
                .modes
                .ok_or_else(|| Error::InvalidSetting("craig-bampton needs --modes C".into()))?;
            let interface = match (&a.interface, a.extra_interface) {
                (Some(i), _) => Interface::Explicit(names.indices(i, "--interface")?),
                (None, Some(k)) => Interface::OutputsPlus(k),
                (None, None) => Interface::Auto,
            };
            let mut opts = CraigBamptonOptions::new(interface, c, scene.band_hz[1]);
            opts.keep_basis = a.keep_basis;
            opts.threads = a.threads;
            Reductor::CraigBampton(opts)
        }
        m => {
            return Err(Error::InvalidSetting(format!(
                "--method '{m}': choose linefit, serep or craig-bampton"
            )))
        }
    })
}

/// The sampling loop's summary with the options it names worded as this command's flags.
pub(super) fn sampling_message(s: &SamplingReport, rom: &Rom) -> String {
    [("max_points", "--max-points"), ("max_order", "--max-order")]
        .iter()
        .fold(
            s.summary(rom.order(), rom.ref_freqs_hz().len()),
            |m, (field, flag)| m.replace(field, flag),
        )
}

fn print_rom(rom: &Rom) {
    println!("method           {}", rom.method());
    println!("order            {}", rom.order());
    if let Some(f) = rom.fit() {
        println!(
            "fit              cond(T_o) {:.2e} (equilibrated {:.2e}), rank {}/{}{}, residual max {:.2e} (DoF {}) mean {:.2e}",
            f.cond_raw,
            f.cond_equilibrated,
            f.rank,
            rom.order(),
            if f.truncated { " TRUNCATED" } else { "" },
            f.residual_max,
            f.residual_argmax_dof,
            f.residual_mean
        );
        let a = &f.solves;
        if a.frequencies > 0 {
            println!("solves           {}", solve_summary(a));
        }
    }
    if let Some(c) = rom.serep_cond() {
        println!("cond(U_cr)       {c:.2e}");
    }
    if let Some(cb) = rom.craig_bampton() {
        println!(
            "boundary         {} DoFs; K_ii by {}{}, constraint-mode residual {:.2e}",
            rom.dofs.len(),
            cb.factorization,
            cb.pivot_ratio
                .map(|r| format!(" (pivot ratio {r:.2e})"))
                .unwrap_or_default(),
            cb.static_residual
        );
        let eta = cb.mode_residuals.iter().copied().fold(0.0, f64::max);
        println!(
            "fixed-interface  {} modes, {} Hz, max backward error {eta:.2e}",
            cb.fixed_interface_hz.len(),
            hz_list(&cb.fixed_interface_hz, 1, ", ")
        );
    }
    let s = Stability::of(rom);
    for (name, class, d) in [
        ("Mr", s.mass, &rom.mass_definiteness),
        ("Kr", s.stiffness, &rom.stiffness_definiteness),
    ] {
        println!(
            "{name}               {class} (eigenvalues {:.3e} .. {:.3e})",
            d.min_eig, d.max_eig
        );
    }
    for t in &rom.timings {
        println!("time             {:<44} {:.4} s", t.phase, t.seconds);
    }
    for w in &rom.warnings {
        println!("warning          {w}");
    }
}

fn parse_growth(s: &str) -> Result<Growth> {
    match s {
        "auto" => Ok(Growth::Auto),
        "residual" => Ok(Growth::Residual),
        "qdeim" => Ok(Growth::QDeim),
        _ => Err(Error::InvalidSetting(format!(
            "--growth '{s}': choose auto, residual or qdeim"
        ))),
    }
}

/// How the full solves behind a ROM were made and how accurate they were.
pub fn solve_summary(a: &sparsemor::sweep::SolveAccuracy) -> String {
    let factored = a.frequencies - a.from_space;
    let mut parts = vec![format!(
        "{} full solves, {} factorizations",
        a.frequencies,
        a.factorizations()
    )];
    if a.from_space > 0 {
        parts.push(format!(
            "{} from a shifted Krylov space (dimension {}, {} block solves, worst relative residual {:.1e}{})",
            a.from_space,
            a.space_dim,
            a.space_block_solves,
            a.relative_residual_max,
            match a.space_disk_written {
                0 => String::new(),
                w => format!(
                    "; factor on disk: {} written, {} read",
                    super::args::human_bytes(w as f64),
                    super::args::human_bytes(a.space_disk_read as f64)
                ),
            }
        ));
    }
    if factored > 0 {
        parts.push(format!(
            "{factored} factored (worst probe error {:.1e}{})",
            a.probe_error_max,
            match a.refined {
                0 => String::new(),
                k => format!(", {k} refined"),
            }
        ));
    }
    parts.push(format!("worst backward error {:.1e}", a.backward_error_max));
    parts.join("; ")
}

fn print_steps(steps: &[Step]) {
    println!("| step | order | new points (Hz) | indicator max | true eps at new (or grid) | true eps at sampled | full solves | factorizations | time s | action |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    // a value the step did not measure (NaN in the library's report: the seed step has no
    // indicator, a growth step refits without new points) is left empty; the action says why
    let measured = |x: f64| {
        if x.is_nan() {
            String::new()
        } else {
            format!("{x:.2e}")
        }
    };
    for (k, s) in steps.iter().enumerate() {
        println!(
            "| {k} | {} | {} | {} | {} | {} | {} | {} | {:.3} | {} |",
            s.order,
            s.points_hz
                .iter()
                .map(|f| format!("{f:.1}"))
                .collect::<Vec<_>>()
                .join(", "),
            measured(s.indicator_max),
            measured(s.true_error_max),
            measured(s.sampled_error_max),
            s.solves,
            s.factorizations,
            s.seconds,
            s.action
        );
    }
}
