//! A thin, safe wrapper over UMFPACK (SuiteSparse) sparse LU, behind the `umfpack` feature.
//!
//! Bindings are hand-written (no bindgen, no `-sys` crate) for the `umfpack_dl_*` (real,
//! 64-bit `SuiteSparse_long` indices) and `umfpack_zl_*` (complex, *split* real/imaginary
//! arrays — never the "packed" layout) routines. The prototypes and constants were checked
//! against `/usr/include/suitesparse/umfpack.h` of **UMFPACK 5.7.9 (Oct 20, 2019)**, as
//! shipped by Debian 12 `libsuitesparse-dev` 1:5.12.0. In that version the routines return
//! `SuiteSparse_long` (= `long` = `i64` on 64-bit Unix) and `solve` takes `SuiteSparse_long
//! sys`; UMFPACK 6 (SuiteSparse 7) returns `int` and takes `int sys`. `build.rs` reads the
//! installed header and sets the cfg `umfpack_v6` for version >= 6, which switches the two
//! type aliases in [`ffi`]. Only the 5.7.9 path has been built and tested.
//!
//! Usage: analyse the pattern once with [`UmfpackSymbolic::new`], then factor any number of
//! value sets on that pattern with [`UmfpackNumeric::real`] / [`UmfpackNumeric::complex`]
//! (possibly from several threads sharing the symbolic object), and solve `A x = b` with
//! [`UmfpackNumeric::solve_real`] / [`UmfpackNumeric::solve_complex`].
//!
//! Control parameters are UMFPACK's defaults (`umfpack_?l_defaults`): automatic strategy
//! (symmetric strategy with AMD on `A+A'`, or unsymmetric with COLAMD, as UMFPACK decides),
//! row scaling by row sums, threshold partial pivoting 0.1, and up to 2 steps of iterative
//! refinement in `solve`. Iterative refinement needs `A` itself, so every numeric object keeps
//! a copy of its values (`nnz` doubles, `2 nnz` for complex) and shares the pattern with the
//! symbolic object through an `Arc`; a numeric object does not borrow the symbolic object
//! and may outlive it (UMFPACK's Numeric object does not reference Symbolic).
//!
//! Singularity is *reported*, not turned into an error: [`UmfpackNumeric::status_singular`]
//! is true when `umfpack_?l_numeric` returned `UMFPACK_WARNING_singular_matrix`, together
//! with [`UmfpackNumeric::rcond`], so the caller can map it to
//! [`Error::Singular`](crate::Error::Singular) with its frequency. All library failures
//! (negative UMFPACK status codes) and invalid inputs become [`Error::Factor`].
//!
//! # Thread safety
//!
//! * [`UmfpackSymbolic`] is `Send + Sync`. It owns a heap object created by
//!   `umfpack_?l_symbolic` that nothing else references. UMFPACK documents the Symbolic
//!   argument of `umfpack_?l_numeric` as "Input argument, not modified. [...] The Symbolic
//!   object is not modified by umfpack_*_numeric" (umfpack_numeric.h, 5.7.9), and the
//!   source (`umfpack_numeric.c`) only reads `Symbolic->...` fields; all work space is
//!   allocated per call. So concurrent numeric factorizations sharing one symbolic object
//!   only read it. The only mutation (`free_symbolic`) happens in `Drop`, which requires
//!   exclusive ownership.
//! * [`UmfpackNumeric`] is `Send + Sync`. It owns an independent heap object (UMFPACK
//!   allocates it with `malloc` and keeps no thread-local or global state tied to it).
//!   `umfpack_?l_solve` documents Numeric as "Input argument, not modified", allocates its
//!   own work space (`Pattern`, `W`) with `malloc` on every call, and writes only to `X` and
//!   the caller's `Info`; here every call uses its own stack `Info` array and the caller's
//!   exclusive `x` slices, so solves from several threads on one factorization do not race.
//!   The values copy used for iterative refinement is immutable after construction.
//!
//! UMFPACK calls the BLAS (on Debian 12 the reference `libblas3` by default). With a
//! multithreaded BLAS (OpenBLAS/MKL), running factorizations from several Rust threads can
//! oversubscribe the cores; set e.g. `OPENBLAS_NUM_THREADS=1` in that case.

