//! ARPACK backend (cargo feature `arpack`): implicitly restarted Lanczos `dsaupd` +
//! `dseupd` in mode 3 — shift-invert, generalized (`bmat = 'G'`), `which = 'LM'` — with
//! OP = (K − σM)⁻¹ M applied through the shared [`ShiftInvert`] factorization.
//!
//! The binding is a hand-written `extern "C"` block for the Fortran symbols of the system
//! library (Debian `libarpack2`, 32-bit integers, built by gfortran ≥ 8): every argument by
//! pointer, `LOGICAL` as a 4-byte integer, and the hidden lengths of the `CHARACTER`
//! arguments appended at the end as `size_t`, in argument order (`bmat`, `which` for
//! `dsaupd`; `howmny`, `bmat`, `which` for `dseupd`). `build.rs` links `-larpack` when the
//! feature is on.
//!
//! ARPACK keeps its state between reverse-communication calls in Fortran `SAVE` variables,
//! so one process can run one ARPACK iteration at a time: a global lock serializes them.
//! No Rust code is called from Fortran, so no panic can cross the FFI boundary.

use super::krylov::{random_vector, Iteration};
use super::operator::ShiftInvert;
use super::options::EigenOptions;
use crate::{Error, Result};
use faer::{Mat, MatMut, MatRef};
use std::ffi::c_char;
use std::sync::Mutex;

type FInt = i32;

extern "C" {
    fn dsaupd_(
        ido: *mut FInt,
        bmat: *const c_char,
        n: *const FInt,
        which: *const c_char,
        nev: *const FInt,
        tol: *const f64,
        resid: *mut f64,
        ncv: *const FInt,
        v: *mut f64,
        ldv: *const FInt,
        iparam: *mut FInt,
        ipntr: *mut FInt,
        workd: *mut f64,
        workl: *mut f64,
        lworkl: *const FInt,
        info: *mut FInt,
        bmat_len: usize,
        which_len: usize,
    );
    fn dseupd_(
        rvec: *const FInt,
        howmny: *const c_char,
        select: *mut FInt,
        d: *mut f64,
        z: *mut f64,
        ldz: *const FInt,
        sigma: *const f64,
        bmat: *const c_char,
        n: *const FInt,
        which: *const c_char,
        nev: *const FInt,
        tol: *const f64,
        resid: *mut f64,
        ncv: *const FInt,
        v: *mut f64,
        ldv: *const FInt,
        iparam: *mut FInt,
        ipntr: *mut FInt,
        workd: *mut f64,
        workl: *mut f64,
        lworkl: *const FInt,
        info: *mut FInt,
        howmny_len: usize,
        bmat_len: usize,
        which_len: usize,
    );
}

/// Serializes ARPACK runs (its Fortran `SAVE` state is process-global).
static ARPACK: Mutex<()> = Mutex::new(());

