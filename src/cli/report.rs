//! `report`: one self-contained HTML page (inline SVG, no scripts or external assets) that
//! compares ROMs with their full model — the paper's figures 4–7 and more (issue 9 item 4).

use super::args::hz_list;
use super::progress::with_progress;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::grid::linspace;
use sparsemor::io::{atomic, model_dir, rom_dir};
use sparsemor::metrics::{
    mac_matrix, ErrorCurve, MacMatrix, ModalComparison, Reference, Stability,
};
use sparsemor::reduce::linefit::Outcome;
use sparsemor::reduce::{Method, Rom};
use sparsemor::report::{
    chart_svg, heat_map_svg, tradeoff_svg, Chart, Draw, HeatMap, Series, TradeoffRow,
};
use sparsemor::scene::{positive_band, Scene};
use sparsemor::sweep::SweepOptions;
use sparsemor::{Error, Result};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct ReportArgs {
    /// Model directory.
    model: PathBuf,
    /// ROM directories of this model (one or more, all with the same inputs and outputs).
    #[arg(required = true)]
    roms: Vec<PathBuf>,
    /// Output directory (must not exist or be empty); gets index.html.
    #[arg(long)]
    out: PathBuf,
    /// CSV written by `sparsemor tradeoff --csv`: adds the speed/accuracy figure.
    #[arg(long)]
    tradeoff: Option<PathBuf>,
    /// Frequency grid over the model's band (full solves), both ends included.
    #[arg(long, default_value_t = 500)]
    points: usize,
    /// I/O pairs OUT:IN (output DoF : input DoF) whose |H| is plotted (default: the first
    /// output with the first input, and the last output with the first input).
    #[arg(long)]
    pairs: Option<String>,
    /// Tolerance line drawn on the ε(f) figure.
    #[arg(long)]
    tol: Option<f64>,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

/// One ROM and everything the page shows about it.
struct Evaluated {
    name: String,
    rom: Rom,
    curve: ErrorCurve,
    modal: ModalComparison,
    mac: MacMatrix,
}

/// Reads and checks every input, computes the full model's reference once, evaluates each
/// ROM and writes `index.html` into `--out` atomically (nothing is written on error).
pub fn report(a: &ReportArgs) -> Result<()> {
    // before the sweeps, not after
    atomic::check_dir_free(&a.out)?;
    let (body, scene) = model_dir::read_body(&a.model)?;
    let roms: Vec<(String, Rom)> = a
        .roms
        .iter()
        .map(|p| {
            let rom = rom_dir::read(p)?;
            rom.check_model(body.n())
                .map_err(|e| Error::InvalidSetting(format!("{}: {e}", p.display())))?;
            Ok((p.display().to_string(), rom))
        })
        .collect::<Result<_>>()?;
    let first = &roms[0].1;
    if let Some((name, _)) = roms
        .iter()
        .find(|(_, r)| r.inputs != first.inputs || r.outputs != first.outputs)
    {
        return Err(Error::InvalidSetting(format!(
            "{name} has other inputs/outputs than {}: a report compares ROMs of one scene",
            roms[0].0
        )));
    }
    let pairs = parse_pairs(a.pairs.as_deref(), &first.inputs, &first.outputs)?;
    let tradeoff = a
        .tradeoff
        .as_ref()
        .map(|p| {
            let text = std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?;
            TradeoffRow::parse_csv(&text, p)
        })
        .transpose()?;
    if let Some(t) = a.tol {
        if !(t > 0.0 && t.is_finite()) {
            return Err(Error::InvalidSetting(format!(
                "--tol {t}: must be a positive number"
            )));
        }
    }
    if a.points < 2 {
        return Err(Error::InvalidSetting("--points must be >= 2".into()));
    }
    let band = positive_band(scene.band_hz);
    let rom_scene = Scene {
        inputs: first.inputs.clone(),
        outputs: first.outputs.clone(),
        band_hz: band,
    };
    let freqs = linspace(band, a.points);
    let opts = SweepOptions {
        threads: a.threads,
        ..Default::default()
    };
    let reference = with_progress(freqs.len(), "full-model sweep", |cb| {
        Reference::compute(&body, &rom_scene, &freqs, &opts, None, cb)
    })?;
    let full = eigenpairs(&body, Request::UpTo(band[1]), &EigenOptions::default())?;
    let evaluated: Vec<Evaluated> = roms
        .into_iter()
        .map(|(name, rom)| {
            let mac = mac_matrix(&rom, &full, rom.basis.as_ref().map(|v| v.as_ref()))?;
            Ok(Evaluated {
                curve: reference.error(&rom)?,
                modal: ModalComparison::from_mac(&mac),
                mac,
                name,
                rom,
            })
        })
        .collect::<Result<_>>()?;
    let mut html = page_head(body.name(), body.n(), band, a.points, &evaluated);
    for &(o, i) in &pairs {
        figure(&mut html, &magnitude_svg(&reference, &evaluated, (o, i), band)?, &format!(
            "|H| from input DoF {i} to output DoF {o}: the full model's elastic transfer function H1 (black) and each ROM's Hr (dashed); dots mark a line-fitting ROM's reference frequencies (the paper's figures 4–5)."
        ));
    }
    figure(&mut html, &error_svg(&evaluated, a.tol, band)?,
        "ε(f) = ‖H − Hr‖_F / ‖H‖_F (eq. 23) over all inputs and outputs: elastic (solid, H1 against Hr) and total (dashed, H0 + H1 against H0 + Hr); the black dashed line is --tol (the paper's figures 6–7).");
    figure(&mut html, &eigen_error_svg(&evaluated, band)?,
        "Relative eigenfrequency error |f_r − f| / f of each full deformation mode in the band and its ROM partner (one-to-one MAC pairing); values below 1e-16 are drawn at 1e-16.");
    for e in &evaluated {
        figure(&mut html, &mac_svg(e)?, &format!(
            "MAC of the full deformation modes in the band (rows) against the ROM's elastic modes (columns) of {}, {}.",
            esc(&e.name),
            if e.mac.expanded { "ROM modes expanded to all DoFs by V" } else { "on the ROM's DoFs only (written without --keep-basis)" }
        ));
    }
    if let (Some(rows), Some(path)) = (&tradeoff, &a.tradeoff) {
        figure(
            &mut html,
            &tradeoff_svg(&format!("{}: time vs accuracy", body.name()), rows)?,
            &format!(
            "Speed/accuracy of the reductions in {}: wall time against verified max ε (eq. 23).",
            esc(&path.display().to_string())
        ),
        );
    }
    table(&mut html, &evaluated);
    html.push_str("</body>\n</html>\n");
    atomic::write_dir(&a.out, |tmp| {
        atomic::write_bytes(&tmp.join("index.html"), &html)
    })?;
    eprintln!("wrote {}", a.out.join("index.html").display());
    Ok(())
}

/// `--pairs OUT:IN,...` as (output DoF, input DoF), each checked against the scene.
fn parse_pairs(
    s: Option<&str>,
    inputs: &[usize],
    outputs: &[usize],
) -> Result<Vec<(usize, usize)>> {
    let Some(s) = s else {
        let mut p = vec![(outputs[0], inputs[0])];
        if outputs.len() > 1 {
            p.push((outputs[outputs.len() - 1], inputs[0]));
        }
        return Ok(p);
    };
    s.split(',')
        .map(|pair| {
            let bad = || {
                Error::InvalidSetting(format!(
                    "--pairs '{pair}': expected OUT:IN with OUT one of the outputs {outputs:?} and IN one of the inputs {inputs:?}"
                ))
            };
            let (o, i) = pair.trim().split_once(':').ok_or_else(bad)?;
            let (o, i): (usize, usize) = (
                o.trim().parse().map_err(|_| bad())?,
                i.trim().parse().map_err(|_| bad())?,
            );
            if outputs.contains(&o) && inputs.contains(&i) {
                Ok((o, i))
            } else {
                Err(bad())
            }
        })
        .collect()
}

/// |H| figure for output DoF `o`, input DoF `i` (log magnitude over the band).
fn magnitude_svg(
    r: &Reference,
    roms: &[Evaluated],
    (o, i): (usize, usize),
    band: [f64; 2],
) -> Result<String> {
    let (ro, ci) = (
        r.outputs.iter().position(|&d| d == o).unwrap_or(0),
        r.inputs.iter().position(|&d| d == i).unwrap_or(0),
    );
    let mut series = vec![Series {
        name: "full model".into(),
        points: r
            .freqs_hz
            .iter()
            .zip(&r.h1)
            .map(|(&f, h)| (f, h[(ro, ci)].norm()))
            .collect(),
        color: 0,
        draw: Draw::Line,
        labels: Vec::new(),
    }];
    for (k, e) in roms.iter().enumerate() {
        let at = |f: f64| (f, e.rom.transfer(f)[(ro, ci)].norm());
        series.push(Series {
            name: e.name.clone(),
            points: r.freqs_hz.iter().map(|&f| at(f)).collect(),
            color: k + 1,
            draw: Draw::Dashed,
            labels: Vec::new(),
        });
        if !e.rom.ref_freqs_hz().is_empty() {
            series.push(Series {
                name: format!("{}: reference frequencies", e.name),
                points: e.rom.ref_freqs_hz().iter().map(|&f| at(f)).collect(),
                color: k + 1,
                draw: Draw::Markers,
                labels: Vec::new(),
            });
        }
    }
    chart_svg(&Chart {
        title: format!("|H| output DoF {o} / input DoF {i}"),
        x_label: "frequency (Hz)".into(),
        y_label: "|H| (output per unit input)".into(),
        x_log: false,
        y_log: true,
        series,
        x_range: Some((band[0], band[1])),
    })
}

/// ε(f) figure (eq. 23): elastic and total per ROM, the tolerance as a horizontal line.
fn error_svg(roms: &[Evaluated], tol: Option<f64>, band: [f64; 2]) -> Result<String> {
    let mut series = Vec::new();
    for (k, e) in roms.iter().enumerate() {
        let c = &e.curve;
        for (part, eps, draw) in [
            ("elastic", &c.eps_elastic, Draw::Line),
            ("total", &c.eps_total, Draw::Dashed),
        ] {
            series.push(Series {
                name: format!("{}: {part}", e.name),
                points: c
                    .freqs_hz
                    .iter()
                    .copied()
                    .zip(eps.iter().copied())
                    .collect(),
                color: k + 1,
                draw,
                labels: Vec::new(),
            });
        }
    }
    if let Some(t) = tol {
        series.push(Series {
            name: format!("tolerance {t:.0e}"),
            points: vec![(band[0], t), (band[1], t)],
            color: 0,
            draw: Draw::Dashed,
            labels: Vec::new(),
        });
    }
    chart_svg(&Chart {
        title: "relative transfer-function error ε(f) (eq. 23)".into(),
        x_label: "frequency (Hz)".into(),
        y_label: "ε".into(),
        x_log: false,
        y_log: true,
        series,
        x_range: Some((band[0], band[1])),
    })
}

/// Eigenfrequency-error figure: one marker per paired full deformation mode and ROM.
fn eigen_error_svg(roms: &[Evaluated], band: [f64; 2]) -> Result<String> {
    let series = roms
        .iter()
        .enumerate()
        .map(|(k, e)| Series {
            name: e.name.clone(),
            points: e
                .modal
                .pairs
                .iter()
                .map(|p| (p.full_hz, p.rel_freq_error.max(1e-16)))
                .collect(),
            color: k + 1,
            draw: Draw::Markers,
            labels: Vec::new(),
        })
        .collect();
    chart_svg(&Chart {
        title: "relative eigenfrequency error per deformation mode".into(),
        x_label: "full-model eigenfrequency (Hz)".into(),
        y_label: "|f_r − f| / f".into(),
        x_log: false,
        y_log: true,
        series,
        x_range: Some((band[0], band[1])),
    })
}

/// MAC heat map of one ROM: full deformation modes (rows) × ROM elastic modes (columns).
fn mac_svg(e: &Evaluated) -> Result<String> {
    let m = &e.mac;
    let hz = |modes: &[(usize, f64)]| -> Vec<String> {
        modes.iter().map(|(_, f)| format!("{f:.0}")).collect()
    };
    heat_map_svg(&HeatMap {
        title: format!("MAC, {}", e.name),
        x_label: "ROM elastic mode (Hz)".into(),
        y_label: "full deformation mode (Hz)".into(),
        columns: hz(&m.rom),
        rows: hz(&m.full),
        values: (0..m.full.len())
            .map(|r| (0..m.rom.len()).map(|c| m.values[(r, c)]).collect())
            .collect(),
    })
}

/// Minimal HTML escaping for text and attribute values.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn page_head(name: &str, n: usize, band: [f64; 2], points: usize, roms: &[Evaluated]) -> String {
    let mut h = String::new();
    let _ = write!(
        h,
        r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>sparsemor report: {name}</title>
<style>
body {{ font-family: sans-serif; margin: 2em; color: #222; }}
figure {{ margin: 1.5em 0; }}
figcaption {{ max-width: 900px; font-size: 0.9em; color: #444; }}
table {{ border-collapse: collapse; font-size: 0.85em; }}
th, td {{ border: 1px solid #bbb; padding: 0.3em 0.5em; text-align: left; vertical-align: top; }}
</style>
</head>
<body>
<h1>sparsemor report: {name}</h1>
<p>Full model: N = {n}, band [{:.3}, {:.3}] Hz, {points} grid points (full solves). ROMs: {}.</p>
"#,
        band[0],
        band[1],
        roms.iter()
            .map(|e| format!("{} ({}, order {})", e.name, e.rom.method(), e.rom.order()))
            .collect::<Vec<_>>()
            .join(", "),
        name = esc(name),
    );
    h
}

fn figure(html: &mut String, svg: &str, caption: &str) {
    let _ = write!(
        html,
        "<figure>\n{svg}<figcaption>{caption}</figcaption>\n</figure>\n"
    );
}

/// The ROMs' numbers: one row per ROM.
fn table(html: &mut String, roms: &[Evaluated]) {
    html.push_str("<h2>The ROMs</h2>\n<table>\n<tr><th>ROM</th><th>method</th><th>order</th><th>factorizations</th><th>time (s) per phase</th><th>conditioning</th><th>Mr, Kr</th><th>max ε elastic / total (grid)</th><th>max eigenfrequency error, min MAC</th><th>tolerance</th><th>warnings</th></tr>\n");
    for e in roms {
        let r = &e.rom;
        let factorizations = match (r.sampling(), r.method()) {
            (Some(s), _) => format!(
                "{} (+ {} verification solves)",
                s.factorizations,
                s.verified.map_or(0, |v| v.points)
            ),
            (None, Method::LineFit) => r.ref_freqs_hz().len().to_string(),
            (None, Method::Serep) => "1 (eigensolver)".into(),
            (None, Method::CraigBampton) => match r.craig_bampton() {
                Some(cb) if cb.fixed_interface_hz.is_empty() => "1 (K_ii)".into(),
                _ => "2 (K_ii, eigensolver)".into(),
            },
        };
        let cond = match (r.fit(), r.serep_cond()) {
            (Some(f), _) => format!(
                "cond(T_o) {:.2e} (equilibrated {:.2e}), rank {}",
                f.cond_raw, f.cond_equilibrated, f.rank
            ),
            (None, Some(c)) => format!("cond(U_cr) {c:.2e}"),
            (None, None) => r
                .craig_bampton()
                .map(|cb| {
                    format!(
                        "K_ii by {}, constraint-mode residual {:.1e}",
                        cb.factorization, cb.static_residual
                    )
                })
                .unwrap_or_default(),
        };
        let pairs = &e.modal.pairs;
        let tolerance = r.sampling().map_or(String::new(), |s| {
            format!(
                "{:.1e} {}: loop error {:.2e}{}",
                s.tol,
                match s.outcome {
                    Outcome::Converged => "reached",
                    Outcome::Confirmed => "reached (confirmed by the verification pass)",
                    Outcome::Budget => "NOT reached (factorization budget spent)",
                    Outcome::Stagnated => "NOT reached (more frequencies stopped helping)",
                },
                s.error,
                s.verified.map_or(String::new(), |v| format!(
                    ", verified {:.2e} over {} full solves",
                    v.error, v.points
                ))
            )
        });
        let _ = writeln!(
            html,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{factorizations}</td><td>{}</td><td>{cond}</td><td>{}</td><td>{:.2e} / {:.2e}</td><td>{:.2e}, {:.4}{}</td><td>{tolerance}</td><td>{}</td></tr>",
            esc(&e.name),
            r.method(),
            r.order(),
            r.timings
                .iter()
                .map(|t| format!("{} {:.3}", esc(&t.phase), t.seconds))
                .collect::<Vec<_>>()
                .join("<br>"),
            Stability::of(r),
            ErrorCurve::max_mean(&e.curve.eps_elastic).0,
            ErrorCurve::max_mean(&e.curve.eps_total).0,
            pairs.iter().map(|p| p.rel_freq_error).fold(0.0, f64::max),
            pairs.iter().map(|p| p.mac).fold(1.0, f64::min),
            if e.modal.unpaired.is_empty() {
                String::new()
            } else {
                format!(
                    "; unpaired full modes at {} Hz",
                    hz_list(
                        &e.modal.unpaired.iter().map(|&(_, f)| f).collect::<Vec<_>>(),
                        1,
                        ", "
                    )
                )
            },
            r.warnings
                .iter()
                .map(|w| esc(w))
                .collect::<Vec<_>>()
                .join("<br>")
        );
    }
    html.push_str("</table>\n");
}