use std::ffi::c_void;
use std::ptr::{self, NonNull};
use std::sync::Arc;

use crate::error::{Error, Result};

/// Raw declarations from `umfpack.h`; everything here is `unsafe` and private to the module.
#[allow(non_snake_case, non_upper_case_globals, dead_code)]
mod ffi {
    use std::ffi::c_void;

    /// `SuiteSparse_long` (5.x) / `int64_t` (6.x): `long` on 64-bit Unix, `__int64` on Win64.
    pub type SsLong = i64;
    /// Return type of `umfpack_?l_symbolic/numeric/solve`.
    #[cfg(not(umfpack_v6))]
    pub type Status = SsLong;
    /// Return type of `umfpack_?l_symbolic/numeric/solve`.
    #[cfg(umfpack_v6)]
    pub type Status = std::ffi::c_int;
    /// Type of the `sys` argument of `umfpack_?l_solve`.
    #[cfg(not(umfpack_v6))]
    pub type Sys = SsLong;
    /// Type of the `sys` argument of `umfpack_?l_solve`.
    #[cfg(umfpack_v6)]
    pub type Sys = std::ffi::c_int;

    // `SuiteSparse_long` is `long` on every 64-bit Unix; make an LP64 mismatch a build error.
    #[cfg(unix)]
    const _: () = assert!(std::mem::size_of::<std::ffi::c_long>() == std::mem::size_of::<SsLong>());

    pub const UMFPACK_INFO: usize = 90;
    pub const UMFPACK_CONTROL: usize = 20;

    // Info indices.
    pub const UMFPACK_STATUS: usize = 0;
    pub const UMFPACK_SIZE_OF_UNIT: usize = 3;
    pub const UMFPACK_PEAK_MEMORY: usize = 41;
    pub const UMFPACK_FLOPS: usize = 42;
    pub const UMFPACK_LNZ: usize = 43;
    pub const UMFPACK_UNZ: usize = 44;
    pub const UMFPACK_RCOND: usize = 67;
    pub const UMFPACK_NUMERIC_WALLTIME: usize = 75;
    pub const UMFPACK_IR_TAKEN: usize = 80;
    pub const UMFPACK_OMEGA1: usize = 82;
    pub const UMFPACK_OMEGA2: usize = 83;

    // Status codes.
    pub const UMFPACK_OK: i64 = 0;
    pub const UMFPACK_WARNING_singular_matrix: i64 = 1;
    pub const UMFPACK_WARNING_determinant_underflow: i64 = 2;
    pub const UMFPACK_WARNING_determinant_overflow: i64 = 3;
    pub const UMFPACK_ERROR_out_of_memory: i64 = -1;
    pub const UMFPACK_ERROR_invalid_Numeric_object: i64 = -3;
    pub const UMFPACK_ERROR_invalid_Symbolic_object: i64 = -4;
    pub const UMFPACK_ERROR_argument_missing: i64 = -5;
    pub const UMFPACK_ERROR_n_nonpositive: i64 = -6;
    pub const UMFPACK_ERROR_invalid_matrix: i64 = -8;
    pub const UMFPACK_ERROR_different_pattern: i64 = -11;
    pub const UMFPACK_ERROR_invalid_system: i64 = -13;
    pub const UMFPACK_ERROR_invalid_permutation: i64 = -15;
    pub const UMFPACK_ERROR_internal_error: i64 = -911;
    pub const UMFPACK_ERROR_file_IO: i64 = -17;
    pub const UMFPACK_ERROR_ordering_failed: i64 = -18;

    /// Solve `A x = b`.
    pub const UMFPACK_A: Sys = 0;

