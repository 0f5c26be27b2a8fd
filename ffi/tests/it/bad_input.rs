//! Bad input through the exported functions (called from Rust exactly as C would): one test
//! per case, each checking the status code and the message (docs/design.md §6, issue item 3).
//! Nothing here may crash; every failure must leave `*_out` handles NULL.

use crate::common::*;
use sparsemor_ffi::*;
use std::ptr::{null, null_mut};

/// Asserts status `want` and a message containing `needle`; returns the message.
#[track_caller]
fn expect(st: SparsemorStatus, want: SparsemorStatus, needle: &str) -> String {
    let msg = last_error();
    assert_eq!(st, want, "message: {msg}");
    assert!(
        msg.contains(needle),
        "message {msg:?} does not contain {needle:?}"
    );
    println!("{want:?}: {msg}");
    msg
}

/// A valid 4×4 SPD mass matrix (tridiagonal) and stiffness (constrained chain).
fn mk() -> (CscArrays, CscArrays) {
    let (m, k) = chain(4);
    (CscArrays::from_dense(4, &m), CscArrays::from_dense(4, &k))
}

/// `sparsemor_model_new` with M, K, Rayleigh β; returns status and checks `*out` stays NULL
/// on failure.
fn new_model(m: *const SparsemorCsc, k: *const SparsemorCsc) -> SparsemorStatus {
    let mut h: *mut SparsemorModel = std::ptr::dangling_mut(); // must be overwritten with NULL on failure
    let st = unsafe { sparsemor_model_new(m, k, null(), 0.0, 1e-4, null(), 0, 0, &mut h) };
    if st == SparsemorStatus::Ok {
        unsafe { sparsemor_model_free(h) };
    } else {
        assert!(h.is_null(), "model_out not set to NULL on failure");
    }
    st
}

// ---- pointers ------------------------------------------------------------------------------

#[test]
fn null_model_out_pointer() {
    let (m, k) = mk();
    let st = unsafe {
        sparsemor_model_new(
            &m.view(),
            &k.view(),
            null(),
            0.0,
            0.0,
            null(),
            0,
            0,
            null_mut(),
        )
    };
    expect(st, SparsemorStatus::NullPointer, "model_out");
}

#[test]
fn null_matrix_descriptor() {
    let (_, k) = mk();
    expect(
        new_model(null(), &k.view()),
        SparsemorStatus::NullPointer,
        "mass",
    );
}

#[test]
fn null_row_index_array() {
    let (m, k) = mk();
    let mut v = m.view();
    v.row_idx = null();
    expect(
        new_model(&v, &k.view()),
        SparsemorStatus::NullPointer,
        "mass matrix M: row_idx",
    );
}

#[test]
fn misaligned_array_pointer() {
    let (m, k) = mk();
    let mut v = m.view();
    v.values = (v.values as usize + 1) as *const f64; // never dereferenced: rejected first
    expect(
        new_model(&v, &k.view()),
        SparsemorStatus::NullPointer,
        "not aligned",
    );
}

// ---- CSC structure -------------------------------------------------------------------------

#[test]
fn zero_dimension() {
    let (m, k) = mk();
    let mut v = m.view();
    v.n = 0;
    expect(
        new_model(&v, &k.view()),
        SparsemorStatus::InvalidArgument,
        "n = 0",
    );
}

#[test]
fn col_ptr_not_starting_at_zero() {
    let (mut m, k) = mk();
    m.col_ptr[0] = 1;
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidArgument,
        "col_ptr[0] = 1",
    );
}

#[test]
fn col_ptr_not_monotone() {
    let (mut m, k) = mk();
    m.col_ptr[2] = m.col_ptr[3] + 1; // a column "ends" before it starts
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidArgument,
        "not non-decreasing",
    );
}

#[test]
fn nnz_disagrees_with_col_ptr() {
    let (m, k) = mk();
    let mut v = m.view();
    v.nnz -= 1; // wrong explicit length
    expect(
        new_model(&v, &k.view()),
        SparsemorStatus::InvalidArgument,
        "col_ptr[n] = 10 but nnz = 9",
    );
}

#[test]
fn row_index_out_of_range() {
    let (mut m, k) = mk();
    let last = m.row_idx.len() - 1;
    m.row_idx[last] = 4;
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidArgument,
        "row index 4 in column 3",
    );
}

