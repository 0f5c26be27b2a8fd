//! Raw declarations from `umfpack.h` (UMFPACK 5.7.9; `umfpack_v6` switches the two types
//! that UMFPACK 6 changed): the `umfpack_dl_*` (real) and `umfpack_zl_*` (complex, split
//! storage) routines, their `Control`/`Info` indices and status codes. Everything here is
//! `unsafe` to call; the safe wrapper is the parent module.

#![allow(non_snake_case, non_upper_case_globals)]

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

// Control indices and values.
pub const UMFPACK_ORDERING: usize = 10;
pub const UMFPACK_ORDERING_CHOLMOD: f64 = 0.0;
pub const UMFPACK_ORDERING_AMD: f64 = 1.0;
pub const UMFPACK_ORDERING_METIS: f64 = 3.0;
pub const UMFPACK_ORDERING_BEST: f64 = 4.0;

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