    extern "C" {
        pub fn umfpack_dl_defaults(control: *mut f64);
        pub fn umfpack_zl_defaults(control: *mut f64);

        pub fn umfpack_dl_symbolic(
            n_row: SsLong,
            n_col: SsLong,
            Ap: *const SsLong,
            Ai: *const SsLong,
            Ax: *const f64,
            symbolic: *mut *mut c_void,
            control: *const f64,
            info: *mut f64,
        ) -> Status;
        pub fn umfpack_zl_symbolic(
            n_row: SsLong,
            n_col: SsLong,
            Ap: *const SsLong,
            Ai: *const SsLong,
            Ax: *const f64,
            Az: *const f64,
            symbolic: *mut *mut c_void,
            control: *const f64,
            info: *mut f64,
        ) -> Status;

        pub fn umfpack_dl_numeric(
            Ap: *const SsLong,
            Ai: *const SsLong,
            Ax: *const f64,
            symbolic: *mut c_void,
            numeric: *mut *mut c_void,
            control: *const f64,
            info: *mut f64,
        ) -> Status;
        pub fn umfpack_zl_numeric(
            Ap: *const SsLong,
            Ai: *const SsLong,
            Ax: *const f64,
            Az: *const f64,
            symbolic: *mut c_void,
            numeric: *mut *mut c_void,
            control: *const f64,
            info: *mut f64,
        ) -> Status;

        pub fn umfpack_dl_solve(
            sys: Sys,
            Ap: *const SsLong,
            Ai: *const SsLong,
            Ax: *const f64,
            X: *mut f64,
            B: *const f64,
            numeric: *mut c_void,
            control: *const f64,
            info: *mut f64,
        ) -> Status;
        #[allow(clippy::too_many_arguments)]
        pub fn umfpack_zl_solve(
            sys: Sys,
            Ap: *const SsLong,
            Ai: *const SsLong,
            Ax: *const f64,
            Az: *const f64,
            Xx: *mut f64,
            Xz: *mut f64,
            Bx: *const f64,
            Bz: *const f64,
            numeric: *mut c_void,
            control: *const f64,
            info: *mut f64,
        ) -> Status;

        pub fn umfpack_dl_free_symbolic(symbolic: *mut *mut c_void);
        pub fn umfpack_zl_free_symbolic(symbolic: *mut *mut c_void);
        pub fn umfpack_dl_free_numeric(numeric: *mut *mut c_void);
        pub fn umfpack_zl_free_numeric(numeric: *mut *mut c_void);
    }
}

use ffi::{UMFPACK_CONTROL, UMFPACK_INFO};

/// The status code `UMFPACK_WARNING_singular_matrix` (the factorization exists but `U` has a
/// zero on its diagonal).
pub const UMFPACK_WARNING_SINGULAR_MATRIX: i64 = ffi::UMFPACK_WARNING_singular_matrix;

/// A readable description of an UMFPACK status code (`Info[UMFPACK_STATUS]`).
#[allow(non_upper_case_globals)]
pub fn status_message(status: i64) -> &'static str {
    use ffi::*;
    match status {
        UMFPACK_OK => "ok",
        UMFPACK_WARNING_singular_matrix => "matrix is singular (a zero pivot in U)",
        UMFPACK_WARNING_determinant_underflow => "determinant underflow",
        UMFPACK_WARNING_determinant_overflow => "determinant overflow",
        UMFPACK_ERROR_out_of_memory => "out of memory",
        UMFPACK_ERROR_invalid_Numeric_object => "invalid Numeric object",
        UMFPACK_ERROR_invalid_Symbolic_object => "invalid Symbolic object",
        UMFPACK_ERROR_argument_missing => "a required argument is missing",
        UMFPACK_ERROR_n_nonpositive => "matrix dimension is not positive",
        UMFPACK_ERROR_invalid_matrix => {
            "invalid matrix (bad column pointers, row index out of range, \
             or unsorted/duplicate row indices)"
        }
        UMFPACK_ERROR_different_pattern => "the pattern changed since the symbolic analysis",
        UMFPACK_ERROR_invalid_system => "invalid system (matrix not square or bad sys code)",
        UMFPACK_ERROR_invalid_permutation => "invalid permutation",
        UMFPACK_ERROR_internal_error => "UMFPACK internal error",
        UMFPACK_ERROR_file_IO => "file I/O error",
        UMFPACK_ERROR_ordering_failed => "the fill-reducing ordering failed",
        _ => "unknown UMFPACK status",
    }
}

fn umf_error(routine: &str, status: i64) -> Error {
    Error::Factor(format!(
        "UMFPACK {routine} failed: {} (status {status})",
        status_message(status)
    ))
}

fn bad_input(msg: impl std::fmt::Display) -> Error {
    Error::Factor(format!("UMFPACK: {msg}"))
}