#[test]
fn row_indices_unsorted() {
    let (mut m, k) = mk();
    m.row_idx.swap(2, 3); // column 1 holds rows 0, 1, 2 -> 1, 0, 2
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidArgument,
        "strictly increasing",
    );
}

#[test]
fn duplicate_row_index() {
    let (mut m, k) = mk();
    m.row_idx[3] = m.row_idx[2];
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidArgument,
        "no duplicates",
    );
}

#[test]
fn non_finite_value() {
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let (m, mut k) = mk();
        k.values[1] = bad;
        expect(
            new_model(&m.view(), &k.view()),
            SparsemorStatus::InvalidArgument,
            "is not finite",
        );
    }
}

#[test]
fn unknown_storage_flag() {
    let (mut m, k) = mk();
    m.storage = 7;
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidArgument,
        "storage = 7",
    );
}

#[test]
fn upper_entry_in_lower_storage() {
    let (mut m, k) = mk();
    m.storage = SPARSEMOR_STORAGE_LOWER;
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidArgument,
        "above the diagonal",
    );
}

#[test]
fn lower_storage_is_mirrored_to_the_same_model() {
    // positive counterpart: the lower triangle gives bit-identical ROMs to full storage
    let (m, k) = mk();
    let lower = |a: &CscArrays| {
        let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
        for j in 0..a.n {
            for p in a.col_ptr[j]..a.col_ptr[j + 1] {
                if a.row_idx[p] >= j {
                    ri.push(a.row_idx[p]);
                    v.push(a.values[p]);
                }
            }
            cp.push(ri.len());
        }
        CscArrays {
            n: a.n,
            col_ptr: cp,
            row_idx: ri,
            values: v,
            storage: SPARSEMOR_STORAGE_LOWER,
        }
    };
    let roms: Vec<Vec<f64>> = [(m.clone(), k.clone()), (lower(&m), lower(&k))]
        .iter()
        .map(|(m, k)| {
            let h = model_from(m, k, 1e-4);
            let io = [3usize];
            let o = options();
            let mut rom = null_mut();
            unsafe {
                assert_eq!(
                    sparsemor_model_set_scene(h, io.as_ptr(), 1, io.as_ptr(), 1, 0.0, 40.0),
                    SparsemorStatus::Ok
                );
                let f = [5.0, 20.0];
                sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 2);
                sparsemor_options_set_interface_outputs_plus(o, 1);
                sparsemor_options_set_threads(o, 1);
                let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
                assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
            }
            let (_, _, kr) = rom_matrix(rom, SPARSEMOR_MATRIX_KR);
            unsafe {
                sparsemor_rom_free(rom);
                sparsemor_options_free(o);
                sparsemor_model_free(h);
            }
            kr
        })
        .collect();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&roms[0]), bits(&roms[1]));
}

// ---- model-level checks --------------------------------------------------------------------

#[test]
fn unsymmetric_matrix() {
    let (m, mut k) = mk();
    k.values[1] *= 1.5; // K[1,0] != K[0,1]
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidModel,
        "not symmetric",
    );
}

#[test]
fn mass_diagonal_not_positive() {
    let (mut m, k) = mk();
    m.values[0] = -1.0;
    expect(
        new_model(&m.view(), &k.view()),
        SparsemorStatus::InvalidModel,
        "positive diagonal",
    );
}

#[test]
fn matrix_sizes_disagree() {
    let (m, _) = mk();
    let (_, k5) = chain(5);
    let k5 = CscArrays::from_dense(5, &k5);
    expect(
        new_model(&m.view(), &k5.view()),
        SparsemorStatus::InvalidArgument,
        "stiffness matrix K is 5×5 but the mass matrix M is 4×4",
    );
}

#[test]
fn rayleigh_coefficients_invalid() {
    let (m, k) = mk();
    for (a, b) in [(-1.0, 0.0), (0.0, f64::NAN), (f64::INFINITY, 0.0)] {
        let mut h = null_mut();
        let st = unsafe {
            sparsemor_model_new(&m.view(), &k.view(), null(), a, b, null(), 0, 0, &mut h)
        };
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "need finite values >= 0",
        );
        assert!(h.is_null());
    }
}

#[test]
fn damping_matrix_and_rayleigh_both_given() {
    let (m, k) = mk();
    let mut h = null_mut();
    let st = unsafe {
        sparsemor_model_new(
            &m.view(),
            &k.view(),
            &m.view(),
            0.0,
            1e-4,
            null(),
            0,
            0,
            &mut h,
        )
    };
    expect(
        st,
        SparsemorStatus::InvalidArgument,
        "both a damping matrix and Rayleigh",
    );
}

