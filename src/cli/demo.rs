//! `sparsemor demo`: the paper's comparison on the built-in bar — line-fitting (order 14)
//! vs SEREP 9/9 and 14/14 and Craig–Bampton of order 14 — and the automatic path for two
//! tolerances.

use super::args::hz_list;
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::grid::linspace;
use sparsemor::metrics::{modal_comparison, rom_spectrum, ErrorCurve, Reference, Stability};
use sparsemor::reduce::craig_bampton::CraigBamptonOptions;
use sparsemor::reduce::interface::Interface;
use sparsemor::reduce::linefit::{LineFitOptions, References, SamplingOptions};
use sparsemor::reduce::serep::{ModeChoice, SerepOptions};
use sparsemor::reduce::{reduce, Context, CraigBamptonReport, Reductor, Rom};
use sparsemor::sweep::no_progress;
use sparsemor::Result;
use std::time::Instant;

/// Craig–Bampton at the demo's order 14: the boundary is the 9 outputs + 1 spread DoF (the
/// outputs' three nodes lie on one edge and do not hold the free bar's rotation about it),
/// plus 4 fixed-interface modes.
pub const CB_EXTRA_BOUNDARY: usize = 1;

/// The demo: the paper's bar, line-fitting (order 14) vs SEREP 9/9 and 14/14 and
/// Craig–Bampton (10 boundary DoFs + 4 modes), and the automatic path for tol 1e-2 and 1e-3.
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
        hz_list(&res, 1, ", "),
        eig_s
    );
    let mut opts = LineFitOptions::new(Interface::OutputsPlus(5), References::Count(20));
    opts.keep_basis = true;
    opts.sweep.threads = threads;
    let sweep = opts.sweep.clone();
    let t = Instant::now();
    let known = Context {
        known_modes: Some(&full),
        ..Context::default()
    };
    let lf = reduce(&body, &scene, &Reductor::LineFit(opts), &known)?;
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
        let known = Context {
            known_modes: Some(&serep_modes),
            ..Context::default()
        };
        let r = reduce(&body, &scene, &Reductor::Serep(opts), &known)?;
        Ok((r, t.elapsed().as_secs_f64()))
    };
    let (s9, s9_s) = serep(9, outputs.clone())?;
    let (s14, s14_s) = serep(14, lf.dofs.clone())?;
    let t = Instant::now();
    let mut cb_opts = CraigBamptonOptions::new(
        Interface::OutputsPlus(CB_EXTRA_BOUNDARY),
        lf.order() - outputs.len() - CB_EXTRA_BOUNDARY,
        band[1],
    );
    cb_opts.keep_basis = true;
    cb_opts.threads = threads;
    let cb = reduce(
        &body,
        &scene,
        &Reductor::CraigBampton(cb_opts),
        &Context::default(),
    )?;
    let cb_s = t.elapsed().as_secs_f64();
    let grid = linspace([1.0, band[1]], 500);
    println!();
    println!("| ROM | order | reduce s | max eps | mean eps | max eigfreq err | min MAC | largest ROM freq Hz | Mr, Kr |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let t = Instant::now();
    let reference = Reference::compute(&body, &scene, &grid, &sweep, None, &no_progress)?;
    for (name, rom, secs) in [
        ("line-fitting", &lf, lf_s),
        ("SEREP 9 modes / 9 DoFs", &s9, s9_s),
        ("SEREP 14 modes / 14 DoFs", &s14, s14_s),
        ("Craig–Bampton 10 boundary DoFs + 4 modes", &cb, cb_s),
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
        let fmax = rom_spectrum(rom)?
            .freqs_hz
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
            Stability::of(rom)
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
    if let Some(CraigBamptonReport {
        fixed_interface_hz,
        static_residual,
        factorization,
        ..
    }) = cb.craig_bampton()
    {
        println!(
            "Craig–Bampton: boundary {:?}; K_ii by {factorization}, constraint-mode residual {static_residual:.1e}; fixed-interface modes {} Hz",
            cb.dofs,
            hz_list(fixed_interface_hz, 1, ", ")
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
        let rom = reduce(&body, &scene, &Reductor::LineFit(o), &Context::default())?;
        let secs = t.elapsed().as_secs_f64();
        let grid_max = ErrorCurve::max_mean(&reference.error(&rom)?.eps_elastic).0;
        if let Some(r) = rom.sampling() {
            let (v, p) = r.verified.map_or((f64::NAN, 0), |v| (v.error, v.points));
            println!(
                "| {tol:.0e} | {} | {} (+ {p}) | {secs:.3} | {:.2e} | {v:.2e} ({p}) | {grid_max:.2e} | {} |",
                rom.order(),
                r.factorizations,
                r.error,
                if r.outcome.reached() && grid_max <= tol {
                    "yes"
                } else {
                    "NO"
                }
            );
        }
    }
    println!(
        "compute: line-fitting {lf_s:.3} s, SEREP {:.3} s + {:.3} s (+ {serep_eig_s:.3} s for their {} modes), Craig–Bampton {cb_s:.3} s, full eigenpairs {eig_s:.3} s, evaluation sweeps {eval_s:.2} s, total {:.2} s",
        s9_s,
        s14_s,
        serep_modes.lambdas.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
