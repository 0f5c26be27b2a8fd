//! ROM export (docs/design.md §3.9, §4): `rom.npz` read by numpy against the `.mtx` files read
//! by scipy (bit for bit); the elastic basis against a dense reference written here; EXUDYN
//! building the exported bar and an imported Abaqus block as free-floating bodies. The Python
//! tests run when python3 has numpy and scipy (and exudyn); CI installs them
//! (`pip install numpy scipy exudyn`); otherwise they print why they were skipped.

use crate::cli::ok;
use crate::common::{dense, full_reference};
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{c64, Mat};
use sparsemor::body::Body;
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::io::{exudyn, model_dir, rom_dir};
use sparsemor::metrics::{rom_eigenfrequencies, ErrorCurve};
use sparsemor::model::Model;
use sparsemor::reduce::flexible::{elastic_basis, ElasticBasis};
use sparsemor::reduce::linefit::{self, Interface, LineFitOptions, References};
use sparsemor::reduce::serep::{self, ModeChoice, SerepOptions};
use sparsemor::reduce::Rom;
use sparsemor::scene::Scene;
use sparsemor::sweep::no_progress;
use std::path::Path;
use std::process::Command;

/// True when `python3 -c "import <modules>"` works; prints why a test is skipped otherwise.
pub(crate) fn python_has(modules: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        println!("NOTE: python3 with {modules} not found; skipped (pip install {modules})");
    }
    ok
}

