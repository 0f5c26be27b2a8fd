//! Craig–Bampton (docs/design.md §3.8) against independent references: a dense Craig–Bampton
//! written here (dense K_ii solve, dense fixed-interface modes refined by subspace
//! iteration) on the built-in bar, an Abaqus block and a constrained random model; EXUDYN's
//! `ComputeHurtyCraigBamptonModes` (when `exudyn` is installed); free-body rigid modes; the
//! Rayleigh–Ritz bounds; the ROM directory round trip.

use crate::common::{dense, random_model};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::fe::{bar_model, paper_io_dofs, paper_scene, BoxSpec};
use sparsemor::io::{import, rom_dir};
use sparsemor::metrics::rom_eigenfrequencies;
use sparsemor::model::{Damping, Model};
use sparsemor::reduce::craig_bampton::{reduce, CraigBamptonOptions};
use sparsemor::reduce::linefit::Interface;
use sparsemor::reduce::Method;
use sparsemor::scene::Scene;
use sparsemor::Error;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Generalized eigenvalues of a small dense pencil (Kr, Mr), ascending, via Mr = LLᵀ.
fn small_eigenvalues(k: &Mat<f64>, m: &Mat<f64>) -> Vec<f64> {
    let l = m.llt(Side::Lower).expect("Mr SPD").L().to_owned();
    let n = k.nrows();
    let linv = l
        .as_ref()
        .partial_piv_lu()
        .solve(Mat::<f64>::identity(n, n));
    let c = &linv * k * linv.transpose();
    let c = Mat::from_fn(n, n, |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    c.self_adjoint_eigenvalues(Side::Lower).unwrap()
}

fn hz(l: f64) -> f64 {
    l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI)
}

/// The dense Craig–Bampton ROM eigenfrequencies (Hz, ascending) of `model` for `boundary`
/// and c modes, and the fixed-interface frequencies (σ < the lowest of them). Ψ by a dense LU solve of K_ii; Φ_c
/// from the dense symmetric eigenproblem of Lᵀ(K_ii − σM_ii)⁻¹L (M_ii = LLᵀ) with c + 10
/// vectors, refined by 3 steps of subspace iteration with (K_ii − σM_ii)⁻¹M_ii and a
/// Rayleigh–Ritz step (faer's dense eigenvectors alone are not accurate enough at N ≈ 1600,
/// tests/it/common.rs).
fn dense_cb(model: &Model, boundary: &[usize], c: usize, sigma: f64) -> (Vec<f64>, Vec<f64>) {
    let (k, m) = (dense(&model.stiffness), dense(&model.mass));
    let n = k.nrows();
    let interior: Vec<usize> = (0..n).filter(|d| !boundary.contains(d)).collect();
    let ni = interior.len();
    let sub = |a: &Mat<f64>, r: &[usize], c: &[usize]| {
        Mat::from_fn(r.len(), c.len(), |i, j| a[(r[i], c[j])])
    };
    let (kii, mii, kib) = (
        sub(&k, &interior, &interior),
        sub(&m, &interior, &interior),
        sub(&k, &interior, boundary),
    );
    let psi = -kii.partial_piv_lu().solve(&kib);
    let mut v = Mat::<f64>::zeros(n, boundary.len() + c);
    for (j, &b) in boundary.iter().enumerate() {
        v[(b, j)] = 1.0;
        for (r, &d) in interior.iter().enumerate() {
            v[(d, j)] = psi[(r, j)];
        }
    }
    let mut fixed = Vec::new();
    if c > 0 {
        // dense shift-invert (σ below the spectrum of (K_ii, M_ii)), then subspace iteration
        let a = Mat::from_fn(ni, ni, |i, j| kii[(i, j)] - sigma * mii[(i, j)]);
        let a_lu = a.partial_piv_lu();
        let l = mii.llt(Side::Lower).unwrap().L().to_owned();
        let cm = l.transpose() * a_lu.solve(&l);
        let cm = Mat::from_fn(ni, ni, |i, j| 0.5 * (cm[(i, j)] + cm[(j, i)]));
        let evd = cm.self_adjoint_eigen(Side::Lower).unwrap();
        let p = (c + 10).min(ni);
        // largest θ are the last columns; x = L⁻ᵀ y
        let y = Mat::from_fn(ni, p, |i, j| evd.U()[(i, ni - 1 - j)]);
        let lt = l.transpose().to_owned();
        let mut x = lt.as_ref().partial_piv_lu().solve(&y);
        for _ in 0..3 {
            x = a_lu.solve(&mii * &x);
            let q = x.qr().compute_thin_Q();
            x = q;
        }
        // Rayleigh–Ritz on span x
        let (kx, mx) = (x.transpose() * &kii * &x, x.transpose() * &mii * &x);
        let lm = mx.llt(Side::Lower).unwrap().L().to_owned();
        let linv = lm
            .as_ref()
            .partial_piv_lu()
            .solve(Mat::<f64>::identity(p, p));
        let cr = &linv * &kx * linv.transpose();
        let cr = Mat::from_fn(p, p, |i, j| 0.5 * (cr[(i, j)] + cr[(j, i)]));
        let e = cr.self_adjoint_eigen(Side::Lower).unwrap();
        let phi = &x * (linv.transpose() * e.U());
        for j in 0..c {
            fixed.push(hz(e.S()[j]));
            for (r, &d) in interior.iter().enumerate() {
                v[(d, boundary.len() + j)] = phi[(r, j)];
            }
        }
    }
    let (kr, mr) = (v.transpose() * &k * &v, v.transpose() * &m * &v);
    let sym =
        |a: Mat<f64>| Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let f = small_eigenvalues(&sym(kr), &sym(mr))
        .into_iter()
        .map(hz)
        .collect();
    (f, fixed)
}

