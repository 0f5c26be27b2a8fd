//! Line-fitting (docs/design.md §3.3–3.4) against a dense implementation of eq. 14–22 written
//! here, the exact-fit property, the paper's accuracy on the built-in bar, ROM files and
//! bad settings.

use crate::common::*;
use faer::linalg::solvers::SolveLstsq;
use faer::{c64, Mat};
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::io::rom_dir;
use sparsemor::metrics::{modal_comparison, Reference};
use sparsemor::model::{Damping, Model};
use sparsemor::reduce::linefit::{
    place_reference_frequencies, reduce, spread_dofs, Interface, LineFitOptions, References,
};
use sparsemor::reduce::Rom;
use sparsemor::scene::Scene;
use sparsemor::sweep::{no_progress, SolveMethod};
use sparsemor::Error;

fn opts(interface: Interface, freqs: &[f64], threads: usize) -> LineFitOptions {
    let mut o = LineFitOptions::new(interface, References::Explicit(freqs.to_vec()));
    o.keep_basis = true;
    o.sweep.threads = threads;
    o
}

/// Line-fitting of `model` for `scene` on a freshly prepared body.
fn lf(model: &Model, scene: &Scene, o: &LineFitOptions) -> sparsemor::Result<Rom> {
    reduce(&Body::new(model)?, scene, o, None, &no_progress)
}

/// The paper bar and its scene.
fn paper_bar() -> (Model, Scene) {
    let spec = BoxSpec::paper_bar();
    (bar_model(&spec).unwrap(), paper_scene(&spec))
}

/// A reference transfer function on a frequency grid.
fn reference(model: &Model, scene: &Scene, freqs: &[f64]) -> Reference {
    let body = Body::new(model).unwrap();
    full_reference(&body, scene, freqs)
}

/// Dense X_k = Pᵀ A(iω)⁻¹ P B (P = I on a constrained body).
fn dense_snapshot(model: &Model, f: f64, inputs: &[usize]) -> Mat<c64> {
    let n = model.n();
    let all: Vec<usize> = (0..n).collect();
    match &model.nodes {
        None => dense_h(model, f, inputs, &all),
        Some(nodes) => {
            let v0 = sparsemor::rigid::rigid_modes(nodes, 3);
            dense_h1_deflated(model, &v0, f, inputs, &all)
        }
    }
}

/// Dense W of eq. 22: stacked T_oᵀ, T_nᵀ, least squares by dense QR.
fn dense_w(
    model: &Model,
    inputs: &[usize],
    interface: &[usize],
    freqs: &[f64],
) -> (Vec<usize>, Mat<f64>) {
    let rest: Vec<usize> = (0..model.n()).filter(|d| !interface.contains(d)).collect();
    let p = inputs.len();
    let rows = 2 * p * freqs.len();
    let mut to = Mat::<f64>::zeros(rows, interface.len());
    let mut tn = Mat::<f64>::zeros(rows, rest.len());
    for (k, &f) in freqs.iter().enumerate() {
        let x = dense_snapshot(model, f, inputs);
        for j in 0..p {
            let (r_re, r_im) = (2 * p * k + j, 2 * p * k + p + j);
            for (c, &d) in interface.iter().enumerate() {
                to[(r_re, c)] = x[(d, j)].re;
                to[(r_im, c)] = x[(d, j)].im;
            }
            for (c, &d) in rest.iter().enumerate() {
                tn[(r_re, c)] = x[(d, j)].re;
                tn[(r_im, c)] = x[(d, j)].im;
            }
        }
    }
    let wt = to.qr().solve_lstsq(&tn); // n × m
    (rest, wt.transpose().to_owned())
}