/// Runs a Python program; returns its stdout, failing the test with its stderr.
pub(crate) fn python(args: &[&str]) -> String {
    let out = Command::new("python3").args(args).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "python3 {args:?} failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// The paper bar's line-fitting ROM of order 14 with V kept.
fn bar_rom(model: &Model, scene: &Scene) -> Rom {
    let body = Body::new(model).unwrap();
    let mut opts = LineFitOptions::new(
        Interface::OutputsPlus(5),
        References::Explicit(vec![50.0, 100.0, 200.0, 400.0, 800.0]),
    );
    opts.keep_basis = true;
    linefit::reduce(&body, scene, &opts, None, &no_progress).unwrap()
}

const NPZ_CHECK: &str = r#"
import sys, tomllib
import numpy as np, scipy.io as sio
d = sys.argv[1]
z = np.load(d + "/rom.npz")
for k in ["Mr", "Dr", "Kr", "Br", "Cr", "V"]:
    a = np.asarray(sio.mmread(f"{d}/{k}.mtx"), dtype=np.float64)
    b = z[k]
    assert b.dtype == np.float64 and a.shape == b.shape, (k, a.shape, b.shape)
    assert a.tobytes(order="C") == b.tobytes(order="C"), f"{k} differs from {k}.mtx"
meta = tomllib.loads(z["metadata"].item())
with open(d + "/rom.toml", "rb") as f:
    assert tomllib.load(f) == meta, "metadata differs from rom.toml"
for k in ["dofs", "inputs", "outputs", "modes"]:
    assert z[k].tolist() == meta[k], k
assert z["ref_freqs_hz"].tolist() == meta["ref_freqs_hz"]
assert (3 * z["dof_node"] + z["dof_dir"]).tolist() == meta["dofs"]
print(z["nodes"].shape[0], " ".join(float(x).hex() for x in z["eigenfrequencies_hz"]))
"#;

#[test]
fn rom_npz_loads_in_numpy_and_equals_the_mtx_files_bitwise() {
    if !python_has("numpy, scipy") {
        return;
    }
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let rom = bar_rom(&model, &scene);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("rom");
    rom_dir::write_for_body(&dir, &rom, &Body::new(&model).unwrap()).unwrap();
    let out = python(&["-c", NPZ_CHECK, dir.to_str().unwrap()]);
    let mut it = out.split_whitespace();
    assert_eq!(it.next(), Some("552"), "{out}");
    // the eigenfrequencies in rom.npz are the ROM's, bit for bit (as float.hex)
    let f: Vec<f64> = it.map(parse_hex).collect();
    assert_eq!(f, rom_eigenfrequencies(&rom).unwrap());
}

/// A Python `float.hex()` string as f64.
fn parse_hex(s: &str) -> f64 {
    let (sign, s) = s.strip_prefix('-').map_or((1.0, s), |r| (-1.0, r));
    let s = s.strip_prefix("0x").unwrap();
    let (mant, exp) = s.split_once('p').unwrap();
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut m = u64::from_str_radix(int, 16).unwrap() as f64;
    for (k, c) in frac.chars().enumerate() {
        m += c.to_digit(16).unwrap() as f64 / 16f64.powi(k as i32 + 1);
    }
    sign * m * 2f64.powi(exp.parse().unwrap())
}

/// Translations and rotations about the origin, per node (3 DoFs per node), built here.
fn rigid_modes(nodes: &[[f64; 3]]) -> Mat<f64> {
    Mat::from_fn(3 * nodes.len(), 6, |i, j| {
        let (p, a) = (nodes[i / 3], i % 3);
        match j {
            0..=2 => f64::from(u8::from(a == j)),
            // e_r × p, component a
            _ => {
                let r = j - 3;
                let (b, c) = ((r + 1) % 3, (r + 2) % 3);
                if a == b {
                    -p[c]
                } else if a == c {
                    p[b]
                } else {
                    0.0
                }
            }
        }
    })
}

/// Ascending eigenvalues of the dense pencil (K, M), M positive definite.
fn dense_pencil_eigenvalues(k: &Mat<f64>, m: &Mat<f64>) -> Vec<f64> {
    let l = m.llt(faer::Side::Lower).unwrap().L().to_owned();
    let linv = l.partial_piv_lu().inverse();
    let c = &linv * k * linv.transpose();
    let c = Mat::from_fn(c.nrows(), c.ncols(), |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    c.self_adjoint_eigenvalues(faer::Side::Lower).unwrap()
}

fn hz(lambda: f64) -> f64 {
    lambda.abs().sqrt() / (2.0 * std::f64::consts::PI)
}

/// Φ against a dense reference: V0ᵀMΦ = 0, ΦᵀMΦ = I, ΦᵀKΦ = diag(ω²), and the frequencies
/// of the pencil of X = V − V0 (V0ᵀMV0)⁻¹ V0ᵀMV formed densely here.
fn check_against_dense(model: &Model, v: &Mat<f64>, eb: &ElasticBasis) {
    let (m, k) = (dense(&model.mass), dense(&model.stiffness));
    let v0 = rigid_modes(model.nodes.as_ref().unwrap());
    let m0 = v0.transpose() * &m * &v0;
    let x = v - &v0 * m0.partial_piv_lu().solve(v0.transpose() * &m * v);
    // an orthonormal basis of span X: its r leading left singular vectors (the other
    // directions of X are the rigid columns the export drops)
    let phi = &eb.phi;
    let r = phi.ncols();
    assert_eq!(v.ncols() - eb.dropped, r);
    let svd = x.thin_svd().unwrap();
    let q = svd.U().subcols(0, r).to_owned();
    let (mq, kq) = (q.transpose() * &m * &q, q.transpose() * &k * &q);
    let lambdas = dense_pencil_eigenvalues(&kq, &mq);
    let reference: Vec<f64> = lambdas.iter().map(|&l| hz(l)).collect();
    let worst = reference
        .iter()
        .zip(&eb.eigenfrequencies_hz)
        .map(|(a, b)| ((a - b) / a).abs())
        .fold(0.0, f64::max);
    println!(
        "elastic basis: {r} modes, {} dropped; frequencies vs dense: {worst:.1e}",
        eb.dropped
    );
    assert!(worst <= 1e-9, "{reference:?}\n{:?}", eb.eigenfrequencies_hz);
    let (pm, pk) = (phi.transpose() * &m * phi, phi.transpose() * &k * phi);
    let w2 = |i: usize| (2.0 * std::f64::consts::PI * eb.eigenfrequencies_hz[i]).powi(2);
    for i in 0..r {
        for j in 0..r {
            let want = f64::from(u8::from(i == j));
            assert!((pm[(i, j)] - want).abs() <= 1e-10, "PhiT M Phi ({i},{j})");
            assert!(
                (pk[(i, j)] - want * w2(i)).abs() <= 1e-9 * w2(r - 1),
                "PhiT K Phi"
            );
        }
    }
    // largest M-cosine between span V0 and span Φ, from M-orthonormal bases of both
    let l0 = m0.llt(faer::Side::Lower).unwrap().L().to_owned();
    let c = l0.partial_piv_lu().inverse() * v0.transpose() * &m * phi;
    let cos = c.norm_l2();
    println!(
        "rigid coupling: {:.1e} (library {:.1e})",
        cos,
        eb.rigid_coupling.unwrap()
    );
    assert!(cos <= 1e-10 && eb.rigid_coupling.unwrap() <= 1e-10);
}

#[test]
fn elastic_basis_of_a_linefit_rom_is_rigid_free_and_keeps_its_accuracy() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let rom = bar_rom(&model, &scene);
    let body = Body::new(&model).unwrap();
    let eb = elastic_basis(&body, &scene, &rom).unwrap();
    assert_eq!(
        eb.dropped, 0,
        "a line-fitting basis carries no pure rigid column"
    );
    check_against_dense(&model, rom.basis.as_ref().unwrap(), &eb);
    let grid: Vec<f64> = (0..50).map(|k| 1.0 + 999.0 * k as f64 / 49.0).collect();
    let reference = full_reference(&body, &scene, &grid);
    let eps = |r: &Rom| ErrorCurve::max_mean(&reference.error(r).unwrap().eps_elastic);
    let (before, after) = (eps(&rom), eps(&eb.rom));
    println!(
        "eps elastic: before max {:.3e} mean {:.3e}, after max {:.3e} mean {:.3e}",
        before.0, before.1, after.0, after.1
    );
    assert!((after.0 - before.0).abs() <= 1e-6 * before.0);
    assert!((after.1 - before.1).abs() <= 1e-6 * before.1);
}

#[test]
fn elastic_basis_of_serep_drops_the_rigid_modes() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let body = Body::new(&model).unwrap();
    // modes 1–9 (six rigid + three elastic) retained on three non-collinear nodes, so the
    // rigid motions are observable there and span V = span of the nine modes
    let retain = [(0, 0, 0), (2, 0, 22), (0, 3, 45)]
        .iter()
        .flat_map(|&(i, j, k)| (0..3).map(move |a| 3 * spec.node_index(i, j, k) + a))
        .collect();
    let opts = SerepOptions {
        modes: ModeChoice::Numbers((1..=9).collect()),
        retain: Some(retain),
        keep_basis: true,
        eigen: sparsemor::eigen::EigenOptions::for_band(1000.0),
    };
    let rom = serep::reduce(&body, &scene, &opts, None).unwrap();
    let eb = elastic_basis(&body, &scene, &rom).unwrap();
    assert_eq!(eb.dropped, 6);
    assert!(eb.dropped_rel_norms.iter().all(|&s| s < 1e-10));
    check_against_dense(&model, rom.basis.as_ref().unwrap(), &eb);
    let f = rom_eigenfrequencies(&rom).unwrap();
    for (a, b) in f[6..].iter().zip(&eb.eigenfrequencies_hz) {
        assert!(
            ((a - b) / a).abs() <= 1e-9,
            "{f:?} vs {:?}",
            eb.eigenfrequencies_hz
        );
    }
}