/// Largest relative difference over the elastic frequencies (|f| ≥ 1 Hz in `b`), and the
/// largest |f| of the rigid ones (|f| < 1 Hz in `b`) in either list.
fn compare(a: &[f64], b: &[f64]) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let (mut rel, mut rigid) = (0.0f64, 0.0f64);
    for (x, y) in a.iter().zip(b) {
        if y.abs() < 1.0 {
            rigid = rigid.max(x.abs()).max(y.abs());
        } else {
            rel = rel.max(((x - y) / y).abs());
        }
    }
    (rel, rigid)
}

/// All three DoFs of each node.
fn node_dofs(nodes: &[usize]) -> Vec<usize> {
    nodes
        .iter()
        .flat_map(|&n| (0..3).map(move |d| 3 * n + d))
        .collect()
}

/// The bar's boundary: the nodes of the paper's I/O DoFs (collinear, on one edge) plus the
/// node of the first spread DoF (off that edge), so that the boundary holds the free bar.
fn bar_boundary_nodes(model: &Model) -> Vec<usize> {
    let spec = BoxSpec::paper_bar();
    let io = paper_io_dofs(&spec);
    let mut nodes: Vec<usize> = io.iter().step_by(3).map(|d| d / 3).collect();
    let body = Body::new(model).unwrap();
    let extra = sparsemor::reduce::linefit::spread_dofs(&body, 1, &io).unwrap();
    nodes.push(extra[0] / 3);
    nodes
}

fn cb_rom_frequencies(
    model: &Model,
    scene: &Scene,
    boundary: &[usize],
    c: usize,
) -> (Vec<f64>, Vec<f64>) {
    let opts = CraigBamptonOptions::new(Interface::Explicit(boundary.to_vec()), c, 1000.0);
    let rom = reduce(&Body::new(model).unwrap(), scene, &opts).unwrap();
    assert_eq!(rom.method(), Method::CraigBampton);
    assert_eq!(rom.order(), boundary.len() + c);
    let cb = rom.craig_bampton().unwrap();
    println!(
        "  K_ii by {}, constraint-mode residual {:.1e}, fixed-interface η max {:.1e}",
        cb.factorization,
        cb.static_residual,
        cb.mode_residuals.iter().copied().fold(0.0, f64::max)
    );
    assert!(cb.static_residual < 1e-10, "{}", cb.static_residual);
    assert!(cb.mode_residuals.iter().all(|&e| e < 1e-12));
    (
        rom_eigenfrequencies(&rom).unwrap(),
        cb.fixed_interface_hz.clone(),
    )
}

