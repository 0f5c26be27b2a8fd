//! Iterative frequency sampling (docs/design.md §3.5) on the built-in bar: verified accuracy on a
//! 2000-point grid, the indicator against the true error, no re-factorization, clear
//! messages when a tolerance cannot be reached.

use crate::common::*;
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::metrics::Reference;
use sparsemor::model::Model;
use sparsemor::reduce::linefit::{
    self, place_reference_frequencies, Growth, Indicator, Interface, LineFitOptions, Outcome,
    References, SamplingOptions, SamplingReport,
};
use sparsemor::reduce::Rom;
use sparsemor::scene::Scene;
use sparsemor::sweep::{no_progress, Progress, ProgressFn, SolveMethod, SweepOptions};
use sparsemor::Error;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

fn bar() -> &'static (Model, Scene, Reference) {
    static BAR: OnceLock<(Model, Scene, Reference)> = OnceLock::new();
    BAR.get_or_init(|| {
        let spec = BoxSpec::paper_bar();
        let (m, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
        let grid: Vec<f64> = (0..2000).map(|k| 1.0 + 999.0 * k as f64 / 1999.0).collect();
        let body = Body::new(&m).unwrap();
        let r = full_reference(&body, &scene, &grid);
        (m, scene, r)
    })
}

/// Line-fitting with the tolerance-driven sampling loop, interface = outputs + `extra`.
fn sampled(
    m: &Model,
    scene: &Scene,
    s: SamplingOptions,
    extra: usize,
    threads: usize,
    progress: ProgressFn<'_>,
) -> sparsemor::Result<Rom> {
    sampled_with(m, scene, s, extra, threads, SolveMethod::Auto, progress)
}

/// [`sampled`] with the responses computed by `method`: [`SolveMethod::Factored`] runs the
/// loop on its residual indicator, [`SolveMethod::Auto`] (the bar's damping is proportional)
/// on the true error over the candidate grid from the shifted Krylov space.
fn sampled_with(
    m: &Model,
    scene: &Scene,
    s: SamplingOptions,
    extra: usize,
    threads: usize,
    method: SolveMethod,
    progress: ProgressFn<'_>,
) -> sparsemor::Result<Rom> {
    let mut o = LineFitOptions::new(Interface::OutputsPlus(extra), References::Tolerance(s));
    o.sweep.threads = threads;
    o.sweep.method = method;
    linefit::reduce(&Body::new(m)?, scene, &o, None, progress)
}

/// `reduce --tol tol` alone: line-fitting with the default interface and sampling options.
fn by_default(body: &Body, scene: &Scene, tol: f64) -> Rom {
    let s = SamplingOptions::new(tol);
    let o = LineFitOptions::new(Interface::Auto, References::Tolerance(s));
    linefit::reduce(body, scene, &o, None, &no_progress).unwrap()
}

fn report(rom: &Rom) -> &SamplingReport {
    rom.sampling().expect("a sampling report")
}

/// How far apart two certified responses of one frequency may put a ROM's relative error ε
/// when they come from different Krylov spaces (the loop's, about the band's top, and a
/// reference sweep's, below the spectrum): their relative difference, measured 1e-11…3e-11
/// on the coarse bar (`shifted_space` tests), with a margin.
const RESPONSES_AGREE: f64 = 1e-9;

fn verified_max(reference: &Reference, rom: &sparsemor::reduce::Rom) -> f64 {
    reference
        .error(rom)
        .unwrap()
        .eps_elastic
        .iter()
        .copied()
        .fold(0.0, f64::max)
}

