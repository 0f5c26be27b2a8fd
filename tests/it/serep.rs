//! SEREP (paper §3.1, docs/design.md §3.6) on the paper's bar: exact reproduction of the kept
//! modes with c = r, the documented warnings (c > r, ill-conditioned U_cr) and bad settings.

use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Modes, Request};
use sparsemor::fe::{bar_model, paper_io_dofs, paper_scene, BoxSpec};
use sparsemor::metrics::{modal_comparison, rom_eigenfrequencies, rom_modes};
use sparsemor::model::Model;
use sparsemor::reduce::serep::{reduce, ModeChoice, SerepOptions};
use sparsemor::reduce::Rom;
use sparsemor::Error;
use std::sync::OnceLock;

/// The paper bar, its nine I/O DoFs and its 15 lowest modes (6 rigid + 9 deformation).
fn bar() -> &'static (Model, Vec<usize>, Modes) {
    static BAR: OnceLock<(Model, Vec<usize>, Modes)> = OnceLock::new();
    BAR.get_or_init(|| {
        let spec = BoxSpec::paper_bar();
        let model = bar_model(&spec).unwrap();
        let full = eigenpairs(
            &Body::new(&model).unwrap(),
            Request::Lowest(15),
            &EigenOptions::for_band(1000.0),
        )
        .unwrap();
        assert_eq!(full.rigid, 6);
        (model, paper_io_dofs(&spec), full)
    })
}

fn serep(modes: ModeChoice, retain: Vec<usize>) -> sparsemor::Result<Rom> {
    let (model, io, _) = bar();
    let opts = SerepOptions {
        modes,
        retain: Some(retain),
        keep_basis: true,
        eigen: EigenOptions::for_band(1000.0),
    };
    let scene = paper_scene(&BoxSpec::paper_bar());
    assert_eq!(&scene.inputs, io);
    reduce(&Body::new(model)?, &scene, &opts, None)
}

/// Checks a c = r = 9 SEREP ROM of the 9 lowest deformation modes: its eigenfrequencies are
/// those of the kept modes to `tol[k]` relative, and every expanded ROM mode V φ̃ has
/// MAC ≥ 0.9999 with its full mode. Returns the measured relative errors.
fn check_reproduces(rom: &Rom, tol: &[f64]) -> Vec<f64> {
    let (_, _, full) = bar();
    assert_eq!(rom.order(), 9);
    assert_eq!(rom.modes(), (7..=15).collect::<Vec<_>>());
    assert!(
        rom.warnings.is_empty(),
        "unexpected warnings: {:?}",
        rom.warnings
    );
    let f_rom = rom_eigenfrequencies(rom).unwrap();
    let f_full = full.freqs_hz();
    let errors: Vec<f64> = (0..9)
        .map(|k| (f_rom[k] - f_full[6 + k]).abs() / f_full[6 + k])
        .collect();
    let cmp = modal_comparison(rom, full, rom.basis.as_ref().map(|v| v.as_ref())).unwrap();
    assert!(cmp.expanded);
    assert_eq!(cmp.pairs.len(), 9);
    for (k, p) in cmp.pairs.iter().enumerate() {
        println!(
            "mode {:2}: full {:9.3} Hz, ROM {:9.3} Hz, rel. error {:.1e} (bound {:.1e}), 1 - MAC {:.1e}",
            p.full_mode, p.full_hz, f_rom[k], errors[k], tol[k], 1.0 - p.mac
        );
        assert_eq!((p.full_mode, p.rom_mode), (7 + k, 1 + k), "pairing");
        assert!(p.mac >= 0.9999, "mode {}: MAC {}", p.full_mode, p.mac);
        assert!(
            errors[k] <= tol[k],
            "mode {}: ROM {} Hz vs full {} Hz ({:.1e})",
            p.full_mode,
            f_rom[k],
            p.full_hz,
            errors[k]
        );
    }
    errors
}

/// c = r = 9 on well-chosen DoFs: the 9 DoFs picked by a column-pivoted QR of U_cᵀ (the
/// Q-DEIM choice), which keeps U_cr well conditioned. The ROM reproduces the 9
/// eigenfrequencies to 1e-8.
#[test]
fn c_equal_r_reproduces_the_kept_modes() {
    let (_, _, full) = bar();
    let u_ct = full.vectors.as_ref().subcols(6, 9).transpose().to_owned();
    let qr = u_ct.col_piv_qr();
    let retain = qr.P().arrays().0[..9].to_vec();
    let rom = serep(ModeChoice::LowestDeformation(9), retain.clone()).unwrap();
    println!(
        "Q-DEIM DoFs {retain:?}: cond(U_cr) = {:.2e}",
        rom.serep_cond().unwrap()
    );
    check_reproduces(&rom, &[1e-8; 9]);
}