#[test]
fn elastic_basis_needs_the_kept_basis() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let mut rom = bar_rom(&model, &scene);
    rom.basis = None;
    let body = Body::new(&model).unwrap();
    let e = elastic_basis(&body, &scene, &rom).unwrap_err().to_string();
    assert!(e.contains("--keep-basis"), "{e}");
}

/// Builds the export of `rom` in EXUDYN (examples/exudyn_flexible_body.py) and checks
/// (a) its linearized eigenfrequencies, (b) the harmonic response at the outputs in the
/// floating frame against H1, (c) the momentum drift of a free transient.
fn exudyn_check(label: &str, model: &Model, scene: &Scene, rom: &Rom, freq_hz: f64, dir: &Path) {
    let body = Body::new(model).unwrap();
    let eb = elastic_basis(&body, scene, rom).unwrap();
    exudyn::write(dir, model, &eb, None, &[], None).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/exudyn_flexible_body.py");
    let f = format!("{freq_hz}");
    let out = python(&[
        script.to_str().unwrap(),
        dir.to_str().unwrap(),
        "--json",
        "--freq",
        &f,
    ]);
    let j: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    let list = |k: &str| -> Vec<f64> {
        j[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    // (a)
    let (exu, ours) = (list("exudyn_hz"), &eb.eigenfrequencies_hz);
    assert_eq!(exu.len(), ours.len(), "{label}: {exu:?} vs {ours:?}");
    let worst = exu
        .iter()
        .zip(ours)
        .map(|(a, b)| ((a - b) / b).abs())
        .fold(0.0, f64::max);
    let rigid = list("rigid_lambdas");
    let lambda1 = (2.0 * std::f64::consts::PI * ours[0]).powi(2);
    println!("{label}: (a) {} elastic frequencies, max rel diff EXUDYN vs ROM {worst:.1e}; rigid λ {rigid:?}", ours.len());
    assert!(worst <= 1e-6);
    assert!(rigid.iter().all(|l| l.abs() <= 1e-6 * lambda1), "{rigid:?}");
    // (b) column of the first input at freq_hz
    let reference = full_reference(&body, scene, &[freq_hz]);
    let eps = reference.error(&eb.rom).unwrap().eps_elastic[0];
    let h1 = &reference.h1[0];
    let (re, im) = (list("response_re"), list("response_im"));
    let y: Vec<c64> = re.iter().zip(&im).map(|(&a, &b)| c64::new(a, b)).collect();
    let hr = eb.rom.transfer(freq_hz);
    let norm = |v: &mut dyn Iterator<Item = c64>| v.map(|z| z.norm_sqr()).sum::<f64>().sqrt();
    let d_h1 = norm(&mut y.iter().enumerate().map(|(o, &z)| z - h1[(o, 0)]));
    let d_hr = norm(&mut y.iter().enumerate().map(|(o, &z)| z - hr[(o, 0)]));
    let col = norm(&mut (0..y.len()).map(|o| hr[(o, 0)]));
    println!(
        "{label}: (b) {freq_hz} Hz: |y - H1| = {:.2e}·|H1|_F (ROM eps {eps:.2e}), |y - Hr| = {:.1e}·|Hr col|",
        d_h1 / h1.norm_l2(),
        d_hr / col
    );
    assert!(d_h1 <= eps * h1.norm_l2() * (1.0 + 1e-6));
    assert!(d_hr <= 1e-8 * col);
    // (c)
    let (lin, ang) = (
        j["drift_linear"].as_f64().unwrap(),
        j["drift_angular"].as_f64().unwrap(),
    );
    println!(
        "{label}: (c) momentum drift over 0.1 s, 4000 steps: linear {lin:.1e}, angular {ang:.1e}"
    );
    assert!(lin <= 1e-6 && ang <= 1e-6);
}

#[test]
fn exudyn_simulates_the_exported_bar() {
    if !python_has("numpy, scipy, exudyn") {
        return;
    }
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let rom = bar_rom(&model, &scene);
    let tmp = tempfile::tempdir().unwrap();
    exudyn_check("bar", &model, &scene, &rom, 300.0, &tmp.path().join("ex"));
}

#[test]
fn exudyn_simulates_an_exported_abaqus_block() {
    let Some(files) = crate::import::abaqus_set("blockC3D8", "_") else {
        return;
    };
    if !python_has("numpy, scipy, exudyn") {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    let mut args = vec!["import"];
    args.extend(files.iter().map(|p| p.to_str().unwrap()));
    args.extend([
        "--inputs",
        "1:x,1:y,1:z",
        "--band",
        "0:1200",
        "--out",
        "block",
    ]);
    ok(w, &args);
    ok(
        w,
        &[
            "reduce",
            "block",
            "--method",
            "linefit",
            "--extra-interface",
            "9",
            "--ref-freqs",
            "100,300,500,700,900,1100",
            "--keep-basis",
            "--out",
            "rom",
        ],
    );
    let printed = ok(
        w,
        &["export", "rom", "--model", "block", "--out", "rom_cli"],
    );
    assert!(
        printed.contains("rigid coupling") && printed.contains("eps elastic"),
        "{printed}"
    );
    let (model, scene, _) = model_dir::read(&w.join("block")).unwrap();
    let rom = rom_dir::read(&w.join("rom")).unwrap();
    exudyn_check("blockC3D8", &model, &scene, &rom, 800.0, &w.join("ex"));
}

#[test]
fn cli_export_without_the_basis_says_how_to_get_it_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    ok(w, &["generate", "bar", "--out", "bar"]);
    ok(
        w,
        &[
            "reduce",
            "bar",
            "--method",
            "linefit",
            "--extra-interface",
            "5",
            "--ref-freqs",
            "50,100,200,400,800",
            "--out",
            "rom",
        ],
    );
    let out = crate::cli::run(w, &["export", "rom", "--model", "bar", "--out", "ex"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--keep-basis"), "{err}");
    assert!(!w.join("ex").exists());
}