/// The `count` eigenpairs of (K, M) closest to σ with `m` Lanczos vectors (`ncv`):
/// (λ, M-orthonormal vectors), in no particular order.
pub(super) fn solve(
    op: &mut ShiftInvert<'_>,
    count: usize,
    m: usize,
    opts: &EigenOptions,
) -> Result<(Vec<f64>, Mat<f64>, Iteration)> {
    let mut stats = Iteration::default();
    let n = op.n();
    if count >= n {
        return Err(Error::InvalidSetting(format!(
            "ARPACK computes at most N - 1 = {} eigenpairs ({count} asked); use the Krylov backend",
            n.saturating_sub(1)
        )));
    }
    let ncv = m.max(count + 1).min(n);
    let lworkl = ncv * (ncv + 8);
    let int = |x: usize, what: &str| {
        FInt::try_from(x).map_err(|_| {
            Error::InvalidSetting(format!(
                "ARPACK (32-bit integers): {what} = {x} is too large"
            ))
        })
    };
    let (n_f, nev_f, ncv_f, lworkl_f) = (
        int(n, "N")?,
        int(count, "the mode count")?,
        int(ncv, "ncv")?,
        int(lworkl, "lworkl")?,
    );
    int(n * ncv, "N * ncv")?;
    // update iterations = restarts + 1
    let max_iter = int(opts.max_restarts.saturating_add(1), "the restart limit")?;
    let (bmat, which) = (
        b"G".as_ptr().cast::<c_char>(),
        b"LM".as_ptr().cast::<c_char>(),
    );

    let mut resid: Vec<f64> = random_vector(n, 0).col(0).iter().copied().collect();
    let mut v = try_zeros(n * ncv)?;
    let mut workd = try_zeros(3 * n)?;
    let mut workl = try_zeros(lworkl)?;
    let mut iparam = [0 as FInt; 11];
    iparam[0] = 1; // exact shifts
    iparam[2] = max_iter;
    iparam[6] = 3; // mode 3: shift-invert, generalized
    let mut ipntr = [0 as FInt; 11];
    let (mut ido, mut info) = (0 as FInt, 1 as FInt); // info = 1: resid holds the start vector
    let tol = opts.tol;

    let _lock = ARPACK.lock().unwrap_or_else(|p| p.into_inner());
    loop {
        // SAFETY: every array has the length ARPACK's documentation requires for these n, ncv
        // (resid n, v n·ncv, workd 3n, workl ncv(ncv+8), iparam/ipntr 11); the strings have the
        // lengths passed; the lock excludes concurrent use of ARPACK's global state.
        unsafe {
            dsaupd_(
                &mut ido,
                bmat,
                &n_f,
                which,
                &nev_f,
                &tol,
                resid.as_mut_ptr(),
                &ncv_f,
                v.as_mut_ptr(),
                &n_f,
                iparam.as_mut_ptr(),
                ipntr.as_mut_ptr(),
                workd.as_mut_ptr(),
                workl.as_mut_ptr(),
                &lworkl_f,
                &mut info,
                1,
                2,
            );
        }
        match ido {
            -1 | 1 | 2 => {
                // 1-based offsets into workd: X at ipntr(1), Y at ipntr(2), B·X at ipntr(3)
                let at = |k: usize| (ipntr[k] as usize).wrapping_sub(1);
                let (x, y, bx) = (at(0), at(1), if ido == 1 { at(2) } else { 0 });
                if x.max(y).max(bx).saturating_add(n) > workd.len() {
                    return Err(Error::Factor(format!(
                        "ARPACK dsaupd returned work pointers outside workd (ipntr = {ipntr:?})"
                    )));
                }
                if ido == 1 {
                    // Y = (K − σM)⁻¹ (B X) with B X given
                    workd.copy_within(bx..bx + n, y);
                    op.solve_in_place(col_mut(&mut workd[y..y + n]));
                    stats.solves += 1;
                } else {
                    let (xs, ys) = disjoint(&mut workd, x, y, n);
                    if ido == -1 {
                        op.apply(col(xs), col_mut(ys));
                        stats.solves += 1;
                    } else {
                        op.mass_mul(col(xs), col_mut(ys));
                    }
                }
            }
            99 => break,
            other => {
                return Err(Error::Factor(format!("ARPACK dsaupd asked for an unsupported operation (ido = {other}, info = {info})")));
            }
        }
    }
    stats.restarts = (iparam[2] - 1).max(0) as usize; // iparam(3): update iterations taken
    stats.residual = opts.tol; // dsaupd's test: ‖r‖ ≤ tol·|θ|
    if info < 0 || info == 3 {
        return Err(Error::Factor(format!(
            "ARPACK dsaupd: info = {info}: {}",
            saupd_message(info, &iparam)
        )));
    }
    let nconv = iparam[4].max(0) as usize;
    if info == 1 || nconv < count {
        return Err(Error::NotConverged(format!(
            "ARPACK dsaupd: only {nconv} of {count} modes converged within {max_iter} Arnoldi update iterations (ncv = {ncv}); \
             increase the Krylov dimension or the restart limit"
        )));
    }

    let mut d = try_zeros(count)?;
    let mut z = try_zeros(n * count)?;
    let mut select = vec![0 as FInt; ncv];
    let (rvec, howmny) = (1 as FInt, b"A".as_ptr().cast::<c_char>());
    let sigma = op.sigma;
    // SAFETY: as above; d has nev entries, z is n × nev with ldz = n, select has ncv entries,
    // and the arrays dsaupd filled are passed back unchanged.
    unsafe {
        dseupd_(
            &rvec,
            howmny,
            select.as_mut_ptr(),
            d.as_mut_ptr(),
            z.as_mut_ptr(),
            &n_f,
            &sigma,
            bmat,
            &n_f,
            which,
            &nev_f,
            &tol,
            resid.as_mut_ptr(),
            &ncv_f,
            v.as_mut_ptr(),
            &n_f,
            iparam.as_mut_ptr(),
            ipntr.as_mut_ptr(),
            workd.as_mut_ptr(),
            workl.as_mut_ptr(),
            &lworkl_f,
            &mut info,
            1,
            1,
            2,
        );
    }
    drop(_lock);
    if info != 0 {
        return Err(Error::Factor(format!(
            "ARPACK dseupd: info = {info}: {}",
            seupd_message(info)
        )));
    }
    drop(v);
    let vectors = MatRef::from_column_major_slice(&z, n, count).to_owned();
    Ok((d, vectors, stats))
}