#[test]
fn nodes_inconsistent_with_n() {
    let (m, k) = mk();
    let xyz = [0.0; 6]; // 2 nodes × 3 DoFs = 6 != N = 4
    let mut h = null_mut();
    let st = unsafe {
        sparsemor_model_new(
            &m.view(),
            &k.view(),
            null(),
            0.0,
            0.0,
            xyz.as_ptr(),
            2,
            3,
            &mut h,
        )
    };
    expect(
        st,
        SparsemorStatus::InvalidModel,
        "2 nodes × 3 DoFs per node",
    );
    let st = unsafe {
        sparsemor_model_new(&m.view(), &k.view(), null(), 0.0, 0.0, null(), 2, 3, &mut h)
    };
    expect(st, SparsemorStatus::NullPointer, "nodes_xyz");
}

// ---- scene and options ---------------------------------------------------------------------

#[test]
fn scene_dof_out_of_range_or_duplicate() {
    let h = chain_model(4);
    let (ok, bad, dup) = ([0usize], [4usize], [1usize, 1]);
    unsafe {
        let st = sparsemor_model_set_scene(h, bad.as_ptr(), 1, ok.as_ptr(), 1, 0.0, 10.0);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "DoF 4 is out of range",
        );
        let st = sparsemor_model_set_scene(h, ok.as_ptr(), 1, dup.as_ptr(), 2, 0.0, 10.0);
        expect(st, SparsemorStatus::InvalidArgument, "DoF 1 appears twice");
        let st = sparsemor_model_set_scene(h, ok.as_ptr(), 0, ok.as_ptr(), 1, 0.0, 10.0);
        expect(st, SparsemorStatus::InvalidArgument, "n_inputs = 0");
        let st = sparsemor_model_set_scene(h, ok.as_ptr(), 1, ok.as_ptr(), 1, 10.0, 5.0);
        expect(st, SparsemorStatus::InvalidArgument, "band_hz = [10, 5]");
        sparsemor_model_free(h);
    }
}

#[test]
fn reduction_without_scene() {
    let (m, k) = mk();
    let h = model_from(&m, &k, 1e-4);
    let o = options();
    let mut rom = null_mut();
    unsafe {
        let st = sparsemor_reduce_serep(h, o, None, null_mut(), &mut rom);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "sparsemor_model_set_scene",
        );
        assert!(rom.is_null());
        sparsemor_options_free(o);
        sparsemor_model_free(h);
    }
}

#[test]
fn tolerance_is_validated_and_reserved() {
    let h = chain_model(6);
    let o = options();
    let mut rom = null_mut();
    unsafe {
        for bad in [f64::NAN, -1e-3, 1.5, f64::INFINITY] {
            let st = sparsemor_options_set_tolerance(o, bad);
            expect(st, SparsemorStatus::InvalidArgument, "tolerance");
        }
        assert_eq!(
            sparsemor_options_set_tolerance(o, 1e-4),
            SparsemorStatus::Ok
        );
        let f = [5.0];
        sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 1);
        // with a tolerance the sampling loop runs (f = 5 Hz is an extra seed)
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        let (mut sampled, mut steps) = (0, 0usize);
        sparsemor_rom_sampling_converged(rom, &mut sampled, null_mut());
        sparsemor_rom_step_count(rom, &mut steps);
        assert!(sampled == 1 && steps >= 1);
        let mut facts = 0usize;
        let st = sparsemor_rom_step(
            rom,
            steps,
            null_mut(),
            null_mut(),
            null_mut(),
            null_mut(),
            null_mut(),
            &mut facts,
            null_mut(),
        );
        expect(st, SparsemorStatus::InvalidArgument, "out of range");
        // the request and what was reached, as rom.toml records them
        let (mut tol, mut err, mut facts_total) = (0.0, f64::NAN, 0usize);
        let st = sparsemor_rom_sampling_result(rom, &mut tol, &mut err, &mut facts_total);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        assert_eq!(tol, 1e-4);
        assert!(
            err.is_finite() && err >= 0.0 && facts_total >= 1,
            "{err} {facts_total}"
        );
        // every factorization of the run: the loop's and the verification's, as rom.toml
        let mut in_all = 0usize;
        let st = sparsemor_rom_factorizations_in_all(rom, &mut in_all);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        assert!(in_all >= facts_total, "{in_all} < {facts_total}");
        let st = sparsemor_rom_factorizations_in_all(rom, null_mut());
        expect(st, SparsemorStatus::NullPointer, "count_out");
        sparsemor_rom_free(rom);
        // a ROM from explicit frequencies has no sampling result
        assert_eq!(sparsemor_options_set_tolerance(o, 0.0), SparsemorStatus::Ok);
        let f3 = [1.0, 3.0, 5.0];
        sparsemor_options_set_reference_frequencies(o, f3.as_ptr(), 3);
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        let st = sparsemor_rom_sampling_result(rom, &mut tol, null_mut(), null_mut());
        expect(st, SparsemorStatus::NotAvailable, "sampling loop");
        let st = sparsemor_rom_factorizations_in_all(rom, &mut facts_total);
        expect(st, SparsemorStatus::NotAvailable, "sampling loop");
        sparsemor_rom_free(rom);
        sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 1);
        // 0 and 0 ask for the library's defaults
        assert_eq!(
            sparsemor_options_set_sampling_limits(o, 0, 0),
            SparsemorStatus::Ok
        );
        assert_eq!(sparsemor_options_set_tolerance(o, 0.0), SparsemorStatus::Ok);
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        sparsemor_rom_free(rom);
        sparsemor_options_free(o);
        sparsemor_model_free(h);
    }
}