fn check_against_dense(model: &Model, scene: &Scene, interface: Vec<usize>, freqs: &[f64]) {
    let i = scene.inputs.clone();
    let rom = lf(
        model,
        scene,
        &opts(Interface::Explicit(interface.clone()), freqs, 2),
    )
    .unwrap();
    let v = rom.basis.as_ref().unwrap();
    let (rest, w_ref) = dense_w(model, &i, &interface, freqs);
    let w = Mat::from_fn(rest.len(), interface.len(), |r, c| v[(rest[r], c)]);
    let e = (&w - &w_ref).norm_l2() / w_ref.norm_l2();
    println!(
        "N = {}: ‖W − W_dense‖/‖W_dense‖ = {e:.2e}, cond(T_o) = {:.2e}",
        model.n(),
        rom.fit().unwrap().cond_raw
    );
    assert!(e <= 1e-8, "W differs from the dense reference: {e:.2e}");
    // the report counts every solve; the damping is proportional, so every response came
    // from one shifted Krylov space (one factorization) and carries its certificate
    let solves = rom.fit().unwrap().solves;
    assert_eq!(solves.frequencies, freqs.len());
    assert_eq!(solves.from_space, freqs.len(), "{solves:?}");
    assert_eq!(solves.factorizations(), 1, "{solves:?}");
    assert!(
        solves.relative_residual_max > 0.0
            && (solves.backward_error_max <= sparsemor::sweep::CERTIFIED_BACKWARD_ERROR
                || solves.relative_residual_max <= sparsemor::sweep::CERTIFIED_RELATIVE_RESIDUAL),
        "{solves:?}"
    );
    for (c, &d) in interface.iter().enumerate() {
        assert_eq!(v[(d, c)], 1.0);
    }
}

#[test]
fn constrained_model_matches_dense_reference() {
    let model = random_model(
        400,
        6,
        21,
        Damping::Rayleigh {
            alpha: 1.0,
            beta: 2e-5,
        },
    );
    let scene = random_scene(400);
    let mut interface = scene.outputs.clone();
    interface.extend([50, 120, 260, 333]);
    check_against_dense(&model, &scene, interface, &[20.0, 60.0, 110.0, 170.0]);
}

#[test]
fn free_bar_matches_dense_reference() {
    let spec = BoxSpec {
        elements: [1, 2, 24],
        size_m: [0.006, 0.008, 0.3],
        ..BoxSpec::paper_bar()
    };
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    assert!(model.n() <= 1000);
    let mut interface = scene.outputs.clone();
    let body = Body::new(&model).unwrap();
    interface.extend(spread_dofs(&body, 4, &interface).unwrap());
    check_against_dense(
        &model,
        &scene,
        interface,
        &[50.0, 180.0, 400.0, 700.0, 950.0],
    );
}

#[test]
fn exact_fit_interpolates_at_reference_frequencies() {
    // 2pz = n: p = 9 inputs, z = 1 frequency → n = 18 = 9 outputs + 9 spread DoFs
    let (model, scene) = paper_bar();
    for freqs in [[333.0], [777.0]] {
        let rom = lf(&model, &scene, &opts(Interface::OutputsPlus(9), &freqs, 1)).unwrap();
        let fit = rom.fit().unwrap();
        assert_eq!((fit.rows, rom.order(), fit.rank), (18, 18, 18));
        let e = reference(&model, &scene, &freqs)
            .error(&rom)
            .unwrap()
            .eps_elastic[0];
        println!("exact fit at {} Hz: eps = {e:.2e}", freqs[0]);
        assert!(
            e <= 1e-8,
            "ROM does not interpolate H1 at {} Hz: {e:.2e}",
            freqs[0]
        );
    }
}

#[test]
fn paper_bar_with_demo_settings_is_within_three_percent() {
    let (model, scene) = paper_bar();
    let full = eigenpairs(
        &Body::new(&model).unwrap(),
        Request::UpTo(1000.0),
        &EigenOptions::default(),
    )
    .unwrap();
    let res = full.freqs_hz()[full.rigid..].to_vec();
    let freqs = place_reference_frequencies(&res, [0.0, 1000.0], 20).unwrap();
    let rom = lf(&model, &scene, &opts(Interface::OutputsPlus(5), &freqs, 2)).unwrap();
    assert_eq!(rom.order(), 14);
    let grid: Vec<f64> = (0..2000).map(|k| 1.0 + 999.0 * k as f64 / 1999.0).collect();
    let curve = reference(&model, &scene, &grid).error(&rom).unwrap();
    let max = curve.eps_elastic.iter().copied().fold(0.0, f64::max);
    println!(
        "max elastic eps over [1, 1000] Hz (2000 points): {:.3} %",
        100.0 * max
    );
    assert!(max < 0.03, "max eps {max:.4}");
    assert!(
        rom.mass_definiteness.positive_definite && rom.stiffness_definiteness.positive_definite
    );
}