fn try_zeros(len: usize) -> Result<Vec<f64>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| Error::Factor(format!("cannot allocate {len} doubles of ARPACK workspace")))?;
    v.resize(len, 0.0);
    Ok(v)
}

/// Two non-overlapping length-n windows of `w` at offsets a (shared) and b (mutable).
fn disjoint(w: &mut [f64], a: usize, b: usize, n: usize) -> (&[f64], &mut [f64]) {
    if a < b {
        let (lo, hi) = w.split_at_mut(b);
        (&lo[a..a + n], &mut hi[..n])
    } else {
        let (lo, hi) = w.split_at_mut(a);
        (&hi[..n], &mut lo[b..b + n])
    }
}

fn col(x: &[f64]) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(x, x.len(), 1)
}

fn col_mut(x: &mut [f64]) -> MatMut<'_, f64> {
    let n = x.len();
    MatMut::from_column_major_slice_mut(x, n, 1)
}

/// The meaning of a `dsaupd` `info` code (ARPACK's documentation of `dsaupd`).
fn saupd_message(info: FInt, iparam: &[FInt; 11]) -> String {
    match info {
        1 => "maximum number of iterations taken (all possible eigenvalues of OP have been found)".into(),
        3 => "no shifts could be applied during a cycle of the implicitly restarted Arnoldi iteration; increase ncv (the Krylov dimension) relative to the mode count".into(),
        -1 => "N must be positive".into(),
        -2 => "NEV (the mode count) must be positive".into(),
        -3 => "NCV must be greater than NEV and at most N".into(),
        -4 => "the maximum number of Arnoldi update iterations must be positive".into(),
        -5 => "WHICH must be one of LM, SM, LA, SA or BE".into(),
        -6 => "BMAT must be I or G".into(),
        -7 => "the private work array WORKL is too short".into(),
        -8 => "error in the tridiagonal eigenvalue computation (LAPACK dsteqr)".into(),
        -9 => "the starting vector is zero".into(),
        -10 => "IPARAM(7) (the mode) must be 1, 2, 3, 4 or 5".into(),
        -11 => "IPARAM(7) = 1 and BMAT = G are incompatible".into(),
        -12 => "IPARAM(1) must be 0 or 1".into(),
        -13 => "NEV and WHICH = BE are incompatible".into(),
        -9999 => format!(
            "could not build a Lanczos factorization (its size reached {}); the operator may be wrong or the workspace too small",
            iparam[4]
        ),
        _ => "undocumented code".into(),
    }
}

/// The meaning of a `dseupd` `info` code (ARPACK's documentation of `dseupd`).
fn seupd_message(info: FInt) -> String {
    match info {
        -1 => "N must be positive",
        -2 => "NEV (the mode count) must be positive",
        -3 => "NCV must be greater than NEV and at most N",
        -5 => "WHICH must be one of LM, SM, LA, SA or BE",
        -6 => "BMAT must be I or G",
        -7 => "the private work array WORKL is too short",
        -8 => "error in the tridiagonal eigenvalue computation (LAPACK dsteqr)",
        -9 => "the starting vector is zero",
        -10 => "IPARAM(7) (the mode) must be 1, 2, 3, 4 or 5",
        -11 => "IPARAM(7) = 1 and BMAT = G are incompatible",
        -12 => "NEV and WHICH = BE are incompatible",
        -14 => "dsaupd did not find any eigenvalues to sufficient accuracy",
        -15 => "HOWMNY must be A or S when RVEC is true",
        -16 => "HOWMNY = S is not implemented",
        -17 => "dseupd got a different count of converged Ritz values than dsaupd (data changed between the calls)",
        _ => "undocumented code",
    }
    .into()
}