#[test]
fn reference_frequencies_invalid() {
    let o = options();
    unsafe {
        let f = [10.0, f64::NAN];
        let st = sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 2);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "reference frequency 1 is NaN",
        );
        let f = [-1.0];
        let st = sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 1);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "reference frequency 0 is -1",
        );
        let st = sparsemor_options_set_reference_frequencies(o, null(), 0);
        expect(st, SparsemorStatus::InvalidArgument, "empty list");
        let st = sparsemor_options_set_reference_frequencies(o, null(), 3);
        expect(st, SparsemorStatus::NullPointer, "freqs_hz");
        let st = sparsemor_options_set_reference_count(o, 0);
        expect(st, SparsemorStatus::InvalidArgument, "z = 0");
        sparsemor_options_free(o);
    }
}

#[test]
fn option_values_invalid() {
    let o = options();
    unsafe {
        let d = [1usize, 2, 1];
        let st = sparsemor_options_set_interface(o, d.as_ptr(), 3);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "interface: DoF 1 appears twice",
        );
        let st = sparsemor_options_set_serep_modes(o, 0);
        expect(st, SparsemorStatus::InvalidArgument, "c = 0");
        let z = [0usize, 7];
        let st = sparsemor_options_set_serep_mode_numbers(o, z.as_ptr(), 2);
        expect(st, SparsemorStatus::InvalidArgument, "1-based");
        let st = sparsemor_options_set_threads(o, 100_000);
        expect(st, SparsemorStatus::InvalidArgument, "threads = 100000");
        let st = sparsemor_options_set_threads(null_mut(), 1);
        expect(st, SparsemorStatus::NullPointer, "options");
        sparsemor_options_free(o);
    }
}

#[test]
fn reduction_settings_rejected_by_the_library() {
    let h = chain_model(8);
    let o = options();
    let mut rom = null_mut();
    unsafe {
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "needs reference frequencies",
        );
        // 2pz = 2 < n = 4
        let f = [5.0];
        sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 1);
        sparsemor_options_set_interface_outputs_plus(o, 3);
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        expect(st, SparsemorStatus::InvalidArgument, "underdetermined");
        // output 7 not in the interface
        let i = [0usize, 1];
        sparsemor_options_set_interface(o, i.as_ptr(), 2);
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "output DoF 7 is not in the interface",
        );
        // interface DoF out of range (checked against N at reduction time)
        let i = [7usize, 99];
        sparsemor_options_set_interface(o, i.as_ptr(), 2);
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "DoF 99 is out of range",
        );
        assert!(rom.is_null());
        sparsemor_options_free(o);
        sparsemor_model_free(h);
    }
}