#[test]
fn bar_equals_dense_craig_bampton() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let boundary = node_dofs(&bar_boundary_nodes(&model));
    for c in [0, 6] {
        let (f, fixed) = cb_rom_frequencies(&model, &scene, &boundary, c);
        let (fd, fixed_d) = dense_cb(&model, &boundary, c, -1.0);
        let (rel, rigid) = compare(&f, &fd);
        let (rel_fixed, _) = compare(&fixed, &fixed_d);
        println!(
            "bar, {} boundary DoFs, c = {c}: ROM frequencies {:?}\n  max rel. diff. vs dense {rel:.2e}, \
             rigid |f| <= {rigid:.1e} Hz, fixed-interface max rel. diff. {rel_fixed:.2e}",
            boundary.len(),
            &f[6..]
        );
        assert!(rel <= 1e-9, "c = {c}: {rel:.2e}");
        assert!(rel_fixed <= 1e-9, "c = {c}: {rel_fixed:.2e}");
        assert!(rigid < 1e-2, "c = {c}: rigid modes at {rigid} Hz");
    }
}

fn abaqus_block(job: &str) -> Option<[PathBuf; 3]> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/abaqus_exudyn");
    if !d.exists() {
        println!("note: {} not found; skipped", d.display());
        return None;
    }
    Some([
        d.join(format!("{job}_STIF1.mtx")),
        d.join(format!("{job}_MASS1.mtx")),
        d.join(format!("{job}.inp")),
    ])
}