#[test]
fn tolerances_are_met_on_a_fine_grid() {
    let (m, scene, reference) = bar();
    for (tol, growth) in [
        (1e-2, Growth::Residual),
        (1e-3, Growth::Residual),
        (1e-3, Growth::QDeim),
    ] {
        let mut o = SamplingOptions::new(tol);
        o.max_order = Some(40);
        o.growth = growth;
        let rom = sampled(m, scene, o, 5, 0, &no_progress).unwrap();
        let r = report(&rom);
        let v = verified_max(reference, &rom);
        println!(
            "tol {tol:.0e} ({growth:?}): {:?}, order {}, {}, verified max eps over 2000 points {v:.3e}",
            r.outcome,
            rom.order(),
            r.cost()
        );
        assert!(
            r.outcome.reached(),
            "{}",
            r.summary(rom.order(), rom.ref_freqs_hz().len())
        );
        assert!(v <= tol, "verified {v:.3e} > tol {tol:.0e}");
    }
}

/// `--tol T` and nothing else: the interface starts at outputs + ⌈q/2⌉, grows up to the
/// automatic cap, and the returned ROM meets the tolerance on 2000 full solves over the band.
/// The verification pass reports the max over its points: on the same 2000 points it equals
/// the independent reference's maximum.
#[test]
fn defaults_reach_the_tolerance_and_report_what_was_written() {
    let (m, scene, reference) = bar();
    let body = Body::new(m).unwrap();
    for tol in [1e-2, 1e-3, 1e-4] {
        let o = LineFitOptions::new(
            Interface::Auto,
            References::Tolerance(SamplingOptions::new(tol)),
        );
        let rom = linefit::reduce(&body, scene, &o, None, &no_progress).unwrap();
        let r = report(&rom);
        let v = verified_max(reference, &rom);
        let stored = r.verified.expect("verification runs by default");
        println!(
            "tol {tol:.0e}, defaults: {:?}, order {}, {} (+{} verification), loop error {:.3e}, verified {:.3e}, 2000-point max {v:.3e}",
            r.outcome,
            rom.order(),
            r.cost(),
            stored.points,
            r.error,
            stored.error
        );
        assert!(r.outcome.reached(), "{:?}", r.outcome);
        assert!(v <= tol, "tol {tol:.0e}: 2000-point max {v:.3e}");
        // a subset max cannot exceed the grid max, but for the responses' own difference:
        // the loop's space (about the band's top) and the reference's (below the spectrum)
        // agree to their certificates, ~1e-11 relative
        assert!(
            stored.error <= v + RESPONSES_AGREE,
            "a subset max cannot exceed the grid max"
        );
    }
    let mut s = SamplingOptions::new(1e-3);
    s.verify_points = Some(2000);
    let o = LineFitOptions::new(Interface::Auto, References::Tolerance(s));
    let rom = linefit::reduce(&body, scene, &o, None, &no_progress).unwrap();
    let stored = report(&rom).verified.unwrap().error;
    let v = verified_max(reference, &rom);
    assert!(
        (stored - v).abs() <= 0.01 * v,
        "stored {stored:.4e} vs reference {v:.4e}"
    );
}

