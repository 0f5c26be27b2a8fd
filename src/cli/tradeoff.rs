//! `sparsemor tradeoff`: speed vs accuracy — the sampling loop per tolerance, SEREP per
//! mode count and Craig–Bampton per number of fixed-interface modes, each verified on one
//! fine grid of full solves.

use super::args::parse_list;
use super::progress::with_progress;
use super::reduce::sampling_message;
use sparsemor::eigen::EigenOptions;
use sparsemor::grid::linspace;
use sparsemor::io::{atomic, model_dir};
use sparsemor::metrics::{ErrorCurve, Reference};
use sparsemor::reduce::craig_bampton::CraigBamptonOptions;
use sparsemor::reduce::interface::{spread_dofs, Interface};
use sparsemor::reduce::linefit::{LineFitOptions, References, SamplingOptions};
use sparsemor::reduce::serep::{ModeChoice, SerepOptions};
use sparsemor::reduce::{reduce, Context, Reductor};
use sparsemor::report::{tradeoff_svg, TradeoffRow};
use sparsemor::scene::positive_band;
use sparsemor::sweep::SweepOptions;
use sparsemor::{Error, Result};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct TradeoffArgs {
    /// Model directory.
    model: PathBuf,
    /// Tolerances of the sampling loop.
    #[arg(long, default_value = "1e-1,1e-2,1e-3,1e-4")]
    tols: String,
    /// Initial interface: outputs + K spread DoFs (default: as `reduce --tol`).
    #[arg(long)]
    extra_interface: Option<usize>,
    /// Largest order the sampling loop may grow to (default: as `reduce --tol`).
    #[arg(long)]
    max_order: Option<usize>,
    /// Budget of full solves per tolerance (default: as `reduce --tol`).
    #[arg(long)]
    max_points: Option<usize>,
    /// SEREP mode counts c to compare (c retained DoFs: the outputs first, then spread DoFs).
    #[arg(long, default_value = "3,6,9,12,15,20")]
    serep_modes: String,
    /// Craig–Bampton fixed-interface mode counts c to compare (boundary: the outputs +
    /// --cb-extra-boundary spread DoFs).
    #[arg(long, default_value = "0,2,4,8,16,32")]
    cb_modes: String,
    /// Craig–Bampton boundary: outputs + K spread DoFs (a free body needs a boundary that
    /// holds its rigid motions).
    #[arg(long, default_value_t = 1)]
    cb_extra_boundary: usize,
    /// Verification grid points over the band (full solves).
    #[arg(long, default_value_t = 2000)]
    points: usize,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// CSV output: method,setting,seconds,factorizations,order,max_eps,solves.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// SVG plot output.
    #[arg(long)]
    svg: Option<PathBuf>,
}