/// An Abaqus block as a model, and four boundary nodes: the corners of the bounding box
/// nearest to (lo, lo, lo), (hi, lo, lo), (lo, hi, lo), (lo, lo, hi).
fn block_model(job: &str) -> Option<(Model, Vec<usize>)> {
    let files = abaqus_block(job)?;
    let imp = import::read(&files).unwrap();
    let (model, _) = imp.into_model(job.into()).unwrap();
    let nodes = model.nodes.clone().unwrap();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &nodes {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let corners = [
        [lo[0], lo[1], lo[2]],
        [hi[0], lo[1], lo[2]],
        [lo[0], hi[1], lo[2]],
        [lo[0], lo[1], hi[2]],
    ];
    let picked = corners
        .iter()
        .map(|c| {
            (0..nodes.len())
                .min_by(|&i, &j| {
                    let d = |k: usize| (0..3).map(|a| (nodes[k][a] - c[a]).powi(2)).sum::<f64>();
                    d(i).total_cmp(&d(j))
                })
                .unwrap()
        })
        .collect();
    Some((model, picked))
}

#[test]
fn abaqus_block_equals_dense_craig_bampton() {
    let Some((model, nodes)) = block_model("blockC3D8") else {
        return;
    };
    let boundary = node_dofs(&nodes);
    let scene = Scene {
        inputs: boundary[..3].to_vec(),
        outputs: boundary[..3].to_vec(),
        band_hz: [0.0, 2000.0],
    };
    let (f, fixed) = cb_rom_frequencies(&model, &scene, &boundary, 8);
    let (fd, fixed_d) = dense_cb(&model, &boundary, 8, -1.0);
    let (rel, rigid) = compare(&f, &fd);
    let (rel_fixed, _) = compare(&fixed, &fixed_d);
    println!(
        "blockC3D8 (N = {}), boundary nodes {nodes:?}, c = 8: ROM frequencies {:?}\n  max rel. diff. vs dense {rel:.2e}, \
         rigid |f| <= {rigid:.1e} Hz, fixed-interface max rel. diff. {rel_fixed:.2e}",
        model.n(),
        &f[6..]
    );
    assert!(rel <= 1e-9, "{rel:.2e}");
    assert!(rel_fixed <= 1e-9, "{rel_fixed:.2e}");
    assert!(rigid < 1e-2, "rigid modes at {rigid} Hz");
}

#[test]
fn constrained_body_cholesky_and_indefinite_lblt_equal_dense() {
    // constrained (K SPD): Cholesky of K_ii
    let model = random_model(120, 4, 7, Damping::None);
    let scene = Scene {
        inputs: vec![0, 60],
        outputs: vec![0, 60, 119],
        band_hz: [0.0, 100.0],
    };
    let boundary = vec![0, 30, 60, 90, 119];
    let (f, _) = cb_rom_frequencies(&model, &scene, &boundary, 5);
    let (fd, _) = dense_cb(&model, &boundary, 5, -1.0);
    let (rel, _) = compare(&f, &fd);
    println!("random constrained model: max rel. diff. vs dense {rel:.2e}");
    assert!(rel <= 1e-9, "{rel:.2e}");
    // K − s·M with s between the two lowest fixed-interface eigenvalues (a softened
    // structure): K_ii is indefinite, so it is factored by LBLᵀ
    let (k, m) = (dense(&model.stiffness), dense(&model.mass));
    let (_, fixed) = dense_cb(&model, &boundary, 2, -1.0);
    let lam: Vec<f64> = fixed
        .iter()
        .map(|f| (2.0 * std::f64::consts::PI * f).powi(2))
        .collect();
    let s = 0.5 * (lam[0] + lam[1]);
    let soft = crate::common::sparse(&Mat::from_fn(120, 120, |i, j| k[(i, j)] - s * m[(i, j)]));
    let (soft_model, _) = Model::new(
        "soft".into(),
        model.mass.clone(),
        soft,
        Damping::None,
        None,
        3,
    )
    .unwrap();
    let mut opts = CraigBamptonOptions::new(Interface::Explicit(boundary.clone()), 4, 100.0);
    opts.eigen.sigma = Some(-4.0 * s);
    let rom = reduce(&Body::new(&soft_model).unwrap(), &scene, &opts).unwrap();
    let cb = rom.craig_bampton().unwrap();
    let (fd, fixed_d) = dense_cb(&soft_model, &boundary, 4, -4.0 * s);
    let f = rom_eigenfrequencies(&rom).unwrap();
    let (rel, _) = compare(&f, &fd);
    let (rel_fixed, _) = compare(&cb.fixed_interface_hz, &fixed_d);
    println!(
        "indefinite K (shift {s:.3e}): K_ii by {}, pivot ratio {:?}, max rel. diff. vs dense {rel:.2e} (fixed-interface {rel_fixed:.2e})",
        cb.factorization, cb.pivot_ratio
    );
    assert_eq!(cb.factorization, "lblt");
    assert!(
        rel <= 1e-9 && rel_fixed <= 1e-9,
        "{rel:.2e} {rel_fixed:.2e}"
    );
}

#[test]
fn free_bar_rigid_modes_and_rayleigh_ritz_bounds() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let body = Body::new(&model).unwrap();
    let full = eigenpairs(&body, Request::Lowest(16), &EigenOptions::for_band(1000.0)).unwrap();
    let f_full = full.freqs_hz();
    let mut previous: Option<Vec<f64>> = None;
    for c in [0, 2, 4, 8] {
        let opts = CraigBamptonOptions::new(Interface::OutputsPlus(1), c, 1000.0);
        let rom = reduce(&body, &scene, &opts).unwrap();
        let f = rom_eigenfrequencies(&rom).unwrap();
        println!(
            "c = {c}: order {}, ROM frequencies {:?}",
            rom.order(),
            &f[..10]
        );
        // the 6 rigid modes at 0 Hz, carried by the constraint modes
        assert!(f[..6].iter().all(|x| x.abs() < 1e-2), "{:?}", &f[..6]);
        assert!(f[6] > 100.0);
        // no "Kr not positive definite" warning for the expected rigid null space
        assert!(rom.warnings.is_empty(), "{:?}", rom.warnings);
        // Rayleigh–Ritz: every ROM frequency bounds the full one from above, and the
        // nested subspaces (c grows) lower every bound
        for k in 6..f.len().min(f_full.len()) {
            assert!(f[k] >= f_full[k] * (1.0 - 1e-10), "c = {c}, mode {k}");
        }
        if let Some(p) = &previous {
            for k in 6..p.len() {
                assert!(f[k] <= p[k] * (1.0 + 1e-10), "c = {c}, mode {k}");
            }
        }
        previous = Some(f);
    }
}