/// Checks a square CSC pattern and converts it to `i64`.
fn validate_pattern(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
) -> Result<(Vec<i64>, Vec<i64>)> {
    if n == 0 {
        return Err(bad_input("matrix dimension n must be at least 1"));
    }
    if i64::try_from(n).is_err() || i64::try_from(row_idx.len()).is_err() {
        return Err(bad_input(format!(
            "matrix too large for 64-bit indices (n = {n}, nnz = {})",
            row_idx.len()
        )));
    }
    if col_ptr.len() != n + 1 {
        return Err(bad_input(format!(
            "col_ptr has length {} but must have n + 1 = {} entries",
            col_ptr.len(),
            n + 1
        )));
    }
    if col_ptr[0] != 0 {
        return Err(bad_input(format!(
            "col_ptr[0] = {} but must be 0",
            col_ptr[0]
        )));
    }
    if col_ptr[n] != row_idx.len() {
        return Err(bad_input(format!(
            "col_ptr[n] = {} but row_idx has {} entries",
            col_ptr[n],
            row_idx.len()
        )));
    }
    let mut ap = Vec::with_capacity(n + 1);
    let mut ai = Vec::with_capacity(row_idx.len());
    ap.push(0i64);
    for j in 0..n {
        let (start, end) = (col_ptr[j], col_ptr[j + 1]);
        if end < start {
            return Err(bad_input(format!(
                "col_ptr is not monotone: col_ptr[{}] = {end} < col_ptr[{j}] = {start}",
                j + 1
            )));
        }
        // `end <= col_ptr[n] == row_idx.len()` holds once monotonicity is checked for all
        // columns, but a later column may still decrease, so guard the slice explicitly.
        let Some(rows) = row_idx.get(start..end) else {
            return Err(bad_input(format!(
                "col_ptr[{}] = {end} exceeds nnz = {}",
                j + 1,
                row_idx.len()
            )));
        };
        let mut prev: Option<usize> = None;
        for &r in rows {
            if r >= n {
                return Err(bad_input(format!(
                    "row index {r} in column {j} is out of range (n = {n})"
                )));
            }
            if let Some(p) = prev {
                if r <= p {
                    return Err(bad_input(format!(
                        "row indices of column {j} are not strictly increasing \
                         ({p} then {r}: unsorted or duplicate entry)"
                    )));
                }
            }
            prev = Some(r);
            ai.push(r as i64);
        }
        ap.push(end as i64);
    }
    Ok((ap, ai))
}

fn check_values(what: &str, values: &[f64], nnz: usize) -> Result<()> {
    if values.len() != nnz {
        return Err(bad_input(format!(
            "{what} has {} entries but the pattern has nnz = {nnz}",
            values.len()
        )));
    }
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        return Err(bad_input(format!(
            "{what}[{k}] = {} is not finite",
            values[k]
        )));
    }
    Ok(())
}

fn check_len(what: &str, len: usize, n: usize) -> Result<()> {
    if len != n {
        return Err(bad_input(format!("{what} has length {len} but n = {n}")));
    }
    Ok(())
}

/// Symbolic analysis (fill-reducing ordering, frontal matrix tree) of a square sparse pattern.
///
/// Owns UMFPACK's `void *Symbolic`, freed on drop, and a copy of the pattern as `i64`
/// (shared with every [`UmfpackNumeric`] built from it). See the module docs for why it is
/// `Send + Sync`.
pub struct UmfpackSymbolic {
    ptr: NonNull<c_void>,
    n: usize,
    complex: bool,
    col_ptr: Arc<[i64]>,
    row_idx: Arc<[i64]>,
    control: [f64; UMFPACK_CONTROL],
    info: [f64; UMFPACK_INFO],
}

// SAFETY: see the module-level "Thread safety" section: the Symbolic object is an independent
// heap object, only read by `umfpack_?l_numeric`, and freed only in `Drop` (`&mut self`).
unsafe impl Send for UmfpackSymbolic {}
// SAFETY: as above; all `&self` uses (numeric factorization) only read the Symbolic object.
unsafe impl Sync for UmfpackSymbolic {}

