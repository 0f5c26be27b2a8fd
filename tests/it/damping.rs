//! Every damping kind (docs/design.md §3.12) against dense solves written here: a loss factor
//! η, a structural damping matrix K₄, an explicit D that is αM + βK, dashpots on top of it;
//! the sweep (the shifted space with its low-rank correction, or factorizations), line-fitting
//! ROMs with K₄r, and the model and ROM directories that carry them.

use crate::common::{assert_sweep_matches_dense, dense_h, dense_h1_deflated, rel_err, sparse};
use faer::Mat;
use sparsemor::body::Body;
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::io::{model_dir, rom_dir};
use sparsemor::model::{Damping, Model, Structural};
use sparsemor::proportional::Split;
use sparsemor::reduce::interface::Interface;
use sparsemor::reduce::linefit::{LineFitOptions, References, SamplingOptions};
use sparsemor::reduce::{reduce, Context, Reductor};
use sparsemor::scene::Scene;
use sparsemor::sweep::SweepOptions;

/// The paper bar coarsely meshed (free, N = 225) and its scene.
fn bar() -> (Model, Scene) {
    let spec = BoxSpec {
        elements: [1, 2, 24],
        ..BoxSpec::paper_bar()
    };
    (bar_model(&spec).unwrap(), paper_scene(&spec))
}

/// a M + b K as a dense matrix, plus dashpots c (e_a − e_b)(e_a − e_b)ᵀ on the z DoFs of node
/// pairs (a, b) on one line along the bar (rigid motion does not load them).
fn combination(model: &Model, a: f64, b: f64, dashpots: &[(usize, usize)], c: f64) -> Mat<f64> {
    let (m, k) = (
        crate::common::dense(&model.mass),
        crate::common::dense(&model.stiffness),
    );
    let mut d = Mat::from_fn(m.nrows(), m.ncols(), |i, j| a * m[(i, j)] + b * k[(i, j)]);
    for &(p, q) in dashpots {
        let (p, q) = (3 * p + 2, 3 * q + 2);
        d[(p, p)] += c;
        d[(q, q)] += c;
        d[(p, q)] -= c;
        d[(q, p)] -= c;
    }
    d
}

/// Two node pairs on the line of node 0 along z: its ends, and its third and middle nodes.
fn line_pairs(model: &Model) -> Vec<(usize, usize)> {
    let nodes = model.nodes.as_ref().unwrap();
    let mut on: Vec<usize> = (0..nodes.len())
        .filter(|&i| nodes[i][0] == nodes[0][0] && nodes[i][1] == nodes[0][1])
        .collect();
    on.sort_by(|&a, &b| nodes[a][2].total_cmp(&nodes[b][2]));
    vec![(on[0], on[on.len() - 1]), (on[2], on[on.len() / 2])]
}

/// Each damping kind: the sweep equals dense solves of K + iH − ω²M + iωD at frequencies
/// across the band and at resonances, answered by the path `info` names (§3.12).
#[test]
fn every_damping_kind_sweeps_like_dense_solves() {
    let (base, scene) = bar();
    let pairs = line_pairs(&base);
    let with = |damping: Damping, structural: Structural| {
        let mut m = base.clone();
        m.damping = damping;
        m.with_structural(structural).unwrap()
    };
    let eta = |eta| Structural { eta, matrix: None };
    let cases = [
        (
            "loss factor",
            with(Damping::None, eta(0.02)),
            "proportional",
        ),
        (
            "Rayleigh and loss factor",
            with(
                Damping::Rayleigh {
                    alpha: 2.0,
                    beta: 1e-6,
                },
                eta(0.01),
            ),
            "proportional",
        ),
        (
            "K4 = 0.03 K + dashpot-like K4 on two pairs",
            with(
                Damping::Rayleigh {
                    alpha: 0.0,
                    beta: 1e-6,
                },
                Structural {
                    eta: 0.0,
                    matrix: Some(sparse(&combination(&base, 0.0, 0.03, &pairs, 1e6))),
                },
            ),
            "low rank",
        ),
        (
            "D = 3 M + 2e-6 K as a matrix",
            with(
                Damping::Matrix(sparse(&combination(&base, 3.0, 2e-6, &[], 0.0))),
                eta(0.0),
            ),
            "proportional",
        ),
        (
            "dashpots on 1e-6 K, loss factor",
            with(
                Damping::Matrix(sparse(&combination(&base, 0.0, 1e-6, &pairs, 300.0))),
                eta(0.02),
            ),
            "low rank",
        ),
        (
            "material-like: 1e-6 K + 1e-5 K on half the DoFs",
            {
                let k = crate::common::dense(&base.stiffness);
                let n = k.nrows();
                let d = Mat::from_fn(n, n, |i, j| {
                    k[(i, j)] * if i < n / 2 && j < n / 2 { 1.1e-5 } else { 1e-6 }
                });
                with(Damping::Matrix(sparse(&d)), eta(0.0))
            },
            "general",
        ),
    ];
    // from 70 Hz: below it the dense total response loses digits to the rigid part (1e-8 at
    // 7 Hz), not the sweep
    let freqs = [70.0, 142.9, 333.0, 610.0, 998.0];
    for (what, mut model, path) in cases {
        model.name = what.into();
        let body = Body::new(&model).unwrap();
        let kind = match body.pencil().split() {
            Split::Proportional(_) => "proportional",
            Split::LowRank(..) => "low rank",
            Split::General(..) => "general",
        };
        assert_eq!(kind, path, "{what}");
        let scene = Scene {
            band_hz: [0.0, 1000.0],
            ..scene.clone()
        };
        assert_sweep_matches_dense(&model, &scene, &freqs, &SweepOptions::default(), 1e-8);
    }
}

