//! `reduce`, `evaluate`, `modes`, `demo`.

use super::commands::{linspace, parse_band, parse_list};
use super::progress::with_progress;
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Modes, Request};
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::io::{atomic, model_dir, rom_dir};
use sparsemor::metrics::{
    modal_comparison, rom_eigenfrequencies, ErrorCurve, ModalComparison, Reference,
};
use sparsemor::reduce::linefit::{
    self, Growth, Interface, LineFitOptions, Outcome, References, SamplingOptions, SamplingReport,
    Step,
};
use sparsemor::reduce::serep::{self, ModeChoice, SerepOptions};
use sparsemor::reduce::Rom;
use sparsemor::report::{tradeoff_svg, TradeoffRow};
use sparsemor::scene::{positive_band, Scene};
use sparsemor::sweep::{no_progress, SweepOptions};
use sparsemor::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct ReduceArgs {
    /// Model directory.
    model: PathBuf,
    /// linefit or serep.
    #[arg(long)]
    method: String,
    /// Interface DoFs D1,D2,... (line-fitting; must contain the outputs).
    #[arg(long, conflicts_with = "extra_interface")]
    interface: Option<String>,
    /// Interface = outputs + K DoFs spread along the body (line-fitting; with --tol the
    /// default is K = ⌈outputs/2⌉).
    #[arg(long)]
    extra_interface: Option<usize>,
    /// Reference frequencies F1,F2,... in Hz (line-fitting; with --tol they are extra seeds).
    #[arg(long)]
    ref_freqs: Option<String>,
    /// Target accuracy: choose the reference frequencies automatically (line-fitting).
    #[arg(long)]
    tol: Option<f64>,
    /// Factorization budget of --tol.
    #[arg(long, default_value_t = 60)]
    max_points: usize,
    /// Largest order --tol may grow the interface to (default: min(max(3·n0, 40), N/2, memory)
    /// for the initial order n0; at most n0 keeps the order fixed).
    #[arg(long)]
    max_order: Option<usize>,
    /// Verification of --tol: full solves at P points spread over the band, their max error
    /// written to rom.toml (default ⌈F/3⌉ for F factorizations, ≈ 25 % of the run; 0 = none).
    #[arg(long, value_name = "P")]
    verify: Option<usize>,
    /// Interface growth rule of --tol: residual or qdeim.
    #[arg(long, default_value = "residual")]
    growth: String,
    /// Number of modes c (SEREP: the c lowest deformation modes).
    #[arg(long)]
    modes: Option<usize>,
    /// Retained DoFs (SEREP; default: the outputs).
    #[arg(long)]
    retain: Option<String>,
    /// Also write V.mtx (N×n).
    #[arg(long)]
    keep_basis: bool,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Output ROM directory.
    #[arg(long)]
    out: PathBuf,
}

pub fn reduce(a: &ReduceArgs) -> Result<super::Done> {
    let (model, scene, _) = model_dir::read(&a.model)?;
    let body = Body::new(&model)?;
    let t = Instant::now();
    let rom = match a.method.as_str() {
        "linefit" => {
            let interface = match (&a.interface, a.extra_interface, a.tol) {
                (Some(i), _, _) => Interface::Explicit(parse_list(i, "--interface")?),
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
            opts.sweep.threads = a.threads;
            let rom = match &opts.references {
                References::Explicit(f) => with_progress(f.len(), "reference frequencies", |cb| {
                    linefit::reduce(&body, &scene, &opts, None, cb)
                })?,
                References::Tolerance(s) => with_progress(s.max_points, "factorizations", |cb| {
                    linefit::reduce(&body, &scene, &opts, None, cb)
                })?,
                References::Count(_) => linefit::reduce(&body, &scene, &opts, None, &no_progress)?,
            };
            if let Some(s) = rom.sampling() {
                print_steps(&s.steps);
                println!("{}", sampling_message(s, &rom));
            }
            rom
        }
        "serep" => {
            let c = a
                .modes
                .ok_or_else(|| Error::InvalidSetting("serep needs --modes C".into()))?;
            let opts = SerepOptions {
                modes: ModeChoice::LowestDeformation(c),
                retain: a
                    .retain
                    .as_deref()
                    .map(|r| parse_list(r, "--retain"))
                    .transpose()?,
                keep_basis: a.keep_basis,
                eigen: EigenOptions::for_band(scene.band_hz[1]),
            };
            serep::reduce(&body, &scene, &opts, None)?
        }
        m => {
            return Err(Error::InvalidSetting(format!(
                "--method '{m}': choose linefit or serep"
            )))
        }
    };
    let secs = t.elapsed().as_secs_f64();
    rom_dir::write(&a.out, &rom)?;
    print_rom(&rom);
    eprintln!("reduced in {secs:.2} s -> {}", a.out.display());
    Ok(match rom.sampling() {
        Some(s) if s.outcome != Outcome::Converged => {
            eprintln!(
                "the ROM was written, but the tolerance {:.1e} was NOT met (error reached {:.2e}); exit status 3",
                s.tol, s.error
            );
            super::Done::RequestNotMet
        }
        _ => super::Done::Met,
    })
}

/// The sampling loop's summary with the options it names worded as this command's flags.
fn sampling_message(s: &SamplingReport, rom: &Rom) -> String {
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
    }
    if let Some(c) = rom.serep_cond() {
        println!("cond(U_cr)       {c:.2e}");
    }
    for (name, d) in [
        ("Mr", &rom.mass_definiteness),
        ("Kr", &rom.stiffness_definiteness),
    ] {
        println!(
            "{name}               {} (eigenvalues {:.3e} .. {:.3e})",
            if d.positive_definite {
                "positive definite"
            } else {
                "NOT positive definite"
            },
            d.min_eig,
            d.max_eig
        );
    }
    for t in &rom.timings {
        println!("time             {:<44} {:.4} s", t.phase, t.seconds);
    }
    for w in &rom.warnings {
        println!("warning          {w}");
    }
}