#[test]
fn thread_count_changes_only_rounding() {
    let (model, scene) = paper_bar();
    let freqs: Vec<f64> = (1..=8).map(|k| 120.0 * k as f64 + 3.0).collect();
    let a = lf(&model, &scene, &opts(Interface::OutputsPlus(5), &freqs, 1)).unwrap();
    let b = lf(&model, &scene, &opts(Interface::OutputsPlus(5), &freqs, 2)).unwrap();
    let (va, vb) = (a.basis.unwrap(), b.basis.unwrap());
    let e = (&va - &vb).norm_l2() / va.norm_l2();
    assert!(e <= 1e-10, "1 vs 2 threads: {e:.2e}");
}

#[test]
fn two_threads_give_the_same_rom_on_every_run() {
    // each worker absorbs a fixed share of the frequencies in a fixed order: from one shifted
    // Krylov space and from a factorization per frequency alike
    let (model, scene) = paper_bar();
    let freqs: Vec<f64> = (1..=9).map(|k| 100.0 * k as f64 - 7.0).collect();
    for method in [SolveMethod::Auto, SolveMethod::Factored] {
        let mut o = opts(Interface::OutputsPlus(5), &freqs, 2);
        o.sweep.method = method;
        let body = Body::new(&model).unwrap();
        let first = reduce(&body, &scene, &o, None, &no_progress).unwrap();
        for run in 0..3 {
            let again = reduce(&body, &scene, &o, None, &no_progress).unwrap();
            for (x, y, what) in [(&first.mr, &again.mr, "Mr"), (&first.kr, &again.kr, "Kr")] {
                assert!(x == y, "{method:?}, run {run}: {what} differs");
            }
        }
    }
}