impl std::fmt::Debug for UmfpackSymbolic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UmfpackSymbolic")
            .field("n", &self.n)
            .field("nnz", &self.nnz())
            .field("complex", &self.complex)
            .finish_non_exhaustive()
    }
}

impl UmfpackSymbolic {
    /// Pattern analysis of the `n x n` matrix with CSC pattern `col_ptr` (length `n + 1`,
    /// starting at 0, non-decreasing) and `row_idx` (length `col_ptr[n]`, row indices `< n`,
    /// strictly increasing within each column).
    ///
    /// The ordering is UMFPACK's own (AMD on `A+A'` or COLAMD on `A`, chosen by the automatic
    /// strategy). `complex` selects the `zl` (complex) or `dl` (real) routines; numeric
    /// factorizations must use the matching kind.
    pub fn new(n: usize, col_ptr: &[usize], row_idx: &[usize], complex: bool) -> Result<Self> {
        let (ap, ai) = validate_pattern(n, col_ptr, row_idx)?;
        let mut control = [0.0f64; UMFPACK_CONTROL];
        let mut info = [0.0f64; UMFPACK_INFO];
        let mut sym: *mut c_void = ptr::null_mut();
        let n_l = n as i64; // checked in validate_pattern
                            // SAFETY: `control` has UMFPACK_CONTROL entries; `ap` has n + 1 and `ai` has
                            // ap[n] entries forming a valid CSC pattern (validated above); Ax/Az may be NULL
                            // (statistics only); `info` has UMFPACK_INFO entries; `sym` is a valid out pointer.
        let status = i64::from(unsafe {
            if complex {
                ffi::umfpack_zl_defaults(control.as_mut_ptr());
                ffi::umfpack_zl_symbolic(
                    n_l,
                    n_l,
                    ap.as_ptr(),
                    ai.as_ptr(),
                    ptr::null(),
                    ptr::null(),
                    &mut sym,
                    control.as_ptr(),
                    info.as_mut_ptr(),
                )
            } else {
                ffi::umfpack_dl_defaults(control.as_mut_ptr());
                ffi::umfpack_dl_symbolic(
                    n_l,
                    n_l,
                    ap.as_ptr(),
                    ai.as_ptr(),
                    ptr::null(),
                    &mut sym,
                    control.as_ptr(),
                    info.as_mut_ptr(),
                )
            }
        });
        let ptr = NonNull::new(sym);
        match ptr {
            Some(ptr) if status >= 0 => Ok(Self {
                ptr,
                n,
                complex,
                col_ptr: ap.into(),
                row_idx: ai.into(),
                control,
                info,
            }),
            Some(p) => {
                // Not expected (UMFPACK returns NULL on error), but never leak.
                let mut raw = p.as_ptr();
                // SAFETY: `raw` was produced by the matching symbolic routine.
                unsafe {
                    if complex {
                        ffi::umfpack_zl_free_symbolic(&mut raw)
                    } else {
                        ffi::umfpack_dl_free_symbolic(&mut raw)
                    }
                }
                Err(umf_error("symbolic analysis", status))
            }
            None => Err(umf_error(
                "symbolic analysis",
                if status < 0 {
                    status
                } else {
                    ffi::UMFPACK_ERROR_internal_error
                },
            )),
        }
    }

    /// Matrix dimension.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries of the pattern.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Whether this analysis is for complex (`zl`) factorizations.
    pub fn is_complex(&self) -> bool {
        self.complex
    }

    /// UMFPACK's `Info` array from the symbolic analysis (indices as in `umfpack.h`).
    pub fn info(&self) -> &[f64; UMFPACK_INFO] {
        &self.info
    }
}

impl Drop for UmfpackSymbolic {
    fn drop(&mut self) {
        let mut raw = self.ptr.as_ptr();
        // SAFETY: `raw` came from the matching `umfpack_?l_symbolic` and is freed only here.
        unsafe {
            if self.complex {
                ffi::umfpack_zl_free_symbolic(&mut raw)
            } else {
                ffi::umfpack_dl_free_symbolic(&mut raw)
            }
        }
    }
}