/// A loop that stops on its budget right after its first step within tol: the best ROM has
/// one measurement within tol, the verification pass gives the second, at evenly spread
/// points, at the indicator's next maxima and by a local search around the worst measured
/// point. Within tol there, the outcome is `Confirmed` and the ROM is within tol on the
/// independent 2000-point reference; above tol, it is `Budget` and the 2000-point maximum
/// is above tol too (at tol 1e-4 the search finds the hump a few Hz from the measured
/// point). Without verification (`verify_points = 0`) the same stop is NOT reached.
#[test]
fn a_budget_stop_after_one_step_within_tol_is_confirmed_by_the_verification() {
    let (m, scene, reference) = bar();
    let mut confirmed = 0;
    for tol in [1e-2, 1e-3, 1e-4] {
        // the two-step rule of the indicator loop (factored responses)
        let run = |s| sampled_with(m, scene, s, 5, 1, SolveMethod::Factored, &no_progress);
        let free = run(SamplingOptions::new(tol)).unwrap();
        let steps = &report(&free).steps;
        let first_ok = steps
            .iter()
            .find(|s| s.true_error_max.max(s.sampled_error_max) <= tol)
            .expect("the free run has a step within tol");
        assert_eq!(report(&free).outcome, Outcome::Converged);
        for verify in [None, Some(0)] {
            let mut s = SamplingOptions::new(tol);
            s.max_points = Some(first_ok.solves);
            s.verify_points = verify;
            let rom = run(s).unwrap();
            let r = report(&rom);
            let v = verified_max(reference, &rom);
            println!(
                "tol {tol:.0e}, budget {} (verify {verify:?}): {:?}, error {:.3e}, verified {:?}, 2000-point max {v:.3e}",
                first_ok.solves,
                r.outcome,
                r.error,
                r.verified.map(|v| (v.points, v.error))
            );
            assert!(r.error <= tol, "{:.3e}", r.error);
            match (verify, &r.outcome) {
                (None, Outcome::Confirmed) => {
                    confirmed += 1;
                    assert!(r.verified.unwrap().error <= tol);
                    assert!(v <= tol, "confirmed, but the 2000-point max is {v:.3e}");
                    assert!(r
                        .summary(rom.order(), rom.ref_freqs_hz().len())
                        .contains("confirmed"));
                }
                (None, Outcome::Budget) => {
                    assert!(
                        r.verified.unwrap().error > tol,
                        "refused, yet verified within tol"
                    );
                    assert!(v > tol, "refused, yet within tol on 2000 points: {v:.3e}");
                }
                (Some(_), o) => assert_eq!(*o, Outcome::Budget),
                (None, o) => panic!("{o:?}"),
            }
        }
    }
    assert!(confirmed > 0, "no tolerance exercised the confirmation");
}

/// When the tolerance is not reached the ROM returned is the measured one of smallest error,
/// and that error is what the report states: re-measured at the sampled points it agrees.
#[test]
fn an_unmet_tolerance_returns_the_rom_whose_error_is_reported() {
    let (m, scene, _) = bar();
    let mut s = SamplingOptions::new(1e-6);
    s.max_order = Some(14);
    s.verify_points = Some(0);
    let rom = sampled(m, scene, s, 5, 1, &no_progress).unwrap();
    let r = report(&rom);
    assert!(!r.outcome.reached(), "{:?}", r.outcome);
    // the step where that ROM was measured: its error is the report's
    let best = r
        .steps
        .iter()
        .map(|s| s.true_error_max.max(s.sampled_error_max))
        .filter(|e| e.is_finite())
        .fold(f64::INFINITY, f64::min);
    assert_eq!(r.error, best);
    // re-measure the returned ROM at every point the loop has H1 for: the sampled points
    let body = Body::new(m).unwrap();
    let reference = Reference::compute(
        &body,
        scene,
        rom.ref_freqs_hz(),
        &SweepOptions::default(),
        None,
        &no_progress,
    )
    .unwrap();
    let at_sampled = reference
        .error(&rom)
        .unwrap()
        .eps_elastic
        .iter()
        .copied()
        .fold(0.0, f64::max);
    println!(
        "reported {:.4e}, re-measured at its {} sampled points {at_sampled:.4e}",
        r.error,
        rom.ref_freqs_hz().len()
    );
    assert!(
        at_sampled <= r.error * (1.0 + 1e-6),
        "{at_sampled:.4e} > reported {:.4e}",
        r.error
    );
}

#[test]
fn automatic_beats_the_hand_placed_demo_points() {
    let (m, scene, reference) = bar();
    let body = Body::new(m).unwrap();
    let full = eigenpairs(&body, Request::UpTo(1000.0), &EigenOptions::default()).unwrap();
    let freqs =
        place_reference_frequencies(&full.freqs_hz()[full.rigid..], [0.0, 1000.0], 20).unwrap();
    let demo_opts = LineFitOptions::new(Interface::OutputsPlus(5), References::Explicit(freqs));
    let demo = verified_max(
        reference,
        &linefit::reduce(&body, scene, &demo_opts, None, &no_progress).unwrap(),
    );
    // same order 14 as the demo, no growth; the residual indicator's picks (factored
    // responses): at a fixed order, picks at the true error's maxima (the Krylov space's
    // grid) stall at 1.55e-2, the least-squares fit trading one point for another
    let mut fixed_order = SamplingOptions::new(1e-2);
    fixed_order.max_order = Some(14);
    let rom = sampled_with(
        m,
        scene,
        fixed_order,
        5,
        0,
        SolveMethod::Factored,
        &no_progress,
    )
    .unwrap();
    let (auto, facts) = (
        verified_max(reference, &rom),
        report(&rom).steps.last().unwrap().solves,
    );
    println!("demo: 20 full solves, max eps {demo:.3e}; automatic: {facts} full solves, max eps {auto:.3e}");
    assert!(
        facts <= 20 && auto <= demo,
        "automatic {auto:.3e} with {facts} full solves vs demo {demo:.3e}"
    );
}