#[derive(clap::Args)]
pub struct EvaluateArgs {
    /// Model directory.
    model: PathBuf,
    /// ROM directory.
    rom: PathBuf,
    /// Band LO:HI in Hz (default: the model's band, starting at 1 Hz on a free body if it starts at 0).
    #[arg(long)]
    band: Option<String>,
    /// Grid points, both ends included.
    #[arg(long, default_value_t = 500)]
    points: usize,
    /// Write ε(f) as CSV: f_hz,eps_elastic,eps_total.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

/// The requested (or the scene's) band, starting above 0 Hz ([`positive_band`]).
fn evaluation_band(scene: &Scene, band: Option<&str>) -> Result<[f64; 2]> {
    Ok(positive_band(match band {
        Some(s) => parse_band(s)?,
        None => scene.band_hz,
    }))
}

pub fn evaluate(a: &EvaluateArgs) -> Result<()> {
    let (model, scene, _) = model_dir::read(&a.model)?;
    let rom = rom_dir::read(&a.rom)?;
    rom.check_model(&model)
        .map_err(|e| Error::InvalidSetting(format!("{}: {e}", a.rom.display())))?;
    let band = evaluation_band(&scene, a.band.as_deref())?;
    let body = Body::new(&model)?;
    let rom_scene = Scene {
        inputs: rom.inputs.clone(),
        outputs: rom.outputs.clone(),
        band_hz: band,
    };
    if a.points < 2 {
        return Err(Error::InvalidSetting("--points must be >= 2".into()));
    }
    let freqs = linspace(band, a.points);
    let opts = SweepOptions {
        threads: a.threads,
        ..Default::default()
    };
    let curve = with_progress(freqs.len(), "evaluate", |cb| {
        Reference::compute(&body, &rom_scene, &freqs, &opts, cb)?.error(&rom)
    })?;
    let full = eigenpairs(&body, Request::UpTo(band[1]), &EigenOptions::default())?;
    let modal = modal_comparison(&rom, &full, rom.basis.as_ref().map(|v| v.as_ref()))?;
    print_evaluation(&rom, &curve, &modal)?;
    if let Some(path) = &a.csv {
        write_eps_csv(path, &curve)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn print_evaluation(rom: &Rom, curve: &ErrorCurve, modal: &ModalComparison) -> Result<()> {
    let (emax, emean) = ErrorCurve::max_mean(&curve.eps_elastic);
    let (tmax, tmean) = ErrorCurve::max_mean(&curve.eps_total);
    println!(
        "eps elastic      max {:.3e}  mean {:.3e}   ({} points in [{}, {}] Hz)",
        emax,
        emean,
        curve.freqs_hz.len(),
        curve.freqs_hz[0],
        curve.freqs_hz[curve.freqs_hz.len() - 1]
    );
    println!("eps total        max {tmax:.3e}  mean {tmean:.3e}");
    let f = rom_eigenfrequencies(rom)?;
    println!(
        "ROM eigenfreqs   {}",
        f.iter()
            .map(|x| format!("{x:.1}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "largest          {:.1} Hz",
        f.last().copied().unwrap_or(f64::NAN)
    );
    println!(
        "stability        Mr {}, Kr {}",
        if rom.mass_definiteness.positive_definite {
            "SPD"
        } else {
            "NOT SPD"
        },
        if rom.stiffness_definiteness.positive_definite {
            "SPD"
        } else {
            "NOT SPD"
        }
    );
    println!(
        "modes in band    (MAC {})",
        if modal.expanded {
            "of expanded modes V·phi"
        } else {
            "on the ROM DoFs; --keep-basis gives expanded MAC"
        }
    );
    for p in &modal.pairs {
        println!(
            "  full {:>3} {:>9.2} Hz   rom {:>3} {:>9.2} Hz   rel err {:.2e}   MAC {:.5}",
            p.full_mode, p.full_hz, p.rom_mode, p.rom_hz, p.rel_freq_error, p.mac
        );
    }
    for (k, f) in &modal.unpaired {
        println!(
            "  full {k:>3} {f:>9.2} Hz   unpaired: beyond the ROM's {} modes",
            rom.order()
        );
    }
    Ok(())
}

fn write_eps_csv(path: &Path, c: &ErrorCurve) -> Result<()> {
    let mut s = String::from("f_hz,eps_elastic,eps_total\n");
    for k in 0..c.freqs_hz.len() {
        s.push_str(&format!(
            "{:?},{:?},{:?}\n",
            c.freqs_hz[k], c.eps_elastic[k], c.eps_total[k]
        ));
    }
    atomic::write_bytes(path, s)
}

#[derive(clap::Args)]
pub struct ModesArgs {
    /// Model directory.
    model: PathBuf,
    /// All modes with f <= HI (counted exactly); LO only filters the printout.
    #[arg(long, conflicts_with = "count")]
    band: Option<String>,
    /// The C lowest modes, rigid ones included.
    #[arg(long)]
    count: Option<usize>,
    /// CSV: index,f_hz,kind,lambda (rigid modes at 0 Hz with their computed lambda).
    #[arg(long)]
    csv: Option<PathBuf>,
}

pub fn modes(a: &ModesArgs) -> Result<()> {
    let (model, scene, _) = model_dir::read(&a.model)?;
    let body = Body::new(&model)?;
    let (req, lo) = match (&a.band, a.count) {
        (Some(b), _) => {
            let b = parse_band(b)?;
            (Request::UpTo(b[1]), b[0])
        }
        (None, Some(c)) => (Request::Lowest(c), f64::NEG_INFINITY),
        (None, None) => (Request::UpTo(scene.band_hz[1]), f64::NEG_INFINITY),
    };
    let t = Instant::now();
    let m = eigenpairs(&body, req, &EigenOptions::for_band(scene.band_hz[1]))?;
    let secs = t.elapsed().as_secs_f64();
    print_modes(&m, lo);
    println!(
        "{} modes ({} rigid) in {secs:.3} s: Cholesky {:.3} s, inertia count {:.3} s, Krylov {:.3} s ({} solves, {} restarts, dim {})",
        m.lambdas.len(),
        m.rigid,
        m.stats.factor_s,
        m.stats.count_s,
        m.stats.iterate_s,
        m.stats.solves,
        m.stats.restarts,
        m.stats.krylov_dim
    );
    if let Some(path) = &a.csv {
        let mut s = String::from("index,f_hz,kind,lambda\n");
        for (k, f) in m.freqs_hz().iter().enumerate() {
            s.push_str(&format!(
                "{},{:?},{},{:?}\n",
                k + 1,
                f,
                if k < m.rigid { "rigid" } else { "elastic" },
                m.lambdas[k]
            ));
        }
        atomic::write_bytes(path, s)?;
    }
    Ok(())
}

fn print_modes(m: &Modes, lo: f64) {
    for (k, f) in m.freqs_hz().iter().enumerate() {
        if *f >= lo || k < m.rigid {
            println!(
                "{:>4} {:>12.4} Hz  {:<8} backward error {:.1e}{}",
                k + 1,
                f,
                if k < m.rigid { "rigid" } else { "elastic" },
                m.residuals[k],
                if k < m.rigid {
                    format!("  (computed lambda {:.2e})", m.lambdas[k])
                } else {
                    String::new()
                }
            );
        }
    }
}

/// The demo: the paper's bar, line-fitting (order 14) vs SEREP 9/9 and 14/14.
pub fn demo(threads: usize) -> Result<()> {
    let t0 = Instant::now();
    let spec = BoxSpec::paper_bar();
    let model = bar_model(&spec)?;
    let scene = paper_scene(&spec);
    let body = Body::new(&model)?;
    let (inputs, outputs) = (&scene.inputs, &scene.outputs);
    let band = scene.band_hz;
    println!(
        "paper bar: {} x {} x {} mm, N = {}, {} inputs = outputs, band [{}, {}] Hz, Rayleigh beta = {:e}",
        spec.size_m[0] * 1e3,
        spec.size_m[1] * 1e3,
        spec.size_m[2] * 1e3,
        model.n(),
        inputs.len(),
        band[0],
        band[1],
        sparsemor::fe::PAPER_RAYLEIGH_BETA
    );
    let t = Instant::now();
    let full = eigenpairs(&body, Request::UpTo(band[1]), &EigenOptions::default())?;
    let eig_s = t.elapsed().as_secs_f64();
    let res: Vec<f64> = full.freqs_hz()[full.rigid..].to_vec();
    println!(
        "full model: {} rigid + {} deformation modes below {} Hz: {} Hz ({:.3} s)",
        full.rigid,
        res.len(),
        band[1],
        res.iter()
            .map(|f| format!("{f:.1}"))
            .collect::<Vec<_>>()
            .join(", "),
        eig_s
    );
    let mut opts = LineFitOptions::new(Interface::OutputsPlus(5), References::Count(20));
    opts.keep_basis = true;
    opts.sweep.threads = threads;
    let t = Instant::now();
    let lf = linefit::reduce(&body, &scene, &opts, Some(&full), &no_progress)?;
    let lf_s = t.elapsed().as_secs_f64();
    println!(
        "line-fitting: interface {:?}; 20 reference frequencies {} Hz",
        lf.dofs,
        lf.ref_freqs_hz()
            .iter()
            .map(|f| format!("{f:.0}"))
            .collect::<Vec<_>>()
            .join(",")
    );
    // one eigensolve serves both SEREP ROMs
    let t = Instant::now();
    let serep_modes = eigenpairs(
        &body,
        Request::Lowest(full.rigid + 14),
        &EigenOptions::for_band(band[1]),
    )?;
    let serep_eig_s = t.elapsed().as_secs_f64();
    let serep = |c: usize, retain: Vec<usize>| -> Result<(Rom, f64)> {
        let t = Instant::now();
        let opts = SerepOptions {
            modes: ModeChoice::LowestDeformation(c),
            retain: Some(retain),
            keep_basis: true,
            eigen: EigenOptions::for_band(band[1]),
        };
        let r = serep::reduce(&body, &scene, &opts, Some(&serep_modes))?;
        Ok((r, t.elapsed().as_secs_f64()))
    };
    let (s9, s9_s) = serep(9, outputs.clone())?;
    let (s14, s14_s) = serep(14, lf.dofs.clone())?;
    let grid = linspace([1.0, band[1]], 500);
    println!();
    println!("| ROM | order | reduce s | max eps | mean eps | max eigfreq err | min MAC | largest ROM freq Hz | Mr, Kr SPD |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let t = Instant::now();
    let reference = Reference::compute(&body, &scene, &grid, &opts.sweep, &no_progress)?;
    for (name, rom, secs) in [
        ("line-fitting", &lf, lf_s),
        ("SEREP 9 modes / 9 DoFs", &s9, s9_s),
        ("SEREP 14 modes / 14 DoFs", &s14, s14_s),
    ] {
        let curve = reference.error(rom)?;
        let modal = modal_comparison(rom, &full, rom.basis.as_ref().map(|v| v.as_ref()))?;
        let (emax, emean) = ErrorCurve::max_mean(&curve.eps_elastic);
        let ferr = modal
            .pairs
            .iter()
            .map(|p| p.rel_freq_error)
            .fold(0.0, f64::max);
        let mac = modal.pairs.iter().map(|p| p.mac).fold(1.0, f64::min);
        let fmax = rom_eigenfrequencies(rom)?
            .last()
            .copied()
            .unwrap_or(f64::NAN);
        println!(
            "| {name} | {} | {secs:.3} | {:.2} % | {:.2} % | {:.2e} | {:.4} | {:.0} | {} |",
            rom.order(),
            100.0 * emax,
            100.0 * emean,
            ferr,
            mac,
            fmax,
            if rom.mass_definiteness.positive_definite
                && rom.stiffness_definiteness.positive_definite
            {
                "yes"
            } else {
                "NO"
            }
        );
    }
    println!();
    println!(
        "eps = elastic transfer-function error (eq. 23) on 500 points in [1, {}] Hz; eigenfrequency error and MAC over the {} deformation modes in the band (expanded modes, one-to-one MAC pairing)",
        band[1],
        res.len()
    );
    if let Some(f) = lf.fit() {
        println!(
            "line-fitting fit: cond(T_o) {:.2e} (equilibrated {:.2e}), rank {}, max residual {:.2e} at DoF {}",
            f.cond_raw, f.cond_equilibrated, f.rank, f.residual_max, f.residual_argmax_dof
        );
    }
    let eval_s = t.elapsed().as_secs_f64();
    println!();
    println!("The automatic path: `reduce --method linefit --tol T` and nothing else (interface = outputs + 5, growing as needed; reference frequencies chosen by the sampling loop):");
    println!();
    println!("| tol | order | factorizations (+ verification) | reduce s | loop error | verified max eps (its points) | max eps, 500-point grid | met |");
    println!("|---|---|---|---|---|---|---|---|");
    for tol in [1e-2, 1e-3] {
        let mut o = LineFitOptions::new(
            Interface::Auto,
            References::Tolerance(SamplingOptions::new(tol)),
        );
        o.sweep.threads = threads;
        let t = Instant::now();
        let rom = linefit::reduce(&body, &scene, &o, None, &no_progress)?;
        let secs = t.elapsed().as_secs_f64();
        let grid_max = ErrorCurve::max_mean(&reference.error(&rom)?.eps_elastic).0;
        if let Some(r) = rom.sampling() {
            let (v, p) = r.verified.map_or((f64::NAN, 0), |v| (v.error, v.points));
            println!(
                "| {tol:.0e} | {} | {} (+ {p}) | {secs:.3} | {:.2e} | {v:.2e} ({p}) | {grid_max:.2e} | {} |",
                rom.order(),
                r.factorizations,
                r.error,
                if r.outcome == Outcome::Converged && grid_max <= tol {
                    "yes"
                } else {
                    "NO"
                }
            );
        }
    }
    println!(
        "compute: line-fitting {lf_s:.3} s, SEREP {:.3} s + {:.3} s (+ {serep_eig_s:.3} s for their {} modes), full eigenpairs {eig_s:.3} s, evaluation sweeps {eval_s:.2} s, total {:.2} s",
        s9_s,
        s14_s,
        serep_modes.lambdas.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

fn parse_growth(s: &str) -> Result<Growth> {
    match s {
        "residual" => Ok(Growth::Residual),
        "qdeim" => Ok(Growth::QDeim),
        _ => Err(Error::InvalidSetting(format!(
            "--growth '{s}': choose residual or qdeim"
        ))),
    }
}

fn print_steps(steps: &[Step]) {
    println!("| step | order | new points (Hz) | indicator max | true eps at new | true eps at sampled | factorizations | time s | action |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for (k, s) in steps.iter().enumerate() {
        println!(
            "| {k} | {} | {} | {:.2e} | {:.2e} | {:.2e} | {} | {:.3} | {} |",
            s.order,
            s.points_hz
                .iter()
                .map(|f| format!("{f:.1}"))
                .collect::<Vec<_>>()
                .join(", "),
            s.indicator_max,
            s.true_error_max,
            s.sampled_error_max,
            s.factorizations,
            s.seconds,
            s.action
        );
    }
}

#[derive(clap::Args)]
pub struct TradeoffArgs {
    /// Model directory.
    model: PathBuf,
    /// Tolerances of the sampling loop.
    #[arg(long, default_value = "1e-1,1e-2,1e-3,1e-4")]
    tols: String,
    /// Initial interface: outputs + K spread DoFs.
    #[arg(long, default_value_t = 5)]
    extra_interface: usize,
    /// Largest order the sampling loop may grow to.
    #[arg(long, default_value_t = 40)]
    max_order: usize,
    /// Factorization budget per tolerance.
    #[arg(long, default_value_t = 80)]
    max_points: usize,
    /// SEREP mode counts c to compare (c retained DoFs: the outputs first, then spread DoFs).
    #[arg(long, default_value = "3,6,9,12,15,20")]
    serep_modes: String,
    /// Verification grid points over the band (full solves).
    #[arg(long, default_value_t = 2000)]
    points: usize,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// CSV output: method,setting,seconds,factorizations,order,max_eps.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// SVG plot output.
    #[arg(long)]
    svg: Option<PathBuf>,
}

/// Speed vs accuracy: the sampling loop per tolerance and SEREP per mode count, each
/// verified on a fine grid by full solves (computed once).
pub fn tradeoff(a: &TradeoffArgs) -> Result<()> {
    let (model, scene, _) = model_dir::read(&a.model)?;
    let body = Body::new(&model)?;
    let outputs = &scene.outputs;
    let tols: Vec<f64> = parse_list(&a.tols, "--tols")?;
    let modes: Vec<usize> = parse_list(&a.serep_modes, "--serep-modes")?;
    let sweep = SweepOptions {
        threads: a.threads,
        ..Default::default()
    };
    let grid = linspace(positive_band(scene.band_hz), a.points.max(2));
    let t = Instant::now();
    let reference = with_progress(grid.len(), "verification grid", |cb| {
        Reference::compute(&body, &scene, &grid, &sweep, cb)
    })?;
    eprintln!(
        "verification grid: {} full solves in {:.1} s",
        grid.len(),
        t.elapsed().as_secs_f64()
    );
    let mut rows: Vec<TradeoffRow> = Vec::new();
    for &tol in &tols {
        let mut s = SamplingOptions::new(tol);
        s.max_order = Some(a.max_order);
        s.max_points = a.max_points;
        // verified below on the common grid
        s.verify_points = Some(0);
        let mut o = LineFitOptions::new(
            Interface::OutputsPlus(a.extra_interface),
            References::Tolerance(s),
        );
        o.sweep = sweep.clone();
        let t = Instant::now();
        let rom = linefit::reduce(&body, &scene, &o, None, &no_progress)?;
        let secs = t.elapsed().as_secs_f64();
        let e = ErrorCurve::max_mean(&reference.error(&rom)?.eps_elastic).0;
        let report = rom
            .sampling()
            .ok_or_else(|| Error::InvalidSetting("the sampling loop returned no report".into()))?;
        rows.push(TradeoffRow {
            method: "linefit".into(),
            setting: format!("tol {tol:.0e}"),
            seconds: secs,
            factorizations: report.factorizations,
            order: rom.order(),
            max_eps: e,
        });
        if report.outcome != Outcome::Converged {
            eprintln!("tol {tol:.0e}: {}", sampling_message(report, &rom));
        }
    }
    for &c in &modes {
        // r = c retained DoFs (SEREP needs c >= r): the outputs first, then spread DoFs
        let mut retain: Vec<usize> = outputs.iter().copied().take(c).collect();
        if c > retain.len() {
            retain.extend(linefit::spread_dofs(&model, c - retain.len(), outputs)?);
        }
        let t = Instant::now();
        let opts = SerepOptions {
            modes: ModeChoice::LowestDeformation(c),
            retain: Some(retain),
            keep_basis: false,
            eigen: EigenOptions::for_band(scene.band_hz[1]),
        };
        let rom = serep::reduce(&body, &scene, &opts, None)?;
        let secs = t.elapsed().as_secs_f64();
        let e = ErrorCurve::max_mean(&reference.error(&rom)?.eps_elastic).0;
        rows.push(TradeoffRow {
            method: "serep".into(),
            setting: format!("{c} modes"),
            seconds: secs,
            factorizations: 1,
            order: rom.order(),
            max_eps: e,
        });
    }
    println!(
        "| method | setting | wall s | factorizations | order | verified max eps ({} points) |",
        grid.len()
    );
    println!("|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {} | {:.3} | {} | {} | {:.2e} |",
            r.method, r.setting, r.seconds, r.factorizations, r.order, r.max_eps
        );
    }
    if let Some(path) = &a.csv {
        atomic::write_bytes(path, TradeoffRow::to_csv(&rows))?;
    }
    if let Some(path) = &a.svg {
        let svg = tradeoff_svg(&format!("{}: time vs accuracy", model.name), &rows)?;
        atomic::write_bytes(path, svg)?;
    }
    Ok(())
}
