//! Structural damping through the C ABI (docs/design.md §3.12, §6):
//! `sparsemor_model_set_structural_damping` (H = ηK + K₄), the ROM's K4r
//! (`SPARSEMOR_MATRIX_K4R`, `sparsemor_rom_has_structural_damping`) and
//! `sparsemor_model_damping_info`. Bad arguments are refused by name and leave the handle as
//! it was; a loss factor η and K₄ = ηK give the same ROM; an exact line-fit of a model with
//! η and a damper in K₄ reproduces C (K + iH − ω²M + iωD)⁻¹ B (dense) at its reference
//! frequencies.

use crate::common::*;
use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use sparsemor_ffi::*;
use std::ptr::{null, null_mut};

const N: usize = 40;
const BETA: f64 = 1e-4;
const ETA: f64 = 0.02;
/// The exact line-fit's reference frequencies (Hz): among the chain's resonances (0.2 to 20 Hz)
/// and above them.
const FREQS: [f64; 3] = [3.0, 11.0, 25.0];
/// Inputs = outputs.
const IO: [usize; 1] = [N - 1];

/// Asserts status `want` and a message containing `needle`.
#[track_caller]
fn expect(st: SparsemorStatus, want: SparsemorStatus, needle: &str) {
    let msg = last_error();
    assert_eq!(st, want, "message: {msg}");
    assert!(msg.contains(needle), "{msg:?} does not contain {needle:?}");
    println!("{want:?}: {msg}");
}