/// The paper's SEREP ROM: the 9 lowest deformation modes on its 9 I/O DoFs.
///
/// Here 1e-8 is below what double precision can represent: the ROM's coordinates are these
/// DoFs, and with cond(U_cr) = 6.8e4 the matrix Mr = (U_cr U_crᵀ)⁻¹ has condition 4.6e9.
/// Merely rounding the entries of Mr and Kr moves λ_k by up to ε·κ_k relative, with the
/// componentwise condition number κ_k = |x|ᵀ|Mr||x| + |x|ᵀ|Kr||x|/λ_k (x the Mr-normalized
/// ROM eigenvector): ε·κ_k = 3.2e-7 and 3.8e-7 for modes 7 and 8, ≤ 6.4e-8 for the others.
/// The bound per mode is therefore max(1e-8, ε·κ_k) on the frequency — twice the first-order
/// bound ½ε·κ_k for f = √λ/2π, as the ROM is built by a few more rounded operations.
/// Measured: 1.1e-8 and 2.6e-8 for modes 7 and 8, ≤ 5.2e-9 for the others.
#[test]
fn c_equal_r_on_the_paper_io_dofs() {
    let (_, io, _) = bar();
    let rom = serep(ModeChoice::LowestDeformation(9), io.clone()).unwrap();
    let (lam, x) = rom_modes(&rom).unwrap();
    let tol: Vec<f64> = (0..9)
        .map(|k| {
            let quad = |a: &faer::Mat<f64>, abs: bool| -> f64 {
                let mut s = 0.0;
                for i in 0..9 {
                    for j in 0..9 {
                        s += if abs {
                            (x[(i, k)] * a[(i, j)] * x[(j, k)]).abs()
                        } else {
                            x[(i, k)] * a[(i, j)] * x[(j, k)]
                        };
                    }
                }
                s
            };
            let kappa = quad(&rom.mr, true) / quad(&rom.mr, false)
                + quad(&rom.kr, true) / (lam[k] * quad(&rom.mr, false));
            (f64::EPSILON * kappa).max(1e-8)
        })
        .collect();
    println!("cond(U_cr) = {:.2e}", rom.serep_cond().unwrap());
    check_reproduces(&rom, &tol);
}

#[test]
fn more_modes_than_retained_dofs_warns() {
    let (_, io, _) = bar();
    let rom = serep(ModeChoice::LowestDeformation(12), io.clone()).unwrap();
    assert_eq!(rom.order(), 9);
    assert!(
        rom.warnings
            .iter()
            .any(|w| w.contains("c = 12 modes > r = 9 retained DoFs")),
        "warnings: {:?}",
        rom.warnings
    );
}

/// U_cr ill-conditioned: the first two deformation modes (bending in x, then in y) on the x
/// DoFs of the end-face nodes (1, 0, 0) and (1, 3, 0), which sit on the mid-plane x = L_x/2
/// symmetrically about y = L_y/2. In x-bending both move alike; in y-bending their x motion
/// (Poisson, ∝ (x − x_c)(y − y_c)) vanishes — the rows of U_cr are parallel up to rounding.
#[test]
fn ill_conditioned_u_cr_warns() {
    let spec = BoxSpec::paper_bar();
    let retain = vec![3 * spec.node_index(1, 0, 0), 3 * spec.node_index(1, 3, 0)];
    let rom = serep(ModeChoice::LowestDeformation(2), retain).unwrap();
    let cond = rom.serep_cond().unwrap();
    println!("cond(U_cr) = {cond:.2e}; warnings: {:#?}", rom.warnings);
    assert!(cond > sparsemor::reduce::serep::ILL_CONDITIONED);
    assert!(
        rom.warnings
            .iter()
            .any(|w| w.contains("U_cr is ill-conditioned")),
        "warnings: {:?}",
        rom.warnings
    );
}

fn expect_invalid(r: sparsemor::Result<Rom>, needle: &str) {
    match r {
        Err(e @ (Error::InvalidSetting(_) | Error::DofOutOfRange { .. })) => {
            let msg = e.to_string();
            assert!(msg.contains(needle), "{needle:?} not in {msg:?}")
        }
        Err(e) => panic!("expected InvalidSetting containing {needle:?}, got {e}"),
        Ok(rom) => panic!(
            "expected InvalidSetting containing {needle:?}, got a ROM of order {}",
            rom.order()
        ),
    }
}

#[test]
fn bad_settings_are_clear_errors() {
    let (model, io, _) = bar();
    let n = model.n();
    expect_invalid(
        serep(ModeChoice::LowestDeformation(0), io.clone()),
        "0 modes",
    );
    expect_invalid(
        serep(ModeChoice::LowestDeformation(n), io.clone()),
        &format!("only N = {n} DoFs"),
    );
    expect_invalid(
        serep(ModeChoice::LowestDeformation(3), vec![0, 1, n]),
        &format!("DoF {n} is out of range"),
    );
    expect_invalid(
        serep(ModeChoice::LowestDeformation(3), vec![5, 1, 5]),
        "DoF 5 appears twice",
    );
    expect_invalid(
        serep(ModeChoice::LowestDeformation(3), vec![]),
        "empty DoF list",
    );
    expect_invalid(
        serep(ModeChoice::Numbers(vec![7, 0, 8]), io.clone()),
        "1-based",
    );
    expect_invalid(
        serep(ModeChoice::Numbers(vec![]), io.clone()),
        "must not be empty",
    );
    expect_invalid(
        serep(ModeChoice::Numbers(vec![7, n + 1]), io.clone()),
        &format!("mode number {} is out of range", n + 1),
    );
    expect_invalid(
        serep(ModeChoice::Numbers(vec![7, 8, 7]), io.clone()),
        "mode 7 appears twice",
    );
    // fewer modes than retained DoFs: Mr, Kr would be singular — refused before any work
    expect_invalid(
        serep(ModeChoice::LowestDeformation(3), io.clone()),
        "c = 3 modes < r = 9 retained DoFs",
    );
    expect_invalid(
        serep(ModeChoice::Numbers(vec![7, 8]), io.clone()),
        "use at least 9 modes or retain at most 2 DoFs",
    );
}