#[test]
fn singular_pencil_at_an_eigenfrequency() {
    // undamped 1-DoF oscillator k = (2π·10)², m = 1: A(i·2π·10) = 0
    let w = 2.0 * std::f64::consts::PI * 10.0;
    let m = CscArrays::from_dense(1, &[1.0]);
    let k = CscArrays::from_dense(1, &[w * w]);
    let h = model_from(&m, &k, 0.0);
    let o = options();
    let mut rom = null_mut();
    unsafe {
        let io = [0usize];
        sparsemor_model_set_scene(h, io.as_ptr(), 1, io.as_ptr(), 1, 0.0, 20.0);
        let f = [10.0];
        sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 1);
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        let msg = last_error();
        assert_eq!(st, SparsemorStatus::Singular, "{msg}");
        assert!(msg.contains("at 10 Hz is numerically singular"), "{msg}");
        println!("{st:?}: {msg}");
        assert!(rom.is_null());
        sparsemor_options_free(o);
        sparsemor_model_free(h);
    }
}

// ---- progress and cancellation -------------------------------------------------------------

unsafe extern "C" fn cancel_after_two(
    done: usize,
    _total: usize,
    _f: f64,
    user: *mut std::ffi::c_void,
) -> i32 {
    let calls = unsafe { &mut *(user as *mut usize) };
    *calls += 1;
    i32::from(done >= 2)
}

#[test]
fn progress_callback_cancels() {
    let h = chain_model(10);
    let o = options();
    let mut rom = null_mut();
    let mut calls = 0usize;
    unsafe {
        let f = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        sparsemor_options_set_reference_frequencies(o, f.as_ptr(), f.len());
        sparsemor_options_set_threads(o, 1);
        let st = sparsemor_reduce_linefit(
            h,
            o,
            Some(cancel_after_two),
            (&mut calls as *mut usize).cast(),
            &mut rom,
        );
        expect(st, SparsemorStatus::Cancelled, "cancelled");
        assert_eq!(
            calls, 2,
            "one thread: the run stops right after the callback said so"
        );
        assert!(rom.is_null());
        sparsemor_options_free(o);
        sparsemor_model_free(h);
    }
}

// ---- ROM queries ---------------------------------------------------------------------------

/// A small line-fitting ROM of the chain (V not kept).
fn small_rom() -> (*mut SparsemorModel, *mut SparsemorRom) {
    let h = chain_model(10);
    let o = options();
    let mut rom = null_mut();
    unsafe {
        let f = [3.0, 12.0];
        sparsemor_options_set_reference_frequencies(o, f.as_ptr(), 2);
        sparsemor_options_set_interface_outputs_plus(o, 2);
        let st = sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        sparsemor_options_free(o);
    }
    (h, rom)
}

#[test]
fn buffer_too_small_reports_the_required_length() {
    let (h, rom) = small_rom();
    let mut buf = [7.0f64; 8];
    let mut need = 0usize;
    unsafe {
        let st =
            sparsemor_rom_copy_matrix(rom, SPARSEMOR_MATRIX_MR, buf.as_mut_ptr(), 8, &mut need);
        expect(st, SparsemorStatus::BufferTooSmall, "9 are needed");
        assert_eq!(need, 9);
        assert!(
            buf.iter().all(|&x| x == 7.0),
            "a short buffer is left untouched"
        );
        let st = sparsemor_rom_copy_matrix(rom, SPARSEMOR_MATRIX_MR, null_mut(), 9, &mut need);
        expect(st, SparsemorStatus::NullPointer, "buf");
        let mut dofs = [0usize; 1];
        let st = sparsemor_rom_dofs(rom, dofs.as_mut_ptr(), 1, &mut need);
        expect(st, SparsemorStatus::BufferTooSmall, "3 are needed");
        assert_eq!(need, 3);
        let mut name = [0 as std::ffi::c_char; 4];
        let st = sparsemor_rom_timing(rom, 0, name.as_mut_ptr(), 4, &mut need, null_mut());
        expect(st, SparsemorStatus::BufferTooSmall, "truncated");
        assert_eq!(name[3], 0, "truncated text is NUL-terminated");
        assert_eq!(need, "symbolic".len() + 1);
        sparsemor_rom_free(rom);
        sparsemor_model_free(h);
    }
}