fn info(h: *const SparsemorModel) -> SparsemorDampingInfo {
    let mut i = SparsemorDampingInfo::default();
    let st = unsafe { sparsemor_model_damping_info(h, &mut i) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    i
}

/// An exact line-fit (interface 2·p·z = 6 = 1 output + 5) at [`FREQS`], one thread.
fn exact_linefit(h: *const SparsemorModel) -> *mut SparsemorRom {
    let o = options();
    let mut rom = null_mut();
    unsafe {
        assert_eq!(sparsemor_options_set_threads(o, 1), SparsemorStatus::Ok);
        assert_eq!(
            sparsemor_options_set_reference_frequencies(o, FREQS.as_ptr(), FREQS.len()),
            SparsemorStatus::Ok
        );
        assert_eq!(
            sparsemor_options_set_interface_outputs_plus(o, 5),
            SparsemorStatus::Ok
        );
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        sparsemor_options_free(o);
    }
    rom
}

/// H(iω) = C (K + iH − ω²M + iωβK)⁻¹ B of the chain, dense (B = Cᵀ = e_{N−1}).
fn dense_h(h: &Mat<f64>, f: f64) -> Mat<c64> {
    let (m, k) = chain(N);
    let w = 2.0 * std::f64::consts::PI * f;
    let a = Mat::<c64>::from_fn(N, N, |i, j| {
        let (m, k) = (m[i + j * N], k[i + j * N]);
        c64::new(k - w * w * m, w * BETA * k + h[(i, j)])
    });
    let b = Mat::<c64>::from_fn(N, 1, |i, _| c64::new(f64::from(i == IO[0]), 0.0));
    let x = a.partial_piv_lu().solve(&b);
    Mat::from_fn(1, 1, |_, _| x[(IO[0], 0)])
}

/// ηK as CSC arrays (full storage).
fn eta_k(eta: f64) -> CscArrays {
    let (_, k) = chain(N);
    let ek: Vec<f64> = k.iter().map(|v| eta * v).collect();
    CscArrays::from_dense(N, &ek)
}

#[test]
fn bad_structural_damping_is_refused_by_name_and_leaves_the_handle_unchanged() {
    let h = chain_model(N);
    let before = info(h);
    let set = |eta: f64, k4: *const SparsemorCsc| unsafe {
        sparsemor_model_set_structural_damping(h, eta, k4)
    };
    expect(
        set(f64::NAN, null()),
        SparsemorStatus::InvalidArgument,
        "eta = NaN",
    );
    expect(
        set(-0.01, null()),
        SparsemorStatus::InvalidArgument,
        "eta = -0.01",
    );
    expect(
        set(f64::INFINITY, null()),
        SparsemorStatus::InvalidArgument,
        "eta = inf",
    );
    expect(
        unsafe { sparsemor_model_set_structural_damping(null_mut(), ETA, null()) },
        SparsemorStatus::NullPointer,
        "model",
    );
    // K₄ of another size than the model
    let (_, k5) = chain(N - 1);
    let small = CscArrays::from_dense(N - 1, &k5);
    expect(
        set(ETA, &small.view()),
        SparsemorStatus::InvalidArgument,
        "k4 (structural damping matrix K4) is 39×39 but the model has N = 40",
    );
    // unsymmetric
    let mut skew = eta_k(0.02);
    let p = skew.col_ptr[3]; // entry (2, 3)
    skew.values[p] *= 2.0;
    expect(
        set(0.0, &skew.view()),
        SparsemorStatus::InvalidModel,
        "k4: invalid model: structural damping matrix K4 is not symmetric",
    );
    // not finite
    let mut nan = eta_k(0.02);
    nan.values[0] = f64::NAN;
    expect(
        set(0.0, &nan.view()),
        SparsemorStatus::InvalidArgument,
        "k4 (structural damping matrix K4): entry (0, 0) is not finite",
    );
    // a bad storage flag and a NULL array inside the descriptor
    let mut flag = eta_k(0.02);
    flag.storage = 9;
    expect(
        set(0.0, &flag.view()),
        SparsemorStatus::InvalidArgument,
        "k4 (structural damping matrix K4): storage = 9",
    );
    let arrays = eta_k(0.02);
    let mut v = arrays.view();
    v.values = null();
    expect(
        set(0.0, &v),
        SparsemorStatus::NullPointer,
        "k4 (structural damping matrix K4): values",
    );
    // nothing changed
    assert_eq!(info(h), before);
    assert_eq!(before.kind, SPARSEMOR_DAMPING_PROPORTIONAL);
    assert_eq!((before.alpha, before.beta, before.eta), (0.0, BETA, 0.0));
    expect(
        unsafe { sparsemor_model_damping_info(h, null_mut()) },
        SparsemorStatus::NullPointer,
        "info_out",
    );
    unsafe { sparsemor_model_free(h) };
}

#[test]
fn a_rom_without_structural_damping_has_no_k4r() {
    let h = chain_model(N);
    let rom = exact_linefit(h);
    let mut has = -1;
    assert_eq!(
        unsafe { sparsemor_rom_has_structural_damping(rom, &mut has) },
        SparsemorStatus::Ok
    );
    assert_eq!(has, 0);
    let (mut r, mut c, mut need) = (7, 7, 7);
    expect(
        unsafe { sparsemor_rom_matrix_shape(rom, SPARSEMOR_MATRIX_K4R, &mut r, &mut c) },
        SparsemorStatus::NotAvailable,
        "K4r: the ROM has no structural damping",
    );
    assert_eq!((r, c), (7, 7), "nothing written on failure");
    expect(
        unsafe { sparsemor_rom_copy_matrix(rom, SPARSEMOR_MATRIX_K4R, null_mut(), 0, &mut need) },
        SparsemorStatus::NotAvailable,
        "sparsemor_rom_has_structural_damping",
    );
    expect(
        unsafe { sparsemor_rom_copy_matrix(rom, 7, null_mut(), 0, &mut need) },
        SparsemorStatus::InvalidArgument,
        "_V or _K4R (0..6)",
    );
    expect(
        unsafe { sparsemor_rom_has_structural_damping(null(), &mut has) },
        SparsemorStatus::NullPointer,
        "rom",
    );
    expect(
        unsafe { sparsemor_rom_has_structural_damping(rom, null_mut()) },
        SparsemorStatus::NullPointer,
        "has_out",
    );
    unsafe {
        sparsemor_rom_free(rom);
        sparsemor_model_free(h);
    }
}

/// η alone and K₄ = ηK are the same H: the same split, the same ROM transfer function
/// (≤ 1e-10), and K4r = η Kr for the loss factor.
#[test]
fn a_loss_factor_and_k4_equal_to_eta_k_give_the_same_rom() {
    let (a, b) = (chain_model(N), chain_model(N));
    let st = unsafe { sparsemor_model_set_structural_damping(a, ETA, null()) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let k4 = eta_k(ETA);
    let st = unsafe { sparsemor_model_set_structural_damping(b, 0.0, &k4.view()) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let (ia, ib) = (info(a), info(b));
    println!("eta: {ia:?}\nK4 = eta K: {ib:?}");
    assert_eq!(ia.kind, SPARSEMOR_DAMPING_PROPORTIONAL);
    assert_eq!((ia.alpha, ia.beta, ia.eta, ia.gamma), (0.0, BETA, ETA, 0.0));
    assert_eq!(ib.kind, SPARSEMOR_DAMPING_PROPORTIONAL);
    assert!((ib.eta - ETA).abs() <= 1e-12 * ETA, "{ib:?}");
    assert!((ib.beta - BETA).abs() <= 1e-12 * BETA, "{ib:?}");

    let (ra, rb) = (exact_linefit(a), exact_linefit(b));
    let (_, _, kr) = rom_matrix(ra, SPARSEMOR_MATRIX_KR);
    let (r, c, k4r) = rom_matrix(ra, SPARSEMOR_MATRIX_K4R);
    assert_eq!((r, c), (6, 6));
    let scaled = kr
        .iter()
        .zip(&k4r)
        .map(|(k, h)| (ETA * k - h).abs())
        .fold(0.0, f64::max);
    assert!(scaled <= 1e-12 * kr.iter().fold(0.0f64, |s, v| s.max(v.abs())));
    let mut worst: f64 = 0.0;
    for f in [1.0, 3.0, 7.5, 11.0, 18.0, 25.0, 33.0] {
        let d = rel(&rom_transfer(rb, f), &rom_transfer(ra, f));
        worst = worst.max(d);
    }
    println!("eta vs K4 = eta K: ROM transfer functions differ by {worst:.2e} (max over 7 f)");
    assert!(worst <= 1e-10);
    unsafe {
        sparsemor_rom_free(ra);
        sparsemor_rom_free(rb);
        sparsemor_model_free(a);
        sparsemor_model_free(b);
    }
}

/// η and a hysteretic damper c (e_a − e_b)(e_a − e_b)ᵀ in K₄ on top of Rayleigh βK: the
/// exact line-fit reproduces the dense C A⁻¹ B with A = K + i(ηK + K₄) − ω²M + iωβK at its
/// reference frequencies (≤ 1e-8), `sparsemor_rom_transfer_error` agrees, and removing the
/// structural damping again gives a ROM without K4r.
#[test]
fn an_exact_line_fit_with_structural_damping_matches_the_dense_solve() {
    let h = chain_model(N);
    let (_, k) = chain(N);
    let (a, b) = (10, 25);
    let c = 0.1 * k[a + a * N];
    let mut damper = vec![0.0; N * N];
    damper[a + a * N] = c;
    damper[b + b * N] = c;
    damper[a + b * N] = -c;
    damper[b + a * N] = -c;
    let k4 = CscArrays::from_dense(N, &damper);
    let st = unsafe { sparsemor_model_set_structural_damping(h, ETA, &k4.view()) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let i = info(h);
    println!("eta = {ETA} and a damper on DoFs {a}, {b}: {i:?}");
    assert_ne!(i.kind, SPARSEMOR_DAMPING_NONE);
    let hmat = Mat::<f64>::from_fn(N, N, |i, j| ETA * k[i + j * N] + damper[i + j * N]);
    let rom = exact_linefit(h);
    let mut worst: f64 = 0.0;
    for f in FREQS {
        let e = rel(&rom_transfer(rom, f), &dense_h(&hmat, f));
        println!("{f} Hz: ROM (with K4r) vs dense solve: {e:.2e}");
        worst = worst.max(e);
    }
    assert!(worst <= 1e-8, "{worst:e}");
    // without the iK4r term the ROM misses: K4r matters
    let without = {
        let (_, _, mr) = rom_matrix(rom, SPARSEMOR_MATRIX_MR);
        let (_, _, dr) = rom_matrix(rom, SPARSEMOR_MATRIX_DR);
        let (_, _, kr) = rom_matrix(rom, SPARSEMOR_MATRIX_KR);
        let (_, _, br) = rom_matrix(rom, SPARSEMOR_MATRIX_BR);
        let (_, _, cr) = rom_matrix(rom, SPARSEMOR_MATRIX_CR);
        let n = 6;
        let w = 2.0 * std::f64::consts::PI * FREQS[1];
        let am = Mat::<c64>::from_fn(n, n, |i, j| {
            c64::new(kr[i + j * n] - w * w * mr[i + j * n], w * dr[i + j * n])
        });
        let bm = Mat::<c64>::from_fn(n, 1, |i, _| c64::new(br[i], 0.0));
        let x = am.partial_piv_lu().solve(&bm);
        let y: c64 = (0..n).map(|i| x[(i, 0)] * cr[i]).sum();
        rel(&Mat::from_fn(1, 1, |_, _| y), &dense_h(&hmat, FREQS[1]))
    };
    println!("{} Hz without iK4r: {without:.2e}", FREQS[1]);
    assert!(without > 1e-3);
    let (mut e1, mut e2) = ([0.0; 3], [0.0; 3]);
    let st = unsafe {
        sparsemor_rom_transfer_error(h, rom, FREQS.as_ptr(), 3, e1.as_mut_ptr(), e2.as_mut_ptr())
    };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    println!(
        "library eps at the reference frequencies: {:.2e} {:.2e} {:.2e}",
        e1[0], e1[1], e1[2]
    );
    assert!(e1.iter().all(|&e| e <= 1e-8), "{e1:?}");

    // removed again: Rayleigh βK only, no K4r
    let st = unsafe { sparsemor_model_set_structural_damping(h, 0.0, null()) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let i = info(h);
    assert_eq!(i.kind, SPARSEMOR_DAMPING_PROPORTIONAL);
    assert_eq!((i.beta, i.eta, i.remainder_rank), (BETA, 0.0, 0));
    let plain = exact_linefit(h);
    let mut has = -1;
    unsafe { sparsemor_rom_has_structural_damping(plain, &mut has) };
    assert_eq!(has, 0);
    let e = rel(
        &rom_transfer(plain, FREQS[1]),
        &dense_h(&Mat::zeros(N, N), FREQS[1]),
    );
    assert!(e <= 1e-8, "{e:e}");
    unsafe {
        sparsemor_rom_free(rom);
        sparsemor_rom_free(plain);
        sparsemor_model_free(h);
    }
}

/// An undamped model (Rayleigh 0, 0) reports `SPARSEMOR_DAMPING_NONE`; with a loss factor,
/// a proportional split with η.
#[test]
fn damping_info_of_an_undamped_model_and_a_loss_factor() {
    let (m, k) = chain(N);
    let h = model_from(
        &CscArrays::from_dense(N, &m),
        &CscArrays::from_dense(N, &k),
        0.0,
    );
    assert_eq!(
        info(h),
        SparsemorDampingInfo {
            kind: SPARSEMOR_DAMPING_NONE,
            ..Default::default()
        }
    );
    let st = unsafe { sparsemor_model_set_structural_damping(h, ETA, null()) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(
        info(h),
        SparsemorDampingInfo {
            kind: SPARSEMOR_DAMPING_PROPORTIONAL,
            eta: ETA,
            ..Default::default()
        }
    );
    unsafe { sparsemor_model_free(h) };
}