/// Backward-error information from one solve with iterative refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UmfpackSolveInfo {
    /// Iterative refinement steps taken (`Info[UMFPACK_IR_TAKEN]`).
    pub ir_steps: usize,
    /// Sparse componentwise backward error `omega1` (`Info[UMFPACK_OMEGA1]`); `-1` when not
    /// computed (no refinement requested).
    pub omega1: f64,
    /// Sparse backward error `omega2` (`Info[UMFPACK_OMEGA2]`); `-1` when not computed.
    pub omega2: f64,
}

impl UmfpackSolveInfo {
    fn from_info(info: &[f64; UMFPACK_INFO]) -> Self {
        Self {
            ir_steps: info[ffi::UMFPACK_IR_TAKEN].max(0.0) as usize,
            omega1: info[ffi::UMFPACK_OMEGA1],
            omega2: info[ffi::UMFPACK_OMEGA2],
        }
    }

    fn merge(self, other: Self) -> Self {
        Self {
            ir_steps: self.ir_steps.max(other.ir_steps),
            omega1: self.omega1.max(other.omega1),
            omega2: self.omega2.max(other.omega2),
        }
    }
}

/// A numeric LU factorization `P R A Q = L U` on the pattern of a [`UmfpackSymbolic`].
///
/// Owns UMFPACK's `void *Numeric`, freed on drop, plus a copy of the matrix values (needed by
/// iterative refinement in `solve`). Independent of the symbolic object once built. See the
/// module docs for why it is `Send + Sync`.
pub struct UmfpackNumeric {
    ptr: NonNull<c_void>,
    n: usize,
    complex: bool,
    col_ptr: Arc<[i64]>,
    row_idx: Arc<[i64]>,
    re: Box<[f64]>,
    /// Imaginary parts; empty for a real factorization.
    im: Box<[f64]>,
    control: [f64; UMFPACK_CONTROL],
    info: [f64; UMFPACK_INFO],
    status: i64,
}

// SAFETY: see the module-level "Thread safety" section: the Numeric object is an independent
// heap object; `solve` only reads it and uses per-call work space; `Drop` needs `&mut self`.
unsafe impl Send for UmfpackNumeric {}
// SAFETY: as above; `&self` methods only read the Numeric object and the immutable copies.
unsafe impl Sync for UmfpackNumeric {}

impl std::fmt::Debug for UmfpackNumeric {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UmfpackNumeric")
            .field("n", &self.n)
            .field("complex", &self.complex)
            .field("status", &self.status)
            .field("rcond", &self.rcond())
            .field("lu_nnz", &self.lu_nnz())
            .finish_non_exhaustive()
    }
}

impl UmfpackNumeric {
    /// Real numeric factorization; `values` are the entries in the order of the symbolic
    /// object's pattern. `sym` must have been created with `complex = false`.
    pub fn real(sym: &UmfpackSymbolic, values: &[f64]) -> Result<Self> {
        if sym.complex {
            return Err(bad_input(
                "real factorization requested on a complex symbolic analysis",
            ));
        }
        check_values("values", values, sym.nnz())?;
        Self::factor(sym, values.into(), Box::default())
    }

    /// Complex numeric factorization with real parts `re` and imaginary parts `im` (split
    /// storage), in the order of the symbolic object's pattern. `sym` must have been created
    /// with `complex = true`.
    pub fn complex(sym: &UmfpackSymbolic, re: &[f64], im: &[f64]) -> Result<Self> {
        if !sym.complex {
            return Err(bad_input(
                "complex factorization requested on a real symbolic analysis",
            ));
        }
        check_values("re", re, sym.nnz())?;
        check_values("im", im, sym.nnz())?;
        Self::factor(sym, re.into(), im.into())
    }