/// A line-fitting ROM of a body with a loss factor carries K₄r and meets its tolerance against
/// dense solves (not the sweep) on 40 points; the same body with K₄ = ηK as a matrix gives the
/// same ROM transfer function.
#[test]
fn a_loss_factor_rom_meets_its_tolerance_against_dense_solves() {
    let (base, scene) = bar();
    let tol = 1e-4;
    let rom_of = |structural: Structural| {
        let mut model = base.clone();
        model.damping = Damping::Rayleigh {
            alpha: 0.0,
            beta: 2e-6,
        };
        let model = model.with_structural(structural).unwrap();
        let body = Body::new(&model).unwrap();
        let opts = LineFitOptions::new(
            Interface::Auto,
            References::Tolerance(SamplingOptions::new(tol)),
        );
        let rom = reduce(&body, &scene, &Reductor::LineFit(opts), &Context::default()).unwrap();
        (model, rom)
    };
    let (model, rom) = rom_of(Structural {
        eta: 0.02,
        matrix: None,
    });
    assert!(rom.k4r.is_some());
    // the elastic part (the ROM's Br = VᵀPB), by the deflated dense pencil
    let v0 = sparsemor::rigid::rigid_modes(model.nodes.as_ref().unwrap(), 3);
    let freqs: Vec<f64> = (0..40).map(|k| 2.0 + 997.0 * k as f64 / 39.0).collect();
    let mut worst = 0.0f64;
    for &f in &freqs {
        let h = dense_h1_deflated(&model, &v0, f, &scene.inputs, &scene.outputs);
        worst = worst.max(rel_err(&rom.transfer(f), &h));
    }
    assert!(worst <= tol, "order {}: {worst:.2e}", rom.order());
    let k4 = crate::common::dense(&base.stiffness);
    let (_, as_matrix) = rom_of(Structural {
        eta: 0.0,
        matrix: Some(sparse(&Mat::from_fn(k4.nrows(), k4.ncols(), |i, j| {
            0.02 * k4[(i, j)]
        }))),
    });
    for &f in &freqs[..10] {
        let d = rel_err(&as_matrix.transfer(f), &rom.transfer(f));
        assert!(d <= 1e-8, "{f} Hz: {d:.2e}");
    }
}

/// model.toml's `[structural] eta` and `structural_damping` are read and written back, a ROM
/// directory keeps K4r.mtx, and bad values are refused naming the field.
#[test]
fn directories_carry_structural_damping() {
    let (base, scene) = bar();
    let k = crate::common::dense(&base.stiffness);
    let k4 = sparse(&Mat::from_fn(k.nrows(), k.ncols(), |i, j| 1e-3 * k[(i, j)]));
    let model = base
        .with_structural(Structural {
            eta: 0.02,
            matrix: Some(k4),
        })
        .unwrap();
    let root = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("damping");
    let _ = std::fs::remove_dir_all(&root);
    let dir = root.join("model");
    model_dir::write(&dir, &model, &scene).unwrap();
    let text = std::fs::read_to_string(dir.join("model.toml")).unwrap();
    assert!(text.contains("structural_damping = \"K4.mtx\"") && text.contains("eta = 0.02"));
    let (back, _, _) = model_dir::read(&dir).unwrap();
    assert_eq!(back.structural.eta, 0.02);
    let f = 333.0;
    let d = rel_err(
        &dense_h(&back, f, &scene.inputs, &scene.outputs),
        &dense_h(&model, f, &scene.inputs, &scene.outputs),
    );
    assert!(d <= 1e-14, "{d:.1e}");
    // the ROM directory
    let body = Body::new(&model).unwrap();
    let opts = LineFitOptions::new(Interface::Auto, References::Count(6));
    let rom = reduce(&body, &scene, &Reductor::LineFit(opts), &Context::default()).unwrap();
    let rom_path = root.join("rom");
    rom_dir::write(&rom_path, &rom).unwrap();
    assert!(rom_path.join("K4r.mtx").exists());
    let read = rom_dir::read(&rom_path).unwrap();
    assert_eq!(read.k4r, rom.k4r);
    assert!(rel_err(&read.transfer(f), &rom.transfer(f)) <= 1e-15);
    // bad values name the field
    for (bad, want) in [("-0.1", "eta = -0.1"), ("nan", "eta = NaN")] {
        let text = text.replace("eta = 0.02", &format!("eta = {bad}"));
        std::fs::write(dir.join("model.toml"), text).unwrap();
        let e = model_dir::read(&dir).expect_err("refused").to_string();
        assert!(e.contains("model.toml") && e.contains(want), "{e}");
    }
}