#[test]
fn a_boundary_that_does_not_hold_the_free_body_is_refused() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    // the 9 I/O DoFs sit at three nodes on one edge: rotation about that edge is free
    let opts = CraigBamptonOptions::new(Interface::OutputsPlus(0), 4, 1000.0);
    match reduce(&Body::new(&model).unwrap(), &scene, &opts) {
        Err(Error::InvalidSetting(m)) => assert!(m.contains("non-collinear"), "{m}"),
        other => panic!("expected a refusal, got {:?}", other.map(|r| r.order())),
    }
    let opts = CraigBamptonOptions::new(Interface::OutputsPlus(1), 2000, 1000.0);
    assert!(matches!(
        reduce(&Body::new(&model).unwrap(), &scene, &opts),
        Err(Error::InvalidSetting(_))
    ));
}

#[test]
fn rom_directory_round_trip() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let opts = CraigBamptonOptions::new(Interface::OutputsPlus(1), 4, 1000.0);
    let rom = reduce(&Body::new(&model).unwrap(), &scene, &opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rom");
    rom_dir::write(&out, &rom).unwrap();
    let back = rom_dir::read(&out).unwrap();
    assert_eq!(back.method(), Method::CraigBampton);
    assert_eq!(back.craig_bampton(), rom.craig_bampton());
    assert_eq!((&back.dofs, back.order()), (&rom.dofs, 14));
    assert_eq!(back.kr, rom.kr);
    assert_eq!(back.mr, rom.mr);
    back.check_model(model.n()).unwrap();
}

// ---------------------------------------------------------------------------------------------
// EXUDYN's Hurty–Craig–Bampton modes

/// EXUDYN: `ComputeHurtyCraigBamptonModes(boundaryNodesList=[nodes], nEigenModes=c,
/// computationMode=allBoundaryNodes)` — one static mode per boundary coordinate (all three
/// DoFs of each boundary node) and c fixed-interface modes (scipy `eigsh`, shift 0), i.e.
/// classical Craig–Bampton with the same boundary DoFs (its RBE2/RBE3 modes replace the
/// boundary by rigid/averaged interfaces and are not comparable). EXUDYN reads the model
/// itself (Abaqus files, or the bar's model directory with scipy); the script prints the
/// eigenfrequencies of (ΦᵀKΦ, ΦᵀMΦ) and EXUDYN's fixed-interface frequencies.
const EXUDYN_SCRIPT: &str = r#"
import sys, json
import numpy as np, scipy.io, scipy.linalg, scipy.sparse
from exudyn.FEM import FEMinterface, HCBstaticModeSelection
cfg = json.loads(sys.argv[1])
fem = FEMinterface()
if cfg["kind"] == "abaqus":
    fem.ImportFromAbaqusInputFile(cfg["inp"], typeName="Instance", name=cfg["instance"])
    fem.ReadMassMatrixFromAbaqus(cfg["mass"])
    fem.ReadStiffnessMatrixFromAbaqus(cfg["stiffness"])
else:
    fem.nodes = {"Position": np.loadtxt(cfg["nodes"], delimiter=",", skiprows=1)}
    fem.massMatrix = scipy.sparse.csr_matrix(scipy.io.mmread(cfg["mass"]))
    fem.stiffnessMatrix = scipy.sparse.csr_matrix(scipy.io.mmread(cfg["stiffness"]))
fem.ComputeHurtyCraigBamptonModes(boundaryNodesList=[cfg["nodes_b"]], nEigenModes=cfg["c"],
                                  useSparseSolver=True,
                                  computationMode=HCBstaticModeSelection.allBoundaryNodes)
phi = fem.modeBasis["matrix"]
K, M = fem.GetStiffnessMatrix(), fem.GetMassMatrix()
kr, mr = phi.T @ (K @ phi), phi.T @ (M @ phi)
lam = scipy.linalg.eigh(0.5 * (kr + kr.T), 0.5 * (mr + mr.T), eigvals_only=True)
hz = lambda l: np.sign(l) * np.sqrt(np.abs(l)) / (2 * np.pi)
print(json.dumps({"rom_hz": [hz(l) for l in lam],
                  "fixed_hz": sorted(hz(l) for l in fem.eigenValues)}))