    fn factor(sym: &UmfpackSymbolic, re: Box<[f64]>, im: Box<[f64]>) -> Result<Self> {
        let control = sym.control;
        let mut info = [0.0f64; UMFPACK_INFO];
        let mut num: *mut c_void = ptr::null_mut();
        // SAFETY: the pattern arrays are the ones given to the symbolic analysis, the value
        // arrays have nnz entries (checked by the callers), `sym.ptr` is a live Symbolic
        // object of the matching kind which UMFPACK only reads (shared access is fine),
        // `control`/`info` have the documented sizes and `num` is a valid out pointer.
        let status = i64::from(unsafe {
            if sym.complex {
                ffi::umfpack_zl_numeric(
                    sym.col_ptr.as_ptr(),
                    sym.row_idx.as_ptr(),
                    re.as_ptr(),
                    im.as_ptr(),
                    sym.ptr.as_ptr(),
                    &mut num,
                    control.as_ptr(),
                    info.as_mut_ptr(),
                )
            } else {
                ffi::umfpack_dl_numeric(
                    sym.col_ptr.as_ptr(),
                    sym.row_idx.as_ptr(),
                    re.as_ptr(),
                    sym.ptr.as_ptr(),
                    &mut num,
                    control.as_ptr(),
                    info.as_mut_ptr(),
                )
            }
        });
        let fresh = |ptr| Self {
            ptr,
            n: sym.n,
            complex: sym.complex,
            col_ptr: Arc::clone(&sym.col_ptr),
            row_idx: Arc::clone(&sym.row_idx),
            re,
            im,
            control,
            info,
            status,
        };
        match NonNull::new(num) {
            // On any failure UMFPACK frees everything and returns NULL; if a pointer did come
            // back with an error, wrapping it first makes `Drop` free it.
            Some(ptr) if status >= 0 => Ok(fresh(ptr)),
            Some(ptr) => {
                drop(fresh(ptr));
                Err(umf_error("numeric factorization", status))
            }
            None => Err(umf_error(
                "numeric factorization",
                if status < 0 {
                    status
                } else {
                    ffi::UMFPACK_ERROR_internal_error
                },
            )),
        }
    }

    /// Matrix dimension.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Whether this is a complex factorization.
    pub fn is_complex(&self) -> bool {
        self.complex
    }

    /// Solves `A x = b` (real factorization).
    pub fn solve_real(&self, b: &[f64], x: &mut [f64]) -> Result<()> {
        self.solve_real_info(b, x).map(|_| ())
    }

    /// Solves `A x = b` (real factorization) and returns the backward-error information.
    ///
    /// Fails with [`Error::Factor`] if the factorization is singular (the result would hold
    /// Inf/NaN); check [`status_singular`](Self::status_singular) first to report singularity.
    pub fn solve_real_info(&self, b: &[f64], x: &mut [f64]) -> Result<UmfpackSolveInfo> {
        if self.complex {
            return Err(bad_input(
                "solve_real called on a complex factorization (use solve_complex)",
            ));
        }
        check_len("b", b.len(), self.n)?;
        check_len("x", x.len(), self.n)?;
        let mut info = [0.0f64; UMFPACK_INFO];
        // SAFETY: pattern and values are the ones factored; `b` and `x` have n entries and
        // do not alias (`&` vs `&mut`); Numeric is live and only read; `info` is per call.
        let status = i64::from(unsafe {
            ffi::umfpack_dl_solve(
                ffi::UMFPACK_A,
                self.col_ptr.as_ptr(),
                self.row_idx.as_ptr(),
                self.re.as_ptr(),
                x.as_mut_ptr(),
                b.as_ptr(),
                self.ptr.as_ptr(),
                self.control.as_ptr(),
                info.as_mut_ptr(),
            )
        });
        self.solve_status(status)?;
        Ok(UmfpackSolveInfo::from_info(&info))
    }

    /// Solves `A x = b` with complex `b = b_re + i b_im`, `x = x_re + i x_im`.
    ///
    /// On a complex factorization this is one `umfpack_zl_solve`; on a real factorization the
    /// real and imaginary parts are solved separately (two `umfpack_dl_solve`).
    pub fn solve_complex(
        &self,
        b_re: &[f64],
        b_im: &[f64],
        x_re: &mut [f64],
        x_im: &mut [f64],
    ) -> Result<()> {
        self.solve_complex_info(b_re, b_im, x_re, x_im).map(|_| ())
    }