/// The stiffness of the bar's far half (its elements 12..24 along z) on the whole bar's DoFs:
/// what a second material's damping is proportional to.
fn far_half_stiffness(spec: &BoxSpec, n: usize) -> Mat<f64> {
    let [nx, ny, nz] = spec.elements;
    let half = BoxSpec {
        elements: [nx, ny, nz / 2],
        size_m: [spec.size_m[0], spec.size_m[1], spec.size_m[2] / 2.0],
        mass_kg: spec.mass_kg / 2.0,
        ..*spec
    };
    let k = crate::common::dense(&bar_model(&half).unwrap().stiffness);
    // node (i, j, l) of the half is node (i, j, l + nz/2) of the bar
    let shift = 3 * (nx + 1) * (ny + 1) * (nz / 2);
    let mut far = Mat::zeros(n, n);
    for j in 0..k.ncols() {
        for i in 0..k.nrows() {
            far[(i + shift, j + shift)] = k[(i, j)];
        }
    }
    far
}

/// Damping that differs by material, viscous and structural: D = 1e-6 K + 9e-6 K_far and
/// K₄ = 0.002 K + 0.018 K_far (the far half 10× more damped). A line-fitting ROM meets its
/// tolerance against dense solves on 40 points with every response of the run from one
/// linearized space about a complex K₀ (docs/design.md §3.13): one factorization for the
/// space, none per frequency, and the report and rom.toml count the inertia count's too.
#[test]
fn material_wise_structural_damping_reduces_from_one_space() {
    let spec = BoxSpec {
        elements: [1, 2, 24],
        ..BoxSpec::paper_bar()
    };
    let (mut model, scene) = bar();
    let (k, far) = (
        crate::common::dense(&model.stiffness),
        far_half_stiffness(&spec, model.n()),
    );
    model.damping = Damping::Matrix(sparse(&(&k * 1e-6 + &far * 9e-6)));
    let model = model
        .with_structural(Structural {
            eta: 0.0,
            matrix: Some(sparse(&(&k * 0.002 + &far * 0.018))),
        })
        .unwrap();
    let body = Body::new(&model).unwrap();
    assert!(matches!(body.pencil().split(), Split::General(..)));
    let tol = 1e-4;
    let opts = LineFitOptions::new(
        Interface::Auto,
        References::Tolerance(SamplingOptions::new(tol)),
    );
    let rom = reduce(&body, &scene, &Reductor::LineFit(opts), &Context::default()).unwrap();
    assert!(rom.k4r.is_some());
    let s = &rom.fit().unwrap().solves;
    assert!(s.frequencies > 0 && s.from_space == s.frequencies, "{s:?}");
    assert_eq!(s.space_factorizations, 1, "{s:?}");
    // the report counts them all: the inertia count's and the space's, none per frequency;
    // rom.toml keeps the count
    let report = rom.sampling().unwrap();
    assert_eq!(report.factorizations_in_all, 2);
    let root = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("damping_material");
    let _ = std::fs::remove_dir_all(&root);
    rom_dir::write(&root, &rom).unwrap();
    let read = rom_dir::read(&root).unwrap();
    assert_eq!(read.sampling().unwrap().factorizations_in_all, 2);
    let v0 = sparsemor::rigid::rigid_modes(model.nodes.as_ref().unwrap(), 3);
    let mut worst = 0.0f64;
    for k in 0..40 {
        let f = 2.0 + 997.0 * k as f64 / 39.0;
        let h = dense_h1_deflated(&model, &v0, f, &scene.inputs, &scene.outputs);
        worst = worst.max(rel_err(&rom.transfer(f), &h));
    }
    assert!(worst <= tol, "order {}: {worst:.2e}", rom.order());
}