/// Speed vs accuracy: the sampling loop per tolerance and SEREP per mode count, each
/// verified on a fine grid by full solves (computed once).
pub fn tradeoff(a: &TradeoffArgs) -> Result<()> {
    let (body, scene) = model_dir::read_body(&a.model)?;
    let outputs = &scene.outputs;
    let tols: Vec<f64> = parse_list(&a.tols, "--tols")?;
    let modes: Vec<usize> = parse_list(&a.serep_modes, "--serep-modes")?;
    let cb_modes: Vec<usize> = parse_list(&a.cb_modes, "--cb-modes")?;
    let sweep = SweepOptions {
        threads: a.threads,
        ..Default::default()
    };
    let grid = linspace(positive_band(scene.band_hz), a.points.max(2));
    let t = Instant::now();
    let reference = with_progress(grid.len(), "verification grid", |cb| {
        Reference::compute(&body, &scene, &grid, &sweep, None, cb)
    })?;
    eprintln!(
        "verification grid: {} full solves in {:.1} s",
        grid.len(),
        t.elapsed().as_secs_f64()
    );
    let mut rows: Vec<TradeoffRow> = Vec::new();
    for &tol in &tols {
        let mut s = SamplingOptions::new(tol);
        s.max_order = a.max_order;
        s.max_points = a.max_points;
        // verified below on the common grid
        s.verify_points = Some(0);
        let interface = a
            .extra_interface
            .map_or(Interface::Auto, Interface::OutputsPlus);
        let mut o = LineFitOptions::new(interface, References::Tolerance(s));
        o.sweep = sweep.clone();
        let t = Instant::now();
        let rom = reduce(&body, &scene, &Reductor::LineFit(o), &Context::default())?;
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
            solves: Some(report.solves),
            order: rom.order(),
            max_eps: e,
        });
        if !report.outcome.reached() {
            eprintln!("tol {tol:.0e}: {}", sampling_message(report, &rom));
        }
    }
    for &c in &modes {
        // r = c retained DoFs (SEREP needs c >= r): the outputs first, then spread DoFs
        let mut retain: Vec<usize> = outputs.iter().copied().take(c).collect();
        if c > retain.len() {
            retain.extend(spread_dofs(&body, c - retain.len(), outputs)?);
        }
        let t = Instant::now();
        let opts = SerepOptions {
            modes: ModeChoice::LowestDeformation(c),
            retain: Some(retain),
            keep_basis: false,
            eigen: EigenOptions::for_band(scene.band_hz[1]),
        };
        let rom = reduce(&body, &scene, &Reductor::Serep(opts), &Context::default())?;
        let secs = t.elapsed().as_secs_f64();
        let e = ErrorCurve::max_mean(&reference.error(&rom)?.eps_elastic).0;
        rows.push(TradeoffRow {
            method: "serep".into(),
            setting: format!("{c} modes"),
            seconds: secs,
            factorizations: 1,
            solves: None,
            order: rom.order(),
            max_eps: e,
        });
    }
    for &c in &cb_modes {
        let mut opts = CraigBamptonOptions::new(
            Interface::OutputsPlus(a.cb_extra_boundary),
            c,
            scene.band_hz[1],
        );
        opts.threads = a.threads;
        let t = Instant::now();
        let rom = reduce(
            &body,
            &scene,
            &Reductor::CraigBampton(opts),
            &Context::default(),
        )?;
        let secs = t.elapsed().as_secs_f64();
        let e = ErrorCurve::max_mean(&reference.error(&rom)?.eps_elastic).0;
        rows.push(TradeoffRow {
            method: "craig-bampton".into(),
            setting: format!("{c} modes"),
            seconds: secs,
            // K_ii, and K_ii − σM_ii of the eigensolver when c > 0
            factorizations: if c == 0 { 1 } else { 2 },
            solves: None,
            order: rom.order(),
            max_eps: e,
        });
    }
    println!(
        "| method | setting | wall s | factorizations | full solves | order | verified max eps ({} points) |",
        grid.len()
    );
    println!("|---|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {} | {:.3} | {} | {} | {} | {:.2e} |",
            r.method,
            r.setting,
            r.seconds,
            r.factorizations,
            r.solves.map_or("—".to_string(), |n| n.to_string()),
            r.order,
            r.max_eps
        );
    }
    println!();
    println!("| line-fitting | fastest Craig–Bampton at least as accurate | time ratio |");
    println!("|---|---|---|");
    for (l, cb) in TradeoffRow::equal_accuracy(&rows) {
        let lf = &rows[l];
        let (other, ratio) = match cb {
            Some(c) => (
                format!(
                    "{}: {:.2e}, {:.3} s, order {}",
                    rows[c].setting, rows[c].max_eps, rows[c].seconds, rows[c].order
                ),
                format!("{:.2}", lf.seconds / rows[c].seconds),
            ),
            None => ("none of the rows above".into(), "—".into()),
        };
        println!(
            "| {}: {:.2e}, {:.3} s, order {} | {} | {} |",
            lf.setting, lf.max_eps, lf.seconds, lf.order, other, ratio
        );
    }
    if let Some(path) = &a.csv {
        atomic::write_bytes(path, TradeoffRow::to_csv(&rows))?;
    }
    if let Some(path) = &a.svg {
        let svg = tradeoff_svg(&format!("{}: time vs accuracy", body.name()), &rows)?;
        atomic::write_bytes(path, svg)?;
    }
    Ok(())
}