"#;

fn exudyn_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import exudyn, scipy, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        println!("NOTE: python3 with exudyn, scipy and numpy not found; skipping the EXUDYN comparison (pip install exudyn scipy)");
    }
    ok
}

/// Runs the EXUDYN script; returns (ROM frequencies, fixed-interface frequencies).
fn exudyn_cb(cfg: &str) -> (Vec<f64>, Vec<f64>) {
    let out = Command::new("python3")
        .args(["-c", EXUDYN_SCRIPT, cfg])
        .output()
        .expect("run python3");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "EXUDYN script failed:\n{}\n{}",
        stdout,
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout.lines().last().unwrap_or_default();
    let num_list = |key: &str| -> Vec<f64> {
        let start = line.find(&format!("\"{key}\": [")).expect(key) + key.len() + 5;
        let end = start + line[start..].find(']').unwrap();
        line[start..end]
            .split(',')
            .filter(|s| !s.trim().is_empty())
            .map(|s| s.trim().parse().unwrap())
            .collect()
    };
    (num_list("rom_hz"), num_list("fixed_hz"))
}

fn check_against_exudyn(what: &str, ours: (Vec<f64>, Vec<f64>), theirs: (Vec<f64>, Vec<f64>)) {
    let (rel, rigid) = compare(&ours.0, &theirs.0);
    let (rel_fixed, _) = compare(&ours.1, &theirs.1);
    println!(
        "{what} vs EXUDYN ComputeHurtyCraigBamptonModes(allBoundaryNodes): ROM frequencies max rel. diff. {rel:.2e} \
         (rigid |f| <= {rigid:.1e} Hz), fixed-interface max rel. diff. {rel_fixed:.2e}\n  ours   {:?}\n  EXUDYN {:?}",
        &ours.0[6..],
        &theirs.0[6..]
    );
    assert!(rel <= 1e-8, "{what}: {rel:.2e}");
    assert!(rel_fixed <= 1e-8, "{what}: {rel_fixed:.2e}");
    assert!(rigid < 1e-2, "{what}: rigid modes at {rigid} Hz");
}

#[test]
fn abaqus_block_equals_exudyn_hurty_craig_bampton() {
    if !exudyn_available() {
        return;
    }
    let (Some((model, nodes)), Some(files)) = (block_model("blockC3D8"), abaqus_block("blockC3D8"))
    else {
        return;
    };
    let boundary = node_dofs(&nodes);
    let scene = Scene {
        inputs: boundary[..3].to_vec(),
        outputs: boundary[..3].to_vec(),
        band_hz: [0.0, 2000.0],
    };
    let c = 8;
    let ours = cb_rom_frequencies(&model, &scene, &boundary, c);
    let cfg = format!(
        r#"{{"kind": "abaqus", "instance": "block-1", "stiffness": "{}", "mass": "{}", "inp": "{}", "nodes_b": {nodes:?}, "c": {c}}}"#,
        files[0].display(),
        files[1].display(),
        files[2].display()
    );
    check_against_exudyn("blockC3D8", ours, exudyn_cb(&cfg));
}

#[test]
fn bar_equals_exudyn_hurty_craig_bampton() {
    if !exudyn_available() {
        return;
    }
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let nodes = bar_boundary_nodes(&model);
    let boundary = node_dofs(&nodes);
    let c = 6;
    let ours = cb_rom_frequencies(&model, &scene, &boundary, c);
    let dir = tempfile::tempdir().unwrap();
    let mdir = dir.path().join("bar");
    sparsemor::io::model_dir::write(&mdir, &model, &scene).unwrap();
    let cfg = format!(
        r#"{{"kind": "dir", "stiffness": "{}", "mass": "{}", "nodes": "{}", "nodes_b": {nodes:?}, "c": {c}}}"#,
        mdir.join("K.mtx").display(),
        mdir.join("M.mtx").display(),
        mdir.join("nodes.csv").display()
    );
    check_against_exudyn("paper bar", ours, exudyn_cb(&cfg));
}