#[test]
fn rom_directory_round_trips_exactly() {
    let (model, scene) = paper_bar();
    let freqs: Vec<f64> = (1..=4).map(|k| 200.0 * k as f64).collect();
    let rom = lf(&model, &scene, &opts(Interface::OutputsPlus(3), &freqs, 2)).unwrap();
    let dir = std::env::temp_dir().join(format!("sparsemor-romdir-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    rom_dir::write(&dir, &rom).unwrap();
    let back = rom_dir::read(&dir).unwrap();
    assert_eq!(
        (&back.mr, &back.dr, &back.kr, &back.br, &back.cr),
        (&rom.mr, &rom.dr, &rom.kr, &rom.br, &rom.cr)
    );
    assert_eq!(back.basis, rom.basis);
    assert_eq!(
        (&back.dofs, back.ref_freqs_hz()),
        (&rom.dofs, rom.ref_freqs_hz())
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

fn expect_setting_error(model: &Model, scene: &Scene, o: LineFitOptions, needle: &str) {
    match lf(model, scene, &o) {
        Err(e) if e.is_invalid_setting() => {
            let m = e.to_string();
            assert!(m.contains(needle), "message '{m}' lacks '{needle}'")
        }
        other => panic!(
            "expected InvalidSetting({needle}), got {:?}",
            other.map(|r| r.order())
        ),
    }
}

#[test]
fn bad_settings_are_clear_errors() {
    let (model, scene) = paper_bar();
    let f20: Vec<f64> = (1..=20).map(|k| 50.0 * k as f64).collect();
    // outputs not in the interface
    expect_setting_error(
        &model,
        &scene,
        opts(Interface::Explicit(vec![0, 1, 2, 5, 6]), &f20, 2),
        "not in the interface",
    );
    // duplicate interface DoF
    let mut dup = scene.outputs.clone();
    dup.push(0);
    expect_setting_error(
        &model,
        &scene,
        opts(Interface::Explicit(dup), &f20, 2),
        "appears twice",
    );
    // 2pz < n: 9 inputs, 1 frequency, n = 19
    expect_setting_error(
        &model,
        &scene,
        opts(Interface::OutputsPlus(10), &[300.0], 2),
        "2pz",
    );
    // no frequency at all
    expect_setting_error(
        &model,
        &scene,
        opts(Interface::OutputsPlus(5), &[], 2),
        "at least one reference frequency",
    );
    // interface DoF out of range
    let mut far = scene.outputs.clone();
    far.push(model.n());
    expect_setting_error(
        &model,
        &scene,
        opts(Interface::Explicit(far), &f20, 2),
        "out of range",
    );
    // empty band for the placement rule
    assert!(matches!(
        place_reference_frequencies(&[100.0], [500.0, 500.0], 20),
        Err(Error::InvalidSetting(_))
    ));
}

/// The modal comparison pairs full and ROM modes one-to-one: over a band far beyond the ROM's
/// reach (20 kHz, ~50 deformation modes for an order-14 ROM) no ROM mode is used twice, the
/// modes without a partner are listed, and the in-band modes keep their accurate partners.
#[test]
fn modal_pairing_is_one_to_one_and_lists_unpaired_modes() {
    let (model, scene) = paper_bar();
    let f20: Vec<f64> = (1..=20).map(|k| 50.0 * k as f64).collect();
    let rom = lf(&model, &scene, &opts(Interface::OutputsPlus(5), &f20, 2)).unwrap();
    let body = Body::new(&model).unwrap();
    let full = eigenpairs(&body, Request::UpTo(20_000.0), &EigenOptions::default()).unwrap();
    let deformation = full.lambdas.len() - full.rigid;
    assert!(deformation > rom.order(), "{deformation} modes");
    let cmp = modal_comparison(&rom, &full, rom.basis.as_ref().map(|v| v.as_ref())).unwrap();
    let mut used: Vec<usize> = cmp.pairs.iter().map(|p| p.rom_mode).collect();
    used.sort_unstable();
    used.dedup();
    assert_eq!(used.len(), cmp.pairs.len(), "a ROM mode is paired twice");
    assert!(cmp.pairs.len() <= rom.order());
    assert_eq!(cmp.pairs.len() + cmp.unpaired.len(), deformation);
    for p in cmp.pairs.iter().filter(|p| p.full_hz <= 1000.0) {
        assert!(
            p.mac > 0.99 && p.rel_freq_error < 1e-3,
            "in-band mode {} at {:.1} Hz: ROM {:.1} Hz, MAC {:.4}",
            p.full_mode,
            p.full_hz,
            p.rom_hz,
            p.mac
        );
    }
    println!(
        "{} full deformation modes up to 20 kHz: {} paired, {} unpaired",
        deformation,
        cmp.pairs.len(),
        cmp.unpaired.len()
    );
}

/// 0 Hz is a valid reference frequency on a free body: the elastic snapshot is the static
/// response with the rigid motion removed (docs/design.md §3.2). The ROM fitted with it
/// reproduces the elastic transfer function there as well as at its other points.
#[test]
fn zero_hertz_is_a_reference_frequency_on_a_free_body() {
    let (model, scene) = paper_bar();
    let f20: Vec<f64> = (0..20).map(|k| 50.0 * k as f64).collect(); // 0, 50, …, 950
    let rom = lf(&model, &scene, &opts(Interface::OutputsPlus(5), &f20, 2)).unwrap();
    let e = reference(&model, &scene, &[0.0, 1e-3, 475.0])
        .error(&rom)
        .unwrap()
        .eps_elastic;
    println!("eps at 0, 1e-3, 475 Hz: {e:?}");
    assert!(e.iter().all(|&x| x < 0.03), "{e:?}");
}
