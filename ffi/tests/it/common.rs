//! Shared helpers of the FFI integration tests: where the built library is, small models,
//! Rust-side wrappers around the exported functions.
#![allow(dead_code)]

use sparsemor::sparse::Csc;
use sparsemor_ffi::*;
use std::path::PathBuf;

/// The directory with the library artifacts of this test build (`target/<profile>/deps`,
/// where cargo puts `libsparsemor_ffi.{a,so}` next to the test executables).
pub fn lib_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    exe.parent().expect("deps directory").to_path_buf()
}

/// `libsparsemor_ffi.a` of this build.
pub fn static_lib() -> PathBuf {
    let p = lib_dir().join("libsparsemor_ffi.a");
    assert!(
        p.exists(),
        "{} not found: cargo builds it with the library",
        p.display()
    );
    p
}

/// A scratch directory for this test binary.
pub fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&d).expect("create scratch dir");
    d
}

/// Is `prog` on PATH (runs `prog --version`)?
pub fn have(prog: &str) -> bool {
    std::process::Command::new(prog)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The last error message of this thread, through the C getters.
pub fn last_error() -> String {
    let len = sparsemor_last_error_length();
    if len == 0 {
        return String::new();
    }
    let mut buf = vec![0u8; len];
    let st = unsafe { sparsemor_last_error_message(buf.as_mut_ptr().cast(), len) };
    assert_eq!(st, SparsemorStatus::Ok);
    assert_eq!(buf[len - 1], 0, "message is NUL-terminated");
    String::from_utf8(buf[..len - 1].to_vec()).expect("UTF-8 message")
}

/// Owned CSC arrays with a `SparsemorCsc` view.
#[derive(Clone, Debug)]
pub struct CscArrays {
    pub n: usize,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    pub values: Vec<f64>,
    pub storage: u32,
}

impl CscArrays {
    pub fn from_csc(a: &Csc) -> Self {
        CscArrays {
            n: a.nrows(),
            col_ptr: a.symbolic().col_ptr().to_vec(),
            row_idx: a.symbolic().row_idx().to_vec(),
            values: a.val().to_vec(),
            storage: SPARSEMOR_STORAGE_FULL,
        }
    }

    /// Dense column-major n×n → CSC (entries != 0), full storage.
    pub fn from_dense(n: usize, d: &[f64]) -> Self {
        let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
        for j in 0..n {
            for i in 0..n {
                if d[i + j * n] != 0.0 {
                    ri.push(i);
                    v.push(d[i + j * n]);
                }
            }
            cp.push(ri.len());
        }
        CscArrays {
            n,
            col_ptr: cp,
            row_idx: ri,
            values: v,
            storage: SPARSEMOR_STORAGE_FULL,
        }
    }

    /// The view passed to C; `nnz` = `values.len()`.
    pub fn view(&self) -> SparsemorCsc {
        SparsemorCsc {
            n: self.n,
            nnz: self.values.len(),
            col_ptr: self.col_ptr.as_ptr(),
            row_idx: self.row_idx.as_ptr(),
            values: self.values.as_ptr(),
            storage: self.storage,
        }
    }
}

/// A constrained spring–mass chain of `n` DoFs (first DoF grounded): tridiagonal K,
/// consistent-like tridiagonal M. Dense column-major.
pub fn chain(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut m = vec![0.0; n * n];
    let mut k = vec![0.0; n * n];
    for i in 0..n {
        m[i + i * n] = 4.0 + 0.1 * i as f64;
        k[i + i * n] = if i + 1 < n { 2.0e4 } else { 1.0e4 };
        if i + 1 < n {
            m[i + (i + 1) * n] = 1.0;
            m[(i + 1) + i * n] = 1.0;
            k[i + (i + 1) * n] = -1.0e4;
            k[(i + 1) + i * n] = -1.0e4;
        }
    }
    (m, k)
}

/// Creates a model handle from arrays; panics with the message on failure.
pub fn model_from(m: &CscArrays, k: &CscArrays, beta: f64) -> *mut SparsemorModel {
    let mut h = std::ptr::null_mut();
    let st = unsafe {
        sparsemor_model_new(
            &m.view(),
            &k.view(),
            std::ptr::null(),
            0.0,
            beta,
            std::ptr::null(),
            0,
            0,
            &mut h,
        )
    };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    h
}

/// The model handle of `model` with its node coordinates (3 DoFs per node) and Rayleigh
/// damping D = βK; panics with the message on failure.
pub fn model_with_nodes(model: &sparsemor::model::Model, beta: f64) -> *mut SparsemorModel {
    let (m, k) = (
        CscArrays::from_csc(&model.mass),
        CscArrays::from_csc(&model.stiffness),
    );
    let xyz: Vec<f64> = model
        .nodes
        .as_ref()
        .expect("a model with node coordinates")
        .iter()
        .flatten()
        .copied()
        .collect();
    let mut h = std::ptr::null_mut();
    let st = unsafe {
        sparsemor_model_new(
            &m.view(),
            &k.view(),
            std::ptr::null(),
            0.0,
            beta,
            xyz.as_ptr(),
            xyz.len() / 3,
            3,
            &mut h,
        )
    };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    h
}

/// The chain model of `n` DoFs with Rayleigh β = 1e-4 and the scene inputs = outputs =
/// {n−1}, band [0, 40] Hz.
pub fn chain_model(n: usize) -> *mut SparsemorModel {
    let (m, k) = chain(n);
    let h = model_from(
        &CscArrays::from_dense(n, &m),
        &CscArrays::from_dense(n, &k),
        1e-4,
    );
    let io = [n - 1];
    let st = unsafe { sparsemor_model_set_scene(h, io.as_ptr(), 1, io.as_ptr(), 1, 0.0, 40.0) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    h
}

/// New options handle.
pub fn options() -> *mut SparsemorOptions {
    let mut o = std::ptr::null_mut();
    assert_eq!(
        unsafe { sparsemor_options_new(&mut o) },
        SparsemorStatus::Ok
    );
    o
}

/// Copies a ROM matrix through the C API (size query, then copy).
pub fn rom_matrix(rom: *const SparsemorRom, which: u32) -> (usize, usize, Vec<f64>) {
    let (mut r, mut c, mut need) = (0, 0, 0);
    unsafe {
        assert_eq!(
            sparsemor_rom_matrix_shape(rom, which, &mut r, &mut c),
            SparsemorStatus::Ok,
            "{}",
            last_error()
        );
        assert_eq!(
            sparsemor_rom_copy_matrix(rom, which, std::ptr::null_mut(), 0, &mut need),
            SparsemorStatus::Ok
        );
        let mut v = vec![f64::NAN; need];
        assert_eq!(
            sparsemor_rom_copy_matrix(rom, which, v.as_mut_ptr(), need, std::ptr::null_mut()),
            SparsemorStatus::Ok
        );
        (r, c, v)
    }
}

/// A column-major `rows` × `cols` array as a matrix.
pub fn col_major(rows: usize, cols: usize, v: &[f64]) -> faer::Mat<f64> {
    faer::Mat::from_fn(rows, cols, |i, j| v[i + j * rows])
}

/// Hr(iω) = Cr (Kr + iK4r − ω²Mr + iωDr)⁻¹ Br at `f` Hz from the ROM's matrices as the ABI
/// hands them out (K4r when `sparsemor_rom_has_structural_damping` says so; docs/design.md
/// §3.12), by a dense LU.
pub fn rom_transfer(rom: *const SparsemorRom, f: f64) -> faer::Mat<faer::c64> {
    use faer::linalg::solvers::Solve;
    use faer::{c64, Mat};
    let w = 2.0 * std::f64::consts::PI * f;
    let get = |which| {
        let (r, c, v) = rom_matrix(rom, which);
        col_major(r, c, &v)
    };
    let (mr, dr, kr, br, cr) = (
        get(SPARSEMOR_MATRIX_MR),
        get(SPARSEMOR_MATRIX_DR),
        get(SPARSEMOR_MATRIX_KR),
        get(SPARSEMOR_MATRIX_BR),
        get(SPARSEMOR_MATRIX_CR),
    );
    let n = mr.nrows();
    let mut has = -1;
    let st = unsafe { sparsemor_rom_has_structural_damping(rom, &mut has) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let k4r = match has {
        0 => Mat::zeros(n, n),
        1 => get(SPARSEMOR_MATRIX_K4R),
        other => panic!("has_structural_damping wrote {other}"),
    };
    let a = Mat::<c64>::from_fn(n, n, |i, j| {
        c64::new(
            kr[(i, j)] - w * w * mr[(i, j)],
            w * dr[(i, j)] + k4r[(i, j)],
        )
    });
    let b = Mat::<c64>::from_fn(n, br.ncols(), |i, j| c64::new(br[(i, j)], 0.0));
    let x = a.partial_piv_lu().solve(&b);
    Mat::<c64>::from_fn(cr.nrows(), n, |i, j| c64::new(cr[(i, j)], 0.0)) * x
}

/// ‖a − b‖_F / ‖b‖_F.
pub fn rel(a: &faer::Mat<faer::c64>, b: &faer::Mat<faer::c64>) -> f64 {
    (a - b).norm_l2() / b.norm_l2()
}