#[test]
fn indicator_argmax_lies_where_the_true_error_is_large() {
    let (m, scene, reference) = bar();
    let body = Body::new(m).unwrap();
    let grid = &reference.freqs_hz;
    // ROMs from a few reference sets (as the loop builds them); the first step (2 seeds only)
    // is excluded: there the indicator is still blind (observed factor 15.6)
    let mut worst: f64 = 1.0;
    for freqs in [
        vec![1.0, 143.0, 175.0, 1000.0],
        vec![1.0, 143.0, 175.0, 396.0, 483.0, 1000.0],
        vec![
            1.0, 142.0, 143.0, 175.0, 389.0, 396.0, 483.0, 773.0, 964.0, 1000.0,
        ],
    ] {
        let mut lo = LineFitOptions::new(Interface::OutputsPlus(5), References::Explicit(freqs));
        lo.keep_basis = true;
        let rom = linefit::reduce(&body, scene, &lo, None, &no_progress).unwrap();
        let ind = Indicator::new(&body, &rom).unwrap();
        let delta: Vec<f64> = grid.iter().map(|&f| ind.eval(&rom, f)).collect();
        let eps = reference.error(&rom).unwrap().eps_elastic;
        let am = (0..delta.len())
            .max_by(|&a, &b| delta[a].total_cmp(&delta[b]))
            .unwrap();
        let factor = eps.iter().copied().fold(0.0, f64::max) / eps[am];
        println!(
            "indicator argmax {:.1} Hz: true eps there {:.2e}, grid max {:.2e}, factor {factor:.2}",
            grid[am],
            eps[am],
            eps.iter().copied().fold(0.0, f64::max)
        );
        worst = worst.max(factor);
    }
    assert!(
        worst <= 2.0,
        "indicator argmax misses the true error by a factor {worst:.2}"
    );
}

#[test]
fn adding_frequencies_never_refactors() {
    let (m, scene, _) = bar();
    let calls = AtomicUsize::new(0);
    let cb = |_: Progress| {
        calls.fetch_add(1, Ordering::Relaxed);
        true
    };
    let mut o = SamplingOptions::new(1e-3);
    o.max_order = Some(24);
    // the loop's solves only (no verification pass)
    o.verify_points = Some(0);
    let rom = sampled(m, scene, o, 5, 0, &cb).unwrap();
    let r = report(&rom);
    let solved: usize = r.steps.iter().map(|s| s.points_hz.len()).sum();
    let mut f = rom.ref_freqs_hz().to_vec();
    let n = f.len();
    f.sort_by(f64::total_cmp);
    f.dedup();
    assert_eq!(f.len(), n, "a frequency was sampled twice");
    // every solve is one progress call; the last step's points verify, not refit
    assert_eq!(calls.load(Ordering::Relaxed), solved);
    assert_eq!(solved, r.steps.last().unwrap().solves);
    // the bar's damping is proportional: one shifted Krylov space answered every frequency
    assert_eq!(r.steps.last().unwrap().factorizations, 1);
    assert_eq!(n + r.steps.last().unwrap().points_hz.len(), solved);
}