    /// As [`solve_complex`](Self::solve_complex), returning the backward-error information
    /// (the worse of the two solves for a real factorization).
    pub fn solve_complex_info(
        &self,
        b_re: &[f64],
        b_im: &[f64],
        x_re: &mut [f64],
        x_im: &mut [f64],
    ) -> Result<UmfpackSolveInfo> {
        check_len("b_re", b_re.len(), self.n)?;
        check_len("b_im", b_im.len(), self.n)?;
        check_len("x_re", x_re.len(), self.n)?;
        check_len("x_im", x_im.len(), self.n)?;
        if !self.complex {
            let a = self.solve_real_info(b_re, x_re)?;
            let b = self.solve_real_info(b_im, x_im)?;
            return Ok(a.merge(b));
        }
        let mut info = [0.0f64; UMFPACK_INFO];
        // SAFETY: as in `solve_real_info`; all four vectors have n entries, split storage
        // (non-NULL imaginary arrays), outputs are exclusive borrows distinct from inputs.
        let status = i64::from(unsafe {
            ffi::umfpack_zl_solve(
                ffi::UMFPACK_A,
                self.col_ptr.as_ptr(),
                self.row_idx.as_ptr(),
                self.re.as_ptr(),
                self.im.as_ptr(),
                x_re.as_mut_ptr(),
                x_im.as_mut_ptr(),
                b_re.as_ptr(),
                b_im.as_ptr(),
                self.ptr.as_ptr(),
                self.control.as_ptr(),
                info.as_mut_ptr(),
            )
        });
        self.solve_status(status)?;
        Ok(UmfpackSolveInfo::from_info(&info))
    }

    fn solve_status(&self, status: i64) -> Result<()> {
        match status {
            ffi::UMFPACK_OK => Ok(()),
            ffi::UMFPACK_WARNING_singular_matrix => Err(Error::Factor(format!(
                "UMFPACK solve: the factorization is singular (rcond = {:e}); \
                 the solution would contain Inf/NaN",
                self.rcond()
            ))),
            s if s > 0 => Ok(()),
            s => Err(umf_error("solve", s)),
        }
    }

    /// UMFPACK's estimate of the reciprocal condition number, `min|U_ii| / max|U_ii|`
    /// (`Info[UMFPACK_RCOND]`); 0 (or NaN) for a singular factorization.
    pub fn rcond(&self) -> f64 {
        self.info[ffi::UMFPACK_RCOND]
    }

    /// True if the numeric factorization returned `UMFPACK_WARNING_singular_matrix`.
    pub fn status_singular(&self) -> bool {
        self.status == ffi::UMFPACK_WARNING_singular_matrix
    }

    /// The status returned by the numeric factorization (0 or a positive warning).
    pub fn status(&self) -> i64 {
        self.status
    }

    /// Entries in `L` plus entries in `U`, each including its diagonal
    /// (`Info[UMFPACK_LNZ] + Info[UMFPACK_UNZ]`).
    pub fn lu_nnz(&self) -> usize {
        let l = self.info[ffi::UMFPACK_LNZ].max(0.0);
        let u = self.info[ffi::UMFPACK_UNZ].max(0.0);
        (l + u) as usize
    }

    /// Peak memory of symbolic plus numeric factorization in bytes
    /// (`Info[UMFPACK_PEAK_MEMORY] * Info[UMFPACK_SIZE_OF_UNIT]`).
    pub fn peak_memory_bytes(&self) -> f64 {
        self.info[ffi::UMFPACK_PEAK_MEMORY] * self.info[ffi::UMFPACK_SIZE_OF_UNIT]
    }

    /// Floating-point operations of the factorization (`Info[UMFPACK_FLOPS]`).
    pub fn flops(&self) -> f64 {
        self.info[ffi::UMFPACK_FLOPS]
    }

    /// Wall-clock time of the factorization in seconds, as measured by UMFPACK
    /// (`Info[UMFPACK_NUMERIC_WALLTIME]`).
    pub fn walltime(&self) -> f64 {
        self.info[ffi::UMFPACK_NUMERIC_WALLTIME]
    }

    /// UMFPACK's `Info` array from the numeric factorization (indices as in `umfpack.h`).
    pub fn info(&self) -> &[f64; UMFPACK_INFO] {
        &self.info
    }
}

impl Drop for UmfpackNumeric {
    fn drop(&mut self) {
        let mut raw = self.ptr.as_ptr();
        // SAFETY: `raw` came from the matching `umfpack_?l_numeric` and is freed only here.
        unsafe {
            if self.complex {
                ffi::umfpack_zl_free_numeric(&mut raw)
            } else {
                ffi::umfpack_dl_free_numeric(&mut raw)
            }
        }
    }
}