#[test]
fn unknown_matrix_id_and_missing_basis() {
    let (h, rom) = small_rom();
    unsafe {
        let st = sparsemor_rom_copy_matrix(rom, 7, null_mut(), 0, null_mut());
        expect(st, SparsemorStatus::InvalidArgument, "matrix id 7");
        let st = sparsemor_rom_copy_matrix(rom, SPARSEMOR_MATRIX_V, null_mut(), 0, null_mut());
        expect(st, SparsemorStatus::NotAvailable, "V was not kept");
        let mut c = 0.0;
        let st = sparsemor_rom_serep_cond(rom, &mut c);
        expect(st, SparsemorStatus::NotAvailable, "only for SEREP");
        sparsemor_rom_free(rom);
        sparsemor_model_free(h);
    }
}

#[test]
fn index_out_of_range() {
    let (h, rom) = small_rom();
    unsafe {
        let (mut n_t, mut n_w) = (0, 0);
        sparsemor_rom_timing_count(rom, &mut n_t);
        sparsemor_rom_warning_count(rom, &mut n_w);
        let st = sparsemor_rom_timing(rom, n_t, null_mut(), 0, null_mut(), null_mut());
        expect(st, SparsemorStatus::InvalidArgument, "timing index");
        let st = sparsemor_rom_warning(rom, n_w, null_mut(), 0, null_mut());
        expect(st, SparsemorStatus::InvalidArgument, "warning index");
        sparsemor_rom_free(rom);
        sparsemor_model_free(h);
    }
}

#[test]
fn transfer_error_with_bad_arguments() {
    let (h, rom) = small_rom();
    let other = chain_model(12);
    let mut e1 = [0.0; 2];
    let mut e2 = [0.0; 2];
    unsafe {
        let f = [1.0, 2.0];
        let st = sparsemor_rom_transfer_error(
            other,
            rom,
            f.as_ptr(),
            2,
            e1.as_mut_ptr(),
            e2.as_mut_ptr(),
        );
        expect(
            st,
            SparsemorStatus::InvalidArgument,
            "N = 10 but this model has N = 12",
        );
        let f = [1.0, f64::INFINITY];
        let st =
            sparsemor_rom_transfer_error(h, rom, f.as_ptr(), 2, e1.as_mut_ptr(), e2.as_mut_ptr());
        expect(st, SparsemorStatus::InvalidArgument, "frequency 1 is inf");
        let f = [1.0, 2.0];
        let st = sparsemor_rom_transfer_error(h, rom, f.as_ptr(), 2, e1.as_mut_ptr(), null_mut());
        expect(st, SparsemorStatus::NullPointer, "eps_total_out");
        let st =
            sparsemor_rom_transfer_error(h, rom, f.as_ptr(), 2, e1.as_mut_ptr(), e2.as_mut_ptr());
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        assert!(e1.iter().chain(&e2).all(|e| e.is_finite() && *e >= 0.0));
        sparsemor_rom_free(rom);
        sparsemor_model_free(h);
        sparsemor_model_free(other);
    }
}

// ---- the last-error protocol ---------------------------------------------------------------

#[test]
fn last_error_getters() {
    let (_, k) = mk();
    assert_eq!(new_model(null(), &k.view()), SparsemorStatus::NullPointer);
    let len = sparsemor_last_error_length();
    let full = last_error();
    assert_eq!(len, full.len() + 1);
    let mut small = [1 as std::ffi::c_char; 5];
    let st = unsafe { sparsemor_last_error_message(small.as_mut_ptr(), 5) };
    assert_eq!(st, SparsemorStatus::BufferTooSmall);
    assert_eq!(small[4], 0);
    let st = unsafe { sparsemor_last_error_message(null_mut(), 5) };
    assert_eq!(st, SparsemorStatus::NullPointer);
    // reading does not clear; another thread has its own (empty) message
    assert_eq!(last_error(), full);
    std::thread::spawn(|| assert_eq!(sparsemor_last_error_length(), 0))
        .join()
        .unwrap();
    // any successful call clears it
    let mut abi = 0u32;
    let st = unsafe { sparsemor_version(null_mut(), null_mut(), null_mut(), &mut abi) };
    assert_eq!(st, SparsemorStatus::Ok);
    assert_eq!(abi, SPARSEMOR_ABI_VERSION);
    assert_eq!(sparsemor_last_error_length(), 0);
}

#[test]
fn free_null_is_a_no_op() {
    unsafe {
        assert_eq!(sparsemor_model_free(null_mut()), SparsemorStatus::Ok);
        assert_eq!(sparsemor_options_free(null_mut()), SparsemorStatus::Ok);
        assert_eq!(sparsemor_rom_free(null_mut()), SparsemorStatus::Ok);
    }
}