#[test]
fn spilled_snapshots_give_the_same_rom() {
    let (m, scene, _) = bar();
    let mut o = SamplingOptions::new(1e-3);
    o.max_order = Some(18);
    // one worker: the same absorption order in both runs, so the results are bit-identical
    let a = sampled(m, scene, o.clone(), 5, 1, &no_progress).unwrap();
    o.snapshot_memory = Some(0);
    let b = sampled(m, scene, o.clone(), 5, 1, &no_progress).unwrap();
    assert!(!report(&a).spilled && report(&b).spilled);
    assert!(report(&b).spill_room.is_none());
    assert_eq!((a.order(), &a.kr, &a.mr), (b.order(), &b.kr, &b.mr));
    // a budget whose snapshots no disk holds (2⁴⁰ × 0.24 MB) is refused before any solve,
    // naming the directory and the fix, instead of failing when the disk is full
    o.max_points = Some(1 << 40);
    let solves = AtomicUsize::new(0);
    let count = |_: Progress| {
        solves.fetch_add(1, Ordering::Relaxed);
        true
    };
    let r = sampled(m, scene, o, 5, 1, &count);
    println!("{r:?}");
    assert!(
        matches!(&r, Err(Error::InvalidSetting(s)) if s.contains("TMPDIR") && s.contains("has room for")),
        "{r:?}"
    );
    assert_eq!(solves.load(Ordering::Relaxed), 0);
}

#[test]
fn impossible_requests_say_what_was_reached_and_what_would_help() {
    let (m, scene, _) = bar();
    for tol in [0.0, -1.0, f64::NAN] {
        let r = sampled(m, scene, SamplingOptions::new(tol), 5, 0, &no_progress);
        assert!(
            matches!(r, Err(Error::InvalidSetting(ref s)) if s.contains("tol")),
            "tol {tol}"
        );
    }
    // order 14 cannot reach 1e-6
    let mut fixed_order = SamplingOptions::new(1e-6);
    fixed_order.max_order = Some(14);
    let rom = sampled(m, scene, fixed_order, 5, 0, &no_progress).unwrap();
    let (r, message) = (
        report(&rom),
        report(&rom).summary(rom.order(), rom.ref_freqs_hz().len()),
    );
    println!("{message}");
    assert_eq!(r.outcome, Outcome::Stagnated);
    assert!(message.contains("NOT reached") && message.contains("larger interface"));
    // a tiny budget: the library names the option (the CLI words it as --max-points, tested
    // in tests/it/cli.rs)
    let mut small = SamplingOptions::new(1e-6);
    small.max_points = Some(5);
    let rom = sampled(m, scene, small, 5, 0, &no_progress).unwrap();
    let (r, message) = (
        report(&rom),
        report(&rom).summary(rom.order(), rom.ref_freqs_hz().len()),
    );
    println!("{message}");
    assert_eq!(r.outcome, Outcome::Budget);
    assert!(message.contains("max_points"));
    let _ = random_freqs; // shared fixtures
}

/// The same on a body that is not a bar: the built-in L-shaped steel bracket (N = 1836, six
/// deformation modes in [0, 6000] Hz). `--tol T` alone meets T on 2000 full solves, and the
/// stored verification (its default ⌈F/3⌉ points) stays within that maximum. A growth the
/// grid shows is needed (the fit at its limit at the sampled points) comes without a step
/// of new solves first: 5 full solves at every tolerance, order 17, 21, 25 (with a step of
/// solves before each of its three one-DoF growths, tol 1e-2 took 10).
#[test]
fn defaults_reach_the_tolerance_on_the_bracket() {
    use sparsemor::fe::bracket::{bracket_model, BracketSpec};
    let (model, scene) = bracket_model(&BracketSpec::steel()).unwrap();
    let body = Body::new(&model).unwrap();
    let band = sparsemor::scene::positive_band(scene.band_hz);
    let grid = sparsemor::grid::linspace(band, 2000);
    let reference = full_reference(&body, &scene, &grid);
    for tol in [1e-2, 1e-3, 1e-4] {
        let rom = by_default(&body, &scene, tol);
        let r = report(&rom);
        let v = verified_max(&reference, &rom);
        let stored = r.verified.unwrap().error;
        println!(
            "bracket tol {tol:.0e}: {:?}, order {}, {}, stored verified {stored:.3e}, 2000-point max {v:.3e}",
            r.outcome,
            rom.order(),
            r.cost()
        );
        assert_eq!(r.outcome, Outcome::Converged);
        assert!(v <= tol, "tol {tol:.0e}: {v:.3e}");
        assert!(
            stored <= v + RESPONSES_AGREE,
            "stored {stored:.4e} vs {v:.4e}"
        );
        assert!(r.solves <= 6, "tol {tol:.0e}: {}", r.cost());
    }
}

