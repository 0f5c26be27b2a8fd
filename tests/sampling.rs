//! Iterative frequency sampling (DESIGN.md §3.5) on the built-in bar: verified accuracy on a
//! 2000-point grid, the indicator against the true error, no re-factorization, clear
//! messages when a tolerance cannot be reached.

mod common;
use common::*;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::metrics::Reference;
use sparsemor::model::Model;
use sparsemor::reduce::linefit::{self, place_reference_frequencies, Interface, LineFitOptions};
use sparsemor::sampling::{reduce, Growth, Indicator, Outcome, SamplingOptions};
use sparsemor::sweep::{no_progress, Progress, SweepOptions};
use sparsemor::Error;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

fn bar() -> &'static (Model, Reference) {
    static BAR: OnceLock<(Model, Reference)> = OnceLock::new();
    BAR.get_or_init(|| {
        let m = bar_model(&BoxSpec::paper_bar()).unwrap();
        let grid: Vec<f64> = (0..2000).map(|k| 1.0 + 999.0 * k as f64 / 1999.0).collect();
        let r = Reference::compute(
            &m,
            &m.scene.inputs,
            &m.scene.outputs,
            &grid,
            &SweepOptions::default(),
            &no_progress,
        )
        .unwrap();
        (m, r)
    })
}

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
    let (m, reference) = bar();
    for (tol, growth) in [
        (1e-2, Growth::Residual),
        (1e-3, Growth::Residual),
        (1e-3, Growth::QDeim),
    ] {
        let mut o = SamplingOptions::new(tol, Interface::OutputsPlus(5));
        o.max_order = 40;
        o.growth = growth;
        let r = reduce(m, &m.scene.inputs, &m.scene.outputs, &o, &no_progress).unwrap();
        let v = verified_max(reference, &r.rom);
        println!(
            "tol {tol:.0e} ({growth:?}): {:?}, order {}, {} factorizations, verified max eps over 2000 points {v:.3e}",
            r.outcome,
            r.rom.order(),
            r.steps.last().unwrap().factorizations
        );
        assert_eq!(r.outcome, Outcome::Converged, "{}", r.message);
        assert!(v <= tol, "verified {v:.3e} > tol {tol:.0e}");
    }
}

#[test]
fn automatic_beats_the_hand_placed_demo_points() {
    let (m, reference) = bar();
    let (i, o) = (&m.scene.inputs, &m.scene.outputs);
    let full = eigenpairs(m, Request::UpTo(1000.0), &EigenOptions::default()).unwrap();
    let freqs =
        place_reference_frequencies(&full.freqs_hz()[full.rigid..], [0.0, 1000.0], 20).unwrap();
    let demo_opts = LineFitOptions {
        interface: Interface::OutputsPlus(5),
        ref_freqs_hz: freqs,
        keep_basis: false,
        sweep: SweepOptions::default(),
        lsq: Default::default(),
    };
    let demo = verified_max(
        reference,
        &linefit::reduce(m, i, o, &demo_opts, &no_progress).unwrap(),
    );
    // same order 14 as the demo, no growth
    let r = reduce(
        m,
        i,
        o,
        &SamplingOptions::new(1e-2, Interface::OutputsPlus(5)),
        &no_progress,
    )
    .unwrap();
    let (auto, facts) = (
        verified_max(reference, &r.rom),
        r.steps.last().unwrap().factorizations,
    );
    println!("demo: 20 factorizations, max eps {demo:.3e}; automatic: {facts} factorizations, max eps {auto:.3e}");
    assert!(
        facts <= 20 && auto <= demo,
        "automatic {auto:.3e} with {facts} factorizations vs demo {demo:.3e}"
    );
}

#[test]
fn indicator_argmax_lies_where_the_true_error_is_large() {
    let (m, reference) = bar();
    let (i, o) = (&m.scene.inputs, &m.scene.outputs);
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
        let lo = LineFitOptions {
            interface: Interface::OutputsPlus(5),
            ref_freqs_hz: freqs,
            keep_basis: true,
            sweep: SweepOptions::default(),
            lsq: Default::default(),
        };
        let rom = linefit::reduce(m, i, o, &lo, &no_progress).unwrap();
        let ind = Indicator::new(m, &rom, true).unwrap();
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
    let (m, _) = bar();
    let calls = AtomicUsize::new(0);
    let cb = |_: Progress| {
        calls.fetch_add(1, Ordering::Relaxed);
        true
    };
    let mut o = SamplingOptions::new(1e-3, Interface::OutputsPlus(5));
    o.max_order = 24;
    let r = reduce(m, &m.scene.inputs, &m.scene.outputs, &o, &cb).unwrap();
    let solved: usize = r.steps.iter().map(|s| s.points_hz.len()).sum();
    let mut f = r.rom.ref_freqs_hz.clone();
    let n = f.len();
    f.sort_by(f64::total_cmp);
    f.dedup();
    assert_eq!(f.len(), n, "a frequency was sampled twice");
    // every factorization is one progress call; the last step's points verify, not refit
    assert_eq!(calls.load(Ordering::Relaxed), solved);
    assert_eq!(solved, r.steps.last().unwrap().factorizations);
    assert_eq!(n + r.steps.last().unwrap().points_hz.len(), solved);
}

#[test]
fn spilled_snapshots_give_the_same_rom() {
    let (m, _) = bar();
    let mut o = SamplingOptions::new(1e-3, Interface::OutputsPlus(5));
    o.max_order = 18;
    // one worker: the same absorption order in both runs, so the results are bit-identical
    o.sweep.threads = 1;
    let a = reduce(m, &m.scene.inputs, &m.scene.outputs, &o, &no_progress).unwrap();
    o.snapshot_memory = Some(0);
    let b = reduce(m, &m.scene.inputs, &m.scene.outputs, &o, &no_progress).unwrap();
    assert!(!a.spilled && b.spilled);
    assert_eq!(
        (a.rom.order(), &a.rom.kr, &a.rom.mr),
        (b.rom.order(), &b.rom.kr, &b.rom.mr)
    );
}

#[test]
fn impossible_requests_say_what_was_reached_and_what_would_help() {
    let (m, _) = bar();
    let (i, o) = (&m.scene.inputs, &m.scene.outputs);
    for tol in [0.0, -1.0, f64::NAN] {
        let r = reduce(
            m,
            i,
            o,
            &SamplingOptions::new(tol, Interface::OutputsPlus(5)),
            &no_progress,
        );
        assert!(
            matches!(r, Err(Error::InvalidSetting(ref s)) if s.contains("tol")),
            "tol {tol}"
        );
    }
    // order 14 cannot reach 1e-6
    let r = reduce(
        m,
        i,
        o,
        &SamplingOptions::new(1e-6, Interface::OutputsPlus(5)),
        &no_progress,
    )
    .unwrap();
    println!("{}", r.message);
    assert_eq!(r.outcome, Outcome::Stagnated);
    assert!(r.message.contains("NOT reached") && r.message.contains("larger interface"));
    // a tiny budget
    let mut small = SamplingOptions::new(1e-6, Interface::OutputsPlus(5));
    small.max_points = 5;
    let r = reduce(m, i, o, &small, &no_progress).unwrap();
    println!("{}", r.message);
    assert_eq!(r.outcome, Outcome::Budget);
    assert!(r.message.contains("max-points"));
    let _ = random_freqs; // shared fixtures
}