/// With dashpots on a Rayleigh-damped body (a low-rank damping remainder, docs/design.md
/// §3.12), Craig–Bampton adds the dampers' residual vectors (§3.8): the fixed-interface modes
/// have no static response to the dampers' forces. The ROM with them is compared with the same
/// basis without them (the last column dropped), against full solves, with 40 modes: measured
/// max ε 9.0e-4 with, 1.6e-2 without.
#[test]
fn dampers_residual_vectors_bring_the_damped_response() {
    use sparsemor::metrics::{ErrorCurve, Reference};
    use sparsemor::reduce::{project, Rom};
    use sparsemor::sweep::{no_progress, SweepOptions};
    let spec = BoxSpec {
        elements: [1, 2, 24],
        ..BoxSpec::paper_bar()
    };
    let scene = paper_scene(&spec);
    let mut model = bar_model(&spec).unwrap();
    // two axial dashpots of 300 N s/m between z DoFs of nodes on one line along the bar
    let nodes = model.nodes.clone().unwrap();
    let line: Vec<usize> = {
        let mut on: Vec<usize> = (0..nodes.len())
            .filter(|&i| nodes[i][0] == nodes[0][0] && nodes[i][1] == nodes[0][1])
            .collect();
        on.sort_by(|&a, &b| nodes[a][2].total_cmp(&nodes[b][2]));
        on
    };
    let mut t = sparsemor::sparse::Triplets::default();
    let k = &model.stiffness;
    for j in 0..k.ncols() {
        let rows = k.symbolic().row_idx_of_col_raw(j);
        for (&i, &v) in rows.iter().zip(k.val_of_col(j)) {
            t.push(i, j, 1e-6 * v);
        }
    }
    let c = 300.0;
    for (a, b) in [
        (line[0], line[line.len() - 1]),
        (line[2], line[line.len() / 2]),
    ] {
        let (a, b) = (3 * a + 2, 3 * b + 2);
        for (i, j, v) in [(a, a, c), (b, b, c), (a, b, -c), (b, a, -c)] {
            t.push(i, j, v);
        }
    }
    model.damping = Damping::Matrix(t.into_csc(model.n(), false));
    let body = Body::new(&model).unwrap();
    assert_eq!(body.pencil().remainder().map(|r| r.rank()), Some(2));
    let mut opts = CraigBamptonOptions::new(Interface::OutputsPlus(1), 40, scene.band_hz[1]);
    opts.keep_basis = true;
    let with = reduce(&body, &scene, &opts).unwrap();
    let sparsemor::reduce::Provenance::CraigBampton(report) = &with.provenance else {
        panic!("a Craig–Bampton ROM");
    };
    // the first dashpot acts on boundary DoFs only (its ends are I/O nodes): its force
    // pattern has no interior part, so one residual vector remains
    let r = report.residual_vectors;
    assert_eq!(r, 1);
    assert_eq!(with.order(), with.dofs.len() + 40 + r);
    let v = with.basis.as_ref().unwrap();
    let v_plain = v.subcols(0, v.ncols() - r).to_owned();
    let plain = Rom::from_projection(
        with.provenance.clone(),
        body.n(),
        project(&body, &scene, v_plain.as_ref()),
        with.dofs.clone(),
        &scene,
        Vec::new(),
        None,
    );
    let freqs: Vec<f64> = (0..30).map(|k| 5.0 + 995.0 * k as f64 / 29.0).collect();
    let reference = Reference::compute(
        &body,
        &scene,
        &freqs,
        &SweepOptions::default(),
        None,
        &no_progress,
    )
    .unwrap();
    let eps = |rom: &Rom| ErrorCurve::max_mean(&reference.error(rom).unwrap().eps_elastic).0;
    let (e_with, e_plain) = (eps(&with), eps(&plain));
    eprintln!("max eps with residual vectors {e_with:.2e}, without {e_plain:.2e}");
    assert!(
        e_with <= e_plain / 10.0,
        "with {e_with:.2e}, without {e_plain:.2e}"
    );
}