/// A ROM converged on the Krylov space's grid reports the larger of its errors on the grid
/// and at the sampled points. The bracket over (0, 1500] Hz at tol 1e-2: the grid's maximum
/// (6.4e-4) lies between the sampled points (2.7e-5 there), and the report used to state
/// only the latter. The stated error is the ROM's maximum over the 2000 candidates, measured
/// again by certified full solves.
#[test]
fn a_rom_converged_on_the_grid_reports_its_grid_error() {
    use sparsemor::fe::bracket::{bracket_model, BracketSpec};
    let (model, mut scene) = bracket_model(&BracketSpec::steel()).unwrap();
    scene.band_hz = [0.0, 1500.0];
    let body = Body::new(&model).unwrap();
    let tol = 1e-2;
    let rom = by_default(&body, &scene, tol);
    let r = report(&rom);
    assert_eq!(r.outcome, Outcome::Converged);
    let last = r.steps.last().unwrap();
    assert!(
        last.points_hz.is_empty(),
        "not converged on the grid: {last:?}"
    );
    let (grid, sampled) = (last.indicator_max, last.sampled_error_max);
    assert!(
        grid > 10.0 * sampled,
        "grid {grid:.3e}, sampled {sampled:.3e}"
    );
    assert_eq!(r.error, grid);
    let band = sparsemor::scene::positive_band(scene.band_hz);
    let candidates = sparsemor::grid::linspace(band, 2000);
    let reference = full_reference(&body, &scene, &candidates);
    let v = verified_max(&reference, &rom);
    println!("reported {:.6e}, 2000 certified solves {v:.6e}", r.error);
    assert!(
        (v - r.error).abs() <= 1e-6 * v,
        "{v:.6e} vs {:.6e}",
        r.error
    );
}

/// A 36-DoF bar (1×1×2 elements) has no resonance in [0, 1000] Hz: the indicator peaks next to
/// the seeds and falls away, so no local maximum lies away from the sampled points. The loop
/// used to measure nothing, report true error NaN and grow the interface to order 18 around a
/// ROM accurate to 1e-12. Now, before the first measurement and after a step within tol, it
/// solves the largest indicator value away from the sampled points: converged, every step's
/// error measured, and the error on a 400-point grid within tol.
#[test]
fn a_band_without_resonances_converges_with_measured_errors() {
    let spec = BoxSpec {
        elements: [1, 1, 2],
        ..BoxSpec::paper_bar()
    };
    let (m, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    assert_eq!(m.n(), 36);
    let body = Body::new(&m).unwrap();
    let tol = 1e-6;
    let rom = by_default(&body, &scene, tol);
    let r = report(&rom);
    assert_eq!(r.outcome, Outcome::Converged, "{:?}", r.steps);
    assert!(
        r.error.is_finite() && r.error <= tol,
        "loop error {}",
        r.error
    );
    // every step measured the ROM: at new points, or (the Krylov space's grid) over all
    // candidates and at the sampled points
    for s in &r.steps[1..] {
        assert!(
            s.true_error_max.is_finite()
                || (s.points_hz.is_empty()
                    && s.indicator_max.is_finite()
                    && s.sampled_error_max.is_finite()),
            "step {s:?}"
        );
    }
    let grid: Vec<f64> = (0..400).map(|k| 1.0 + 999.0 * k as f64 / 399.0).collect();
    let reference = full_reference(&body, &scene, &grid);
    let v = verified_max(&reference, &rom);
    assert!(v <= tol, "400-point max {v:.3e}");
}
