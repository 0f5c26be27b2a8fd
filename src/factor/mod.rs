//! Sparse factorization of the pencil A(iω) behind one interface (DESIGN.md §3.1).
//!
//! [`Analysis::new`] does the pattern work once per model: AMD ordering and symbolic
//! factorization. [`Numeric`] holds one numeric factorization's buffers and is refilled for
//! every frequency by [`Numeric::factor`] (no pattern work, no allocation after the first use).
//!
//! Backends ([`Backend`]):
//! - **faer LBLᵀ** (default): faer's supernodal symmetric machinery with intranode
//!   Bunch–Kaufman pivoting. Undamped (D = 0), A = K − ω²M is real symmetric indefinite and is
//!   factored as is (the real path). Damped, A = Ar + iAi is complex symmetric; faer has no
//!   complex-symmetric LDLᵀ, so the equivalent real symmetric system
//!   [[Ar, Ai], [Ai, −Ar]] [xr; −xi] = [br; bi] is factored with the two unknowns of each DoF
//!   interleaved (2N×2N, every 2×2 block [[a_r, a_i], [a_i, −a_r]] is a scaled reflection,
//!   well conditioned whenever the complex entry is non-zero). The AMD order of the N×N
//!   pattern is expanded pairwise, so pairs stay in one supernode (where 2×2 pivots can form)
//!   and the fill is exactly 4× that of the real factor on the same order.
//! - **faer LU**: faer's sparse LU (COLAMD) of the full pattern, real or complex. Fine for
//!   small models; it blows up on 3-D pencils at 10⁵ DoF (DESIGN.md §3.1), so
//!   [`Backend::Auto`] uses it only below [`LU_MAX_N`].
//! - **UMFPACK** (cargo feature `umfpack`).
//!
//! Accuracy is not assumed: the sweep verifies every factorization with a probe solve.

#[cfg(feature = "umfpack")]
pub mod umfpack;

use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, IntranodeLbltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::lu::{
    factorize_symbolic_lu, LuRef, LuSymbolicParams, NumericLu, SymbolicLu,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{c64, Conj, Mat, MatMut, Par, Side};
use std::time::Instant;

/// Largest N for which [`Backend::Auto`] picks faer LU. Measured (`sparsemor bench sweep`,
/// README): on the bar, faer LU and the LBLᵀ form factor equally fast at N = 1656 and LU
/// sweeps 1.4–1.6× faster at N = 12 060 (its solve is 2× cheaper); at 10⁵ DoF LU's COLAMD fill
/// explodes on 3-D pencils (DESIGN.md §3.1), so above this size Auto uses LBLᵀ.
pub const LU_MAX_N: usize = 15_000;

/// Which sparse factorization to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// faer LBLᵀ, except faer LU for N ≤ [`LU_MAX_N`] (measured rule, see README).
    Auto,
    /// faer supernodal LBLᵀ (real N×N undamped, interleaved real 2N×2N damped).
    FaerLblt,
    /// faer sparse LU (COLAMD), real or complex.
    FaerLu,
    /// UMFPACK (SuiteSparse), real or complex; needs the `umfpack` feature.
    Umfpack,
}

impl std::str::FromStr for Backend {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "auto" => Ok(Backend::Auto),
            "lblt" | "faer-lblt" => Ok(Backend::FaerLblt),
            "lu" | "faer-lu" => Ok(Backend::FaerLu),
            "umfpack" => Ok(Backend::Umfpack),
            _ => Err(Error::InvalidSetting(format!(
                "backend '{s}': choose auto, faer-lblt, faer-lu or umfpack"
            ))),
        }
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Backend::Auto => "auto",
            Backend::FaerLblt => "faer-lblt",
            Backend::FaerLu => "faer-lu",
            Backend::Umfpack => "umfpack",
        })
    }
}

/// What the symbolic analysis measured.
#[derive(Clone, Debug)]
pub struct SymbolicStats {
    /// The backend actually used.
    pub backend: Backend,
    /// True when the real path (D = 0) is used.
    pub real: bool,
    /// Wall time of ordering + symbolic factorization (s).
    pub seconds: f64,
    /// Stored entries of the factor (scalars of the factorized matrix; 0 if the backend
    /// reports it only after the numeric phase).
    pub factor_nnz: usize,
    /// Estimated bytes of one numeric factorization incl. workspace.
    pub bytes_per_factor: usize,
}

// One value per analysis / per worker: the size difference between variants costs nothing.
#[allow(clippy::large_enum_variant)]
enum Inner {
    Lblt {
        /// symbolic of the factorized matrix (N×N real, or 2N×2N interleaved)
        sym: SymbolicCholesky<usize>,
        /// lower pattern of the factorized matrix when it is the 2N form
        pattern2: Option<(Vec<usize>, Vec<usize>)>,
    },
    Lu {
        sym: SymbolicLu<usize>,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        /// for each full-pattern entry, the position in the pencil's lower pattern
        src: Vec<usize>,
    },
    #[cfg(feature = "umfpack")]
    Umfpack {
        sym: umfpack::UmfpackSymbolic,
        row_idx: Vec<usize>,
        src: Vec<usize>,
    },
}

/// The once-per-model part of the factorization: ordering and symbolic analysis.
pub struct Analysis {
    inner: Inner,
    n: usize,
    real: bool,
    stats: SymbolicStats,
    max_rhs: usize,
}

/// Builds the AMD-ordered symbolic Cholesky of the pencil's N×N lower pattern.
fn symbolic_n(
    pencil: &Pencil,
    ord: SymmetricOrdering<'_, usize>,
) -> Result<SymbolicCholesky<usize>> {
    let n = pencil.n();
    let pat = unsafe {
        SymbolicSparseColMatRef::new_unchecked(n, n, pencil.col_ptr(), None, pencil.row_idx())
    };
    factorize_symbolic_cholesky(pat, Side::Lower, ord, supernodal_params())
        .map_err(|e| Error::Factor(format!("symbolic analysis: {e:?}")))
}

fn supernodal_params() -> CholeskySymbolicParams<'static> {
    CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    }
}

/// Symbolic Cholesky of the pencil's pattern with AMD ordering: the reference "real
/// Cholesky on the same pattern" of the benches, and the ordering the 2N form expands.
pub fn symbolic_cholesky(pencil: &Pencil) -> Result<SymbolicCholesky<usize>> {
    symbolic_n(pencil, SymmetricOrdering::Amd)
}

/// Lower pattern of the interleaved 2N×2N form: block (i, j) of the N×N lower pattern
/// becomes rows 2i, 2i+1 of columns 2j, 2j+1 (only 2j+1 for the diagonal of column 2j+1).
fn interleaved_pattern(pencil: &Pencil) -> (Vec<usize>, Vec<usize>) {
    let n = pencil.n();
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    let mut col_ptr = Vec::with_capacity(2 * n + 1);
    let mut row_idx = Vec::with_capacity(4 * ri.len());
    col_ptr.push(0);
    for j in 0..n {
        for &i in &ri[cp[j]..cp[j + 1]] {
            row_idx.extend([2 * i, 2 * i + 1]);
        }
        col_ptr.push(row_idx.len());
        for &i in &ri[cp[j]..cp[j + 1]] {
            if i == j {
                row_idx.push(2 * i + 1);
            } else {
                row_idx.extend([2 * i, 2 * i + 1]);
            }
        }
        col_ptr.push(row_idx.len());
    }
    (col_ptr, row_idx)
}

/// Full (both triangles) pattern from the pencil's lower pattern, with the source position
/// of every entry in the lower pattern.
fn full_pattern(pencil: &Pencil) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let n = pencil.n();
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    let mut count = vec![0usize; n];
    for j in 0..n {
        for &i in &ri[cp[j]..cp[j + 1]] {
            count[j] += 1;
            if i != j {
                count[i] += 1;
            }
        }
    }
    let mut col_ptr = vec![0usize; n + 1];
    for j in 0..n {
        col_ptr[j + 1] = col_ptr[j] + count[j];
    }
    let mut next = col_ptr[..n].to_vec();
    let nnz = col_ptr[n];
    let mut row_idx = vec![0usize; nnz];
    let mut src = vec![0usize; nnz];
    // rows of column j: first the upper part (from columns i < j, i.e. entries (j, i) of the
    // lower pattern, visited in increasing i), then the lower part (sorted): sorted overall
    for j in 0..n {
        for p in cp[j]..cp[j + 1] {
            let i = ri[p];
            if i != j {
                // entry (i, j) lower → also (j, i) in column i, row j
                row_idx[next[i]] = j;
                src[next[i]] = p;
                next[i] += 1;
            }
        }
    }
    // second pass for the lower part, appended after the upper entries of each column
    for j in 0..n {
        for p in cp[j]..cp[j + 1] {
            row_idx[next[j]] = ri[p];
            src[next[j]] = p;
            next[j] += 1;
        }
    }
    (col_ptr, row_idx, src)
}

impl Analysis {
    /// Orders and analyses the pencil's pattern for `backend`. `max_rhs` is the largest number
    /// of right-hand sides solved at once (sizes the solve workspace).
    ///
    /// # Errors
    /// [`Error::Factor`] when the analysis fails (allocation, index overflow), or
    /// [`Error::InvalidSetting`] for `umfpack` without the feature.
    pub fn new(pencil: &Pencil, backend: Backend, max_rhs: usize) -> Result<Self> {
        let start = Instant::now();
        let n = pencil.n();
        let real = pencil.is_real();
        let backend = match backend {
            Backend::Auto if n <= LU_MAX_N => Backend::FaerLu,
            Backend::Auto => Backend::FaerLblt,
            b => b,
        };
        let scalar = if real { 8 } else { 16 };
        let (inner, factor_nnz, bytes) = match backend {
            Backend::FaerLblt => {
                let sym_n = symbolic_cholesky(pencil)?;
                if real {
                    let nnz = sym_n.len_val();
                    let bytes = 8 * nnz
                        + lblt_scratch(&sym_n, max_rhs).size_bytes()
                        + 24 * n
                        + 8 * pencil.nnz();
                    (
                        Inner::Lblt {
                            sym: sym_n,
                            pattern2: None,
                        },
                        nnz,
                        bytes,
                    )
                } else {
                    let perm = sym_n.perm().expect("AMD ordering yields a permutation");
                    let (fwd, _) = perm.arrays();
                    let fwd2: Vec<usize> = fwd.iter().flat_map(|&f| [2 * f, 2 * f + 1]).collect();
                    let mut inv2 = vec![0usize; 2 * n];
                    for (k, &f) in fwd2.iter().enumerate() {
                        inv2[f] = k;
                    }
                    let (cp2, ri2) = interleaved_pattern(pencil);
                    let pat2 = unsafe {
                        SymbolicSparseColMatRef::new_unchecked(2 * n, 2 * n, &cp2, None, &ri2)
                    };
                    let perm2 = unsafe { faer::perm::PermRef::new_unchecked(&fwd2, &inv2, 2 * n) };
                    let sym = factorize_symbolic_cholesky(
                        pat2,
                        Side::Lower,
                        SymmetricOrdering::Custom(perm2),
                        supernodal_params(),
                    )
                    .map_err(|e| Error::Factor(format!("symbolic analysis (2N form): {e:?}")))?;
                    let nnz = sym.len_val();
                    let bytes = 8 * nnz
                        + lblt_scratch(&sym, 2 * max_rhs).size_bytes()
                        + 48 * n
                        + 8 * ri2.len()
                        + 16 * pencil.nnz();
                    (
                        Inner::Lblt {
                            sym,
                            pattern2: Some((cp2, ri2)),
                        },
                        nnz,
                        bytes,
                    )
                }
            }
            Backend::FaerLu => {
                let (col_ptr, row_idx, src) = full_pattern(pencil);
                let pat = unsafe {
                    SymbolicSparseColMatRef::new_unchecked(n, n, &col_ptr, None, &row_idx)
                };
                let sym = factorize_symbolic_lu(pat, LuSymbolicParams::default())
                    .map_err(|e| Error::Factor(format!("symbolic LU: {e:?}")))?;
                let bytes = scalar * row_idx.len() * 4;
                (
                    Inner::Lu {
                        sym,
                        col_ptr,
                        row_idx,
                        src,
                    },
                    0,
                    bytes,
                )
            }
            #[cfg(feature = "umfpack")]
            Backend::Umfpack => {
                let (col_ptr, row_idx, src) = full_pattern(pencil);
                // METIS: measured 6× fewer flops and 2.4× less fill than UMFPACK's default AMD
                // on a 10⁵-DoF 3-D pattern (143 s vs 861 s per real factorization)
                let sym = umfpack::UmfpackSymbolic::with_ordering(
                    n,
                    &col_ptr,
                    &row_idx,
                    !real,
                    umfpack::UmfpackOrdering::Metis,
                )?;
                let bytes = scalar * row_idx.len() * 4;
                (Inner::Umfpack { sym, row_idx, src }, 0, bytes)
            }
            #[cfg(not(feature = "umfpack"))]
            Backend::Umfpack => return Err(Error::InvalidSetting(
                "backend umfpack: this build has no UMFPACK; rebuild with `--features umfpack` \
                     (needs libsuitesparse-dev)"
                    .into(),
            )),
            Backend::Auto => unreachable!("resolved above"),
        };
        Ok(Analysis {
            inner,
            n,
            real,
            max_rhs,
            stats: SymbolicStats {
                backend,
                real,
                seconds: start.elapsed().as_secs_f64(),
                factor_nnz,
                bytes_per_factor: bytes,
            },
        })
    }

    /// What the analysis measured.
    pub fn stats(&self) -> &SymbolicStats {
        &self.stats
    }

    /// Dimension N of the pencil.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Allocates the buffers of one numeric factorization (one per concurrent frequency).
    ///
    /// # Errors
    /// [`Error::Factor`] when the workspace cannot be allocated.
    pub fn numeric(&self, pencil: &Pencil) -> Result<Numeric> {
        let nnz_lower = pencil.nnz();
        let alloc = |req: StackReq| {
            MemBuffer::try_new(req).map_err(|_| {
                Error::Factor(format!(
                    "cannot allocate {} bytes of factorization workspace",
                    req.size_bytes()
                ))
            })
        };
        let state = match &self.inner {
            Inner::Lblt { sym, pattern2 } => {
                let n_f = sym.nrows();
                let rhs = if pattern2.is_some() {
                    self.max_rhs
                } else {
                    2 * self.max_rhs
                };
                State::Lblt {
                    l: try_vec(sym.len_val())?,
                    subdiag: try_vec(n_f)?,
                    fwd: vec![0; n_f],
                    inv: vec![0; n_f],
                    vals2: match pattern2 {
                        Some((_, ri2)) => try_vec(ri2.len())?,
                        None => Vec::new(),
                    },
                    stack: alloc(lblt_scratch(sym, rhs))?,
                }
            }
            Inner::Lu { sym, row_idx, .. } => {
                let req = if self.real {
                    sym.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default())
                        .or(sym.solve_in_place_scratch::<f64>(2 * self.max_rhs, Par::Seq))
                } else {
                    sym.factorize_numeric_lu_scratch::<c64>(Par::Seq, Default::default())
                        .or(sym.solve_in_place_scratch::<c64>(self.max_rhs, Par::Seq))
                };
                State::Lu {
                    real: NumericLu::new(),
                    complex: NumericLu::new(),
                    vals_r: if self.real {
                        try_vec(row_idx.len())?
                    } else {
                        Vec::new()
                    },
                    vals_c: if self.real {
                        Vec::new()
                    } else {
                        vec![c64::new(0.0, 0.0); row_idx.len()]
                    },
                    stack: alloc(req)?,
                }
            }
            #[cfg(feature = "umfpack")]
            Inner::Umfpack { row_idx, .. } => State::Umfpack {
                num: None,
                re: try_vec(row_idx.len())?,
                im: if self.real {
                    Vec::new()
                } else {
                    try_vec(row_idx.len())?
                },
            },
        };
        Ok(Numeric {
            state,
            re: try_vec(nnz_lower)?,
            im: if self.real {
                Vec::new()
            } else {
                try_vec(nnz_lower)?
            },
            factored_at: None,
            pivot_ratio: f64::NAN,
        })
    }
}

fn lblt_scratch(sym: &SymbolicCholesky<usize>, rhs: usize) -> StackReq {
    sym.factorize_numeric_intranode_lblt_scratch::<f64>(Par::Seq, Default::default())
        .or(sym.solve_in_place_scratch::<f64>(rhs.max(1), Par::Seq))
}

fn try_vec<T: Clone + Default>(len: usize) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| Error::Factor(format!("cannot allocate {len} factor entries")))?;
    v.resize(len, T::default());
    Ok(v)
}

#[allow(clippy::large_enum_variant)]
enum State {
    Lblt {
        l: Vec<f64>,
        subdiag: Vec<f64>,
        fwd: Vec<usize>,
        inv: Vec<usize>,
        vals2: Vec<f64>,
        stack: MemBuffer,
    },
    Lu {
        real: NumericLu<usize, f64>,
        complex: NumericLu<usize, c64>,
        vals_r: Vec<f64>,
        vals_c: Vec<c64>,
        stack: MemBuffer,
    },
    #[cfg(feature = "umfpack")]
    Umfpack {
        num: Option<umfpack::UmfpackNumeric>,
        re: Vec<f64>,
        im: Vec<f64>,
    },
}

/// One numeric factorization of A(iω), refilled per frequency.
pub struct Numeric {
    state: State,
    re: Vec<f64>,
    im: Vec<f64>,
    factored_at: Option<f64>,
    pivot_ratio: f64,
}

impl Numeric {
    /// Factors A(iω) = K − ω²M + iωD in place. `par` is the parallelism inside the
    /// factorization (use `Par::Seq` when frequencies run in parallel).
    ///
    /// # Errors
    /// [`Error::Singular`] when a pivot breaks down exactly, [`Error::Factor`] on backend
    /// failure.
    pub fn factor(&mut self, an: &Analysis, pencil: &Pencil, omega: f64, par: Par) -> Result<()> {
        self.factored_at = None;
        let freq_hz = omega / (2.0 * std::f64::consts::PI);
        if an.real {
            pencil.fill_real(omega, &mut self.re);
        } else {
            pencil.fill_complex(omega, &mut self.re, &mut self.im);
        }
        match (&an.inner, &mut self.state) {
            (
                Inner::Lblt { sym, pattern2 },
                State::Lblt {
                    l,
                    subdiag,
                    fwd,
                    inv,
                    vals2,
                    stack,
                },
            ) => {
                let n_f = sym.nrows();
                let (cp, ri, vals): (&[usize], &[usize], &[f64]) = match pattern2 {
                    None => (pencil.col_ptr(), pencil.row_idx(), &self.re),
                    Some((cp2, ri2)) => {
                        interleave(pencil.col_ptr(), &self.re, &self.im, vals2);
                        (cp2, ri2, vals2)
                    }
                };
                let a = SparseColMatRef::new(
                    unsafe { SymbolicSparseColMatRef::new_unchecked(n_f, n_f, cp, None, ri) },
                    vals,
                );
                sym.factorize_numeric_intranode_lblt(
                    l,
                    subdiag,
                    fwd,
                    inv,
                    a,
                    Side::Lower,
                    par,
                    MemStack::new(stack),
                    Default::default(),
                );
                self.pivot_ratio = lblt_pivots(sym, l, subdiag).ratio;
                if !(self.pivot_ratio > 0.0) {
                    return Err(Error::Singular {
                        freq_hz,
                        detail: "a zero pivot occurred in the LBLᵀ factorization (undamped at an eigenfrequency?)".into(),
                    });
                }
            }
            (
                Inner::Lu {
                    sym,
                    col_ptr,
                    row_idx,
                    src,
                },
                State::Lu {
                    real,
                    complex,
                    vals_r,
                    vals_c,
                    stack,
                },
            ) => {
                let n = an.n;
                let pat =
                    unsafe { SymbolicSparseColMatRef::new_unchecked(n, n, col_ptr, None, row_idx) };
                let res = if an.real {
                    for (v, &s) in vals_r.iter_mut().zip(src.iter()) {
                        *v = self.re[s];
                    }
                    sym.factorize_numeric_lu(
                        real,
                        SparseColMatRef::new(pat, vals_r),
                        par,
                        MemStack::new(stack),
                        Default::default(),
                    )
                    .map(|_| ())
                } else {
                    for (v, &s) in vals_c.iter_mut().zip(src.iter()) {
                        *v = c64::new(self.re[s], self.im[s]);
                    }
                    sym.factorize_numeric_lu(
                        complex,
                        SparseColMatRef::new(pat, vals_c),
                        par,
                        MemStack::new(stack),
                        Default::default(),
                    )
                    .map(|_| ())
                };
                res.map_err(|e| Error::Singular {
                    freq_hz,
                    detail: format!("sparse LU failed: {e:?}"),
                })?;
                self.pivot_ratio = f64::NAN;
            }
            #[cfg(feature = "umfpack")]
            (Inner::Umfpack { sym, src, .. }, State::Umfpack { num, re, im }) => {
                *num = None;
                for (v, &s) in re.iter_mut().zip(src.iter()) {
                    *v = self.re[s];
                }
                let f = if an.real {
                    umfpack::UmfpackNumeric::real(sym, re)?
                } else {
                    for (v, &s) in im.iter_mut().zip(src.iter()) {
                        *v = self.im[s];
                    }
                    umfpack::UmfpackNumeric::complex(sym, re, im)?
                };
                self.pivot_ratio = f.rcond();
                if f.status_singular() {
                    return Err(Error::Singular {
                        freq_hz,
                        detail: format!(
                            "UMFPACK reports a singular matrix (rcond {:.1e})",
                            f.rcond()
                        ),
                    });
                }
                *num = Some(f);
            }
            #[allow(unreachable_patterns)]
            _ => unreachable!("state built by the same analysis"),
        }
        self.factored_at = Some(omega);
        Ok(())
    }

    /// min |pivot| / max |pivot| of the last factorization (1×1 pivots and the eigenvalues of
    /// 2×2 pivots for LBLᵀ; UMFPACK's rcond estimate; NaN for faer LU).
    pub fn pivot_ratio(&self) -> f64 {
        self.pivot_ratio
    }

    /// Solves A(iω) X = B in place for a complex block (N × k, k ≤ the analysis' max_rhs + 1).
    pub fn solve(&mut self, an: &Analysis, rhs: MatMut<'_, c64>, par: Par) {
        debug_assert!(self.factored_at.is_some());
        let mut rhs = rhs;
        let (n, k) = (rhs.nrows(), rhs.ncols());
        match (&an.inner, &mut self.state) {
            (
                Inner::Lblt { sym, pattern2 },
                State::Lblt {
                    l,
                    subdiag,
                    fwd,
                    inv,
                    stack,
                    ..
                },
            ) => {
                let f = IntranodeLbltRef::new(sym, l, subdiag, unsafe {
                    faer::perm::PermRef::new_unchecked(fwd, inv, sym.nrows())
                });
                if pattern2.is_some() {
                    // [br; bi] interleaved; the solution is [xr; −xi] interleaved
                    let mut u = Mat::<f64>::from_fn(2 * n, k, |r, c| {
                        let z = rhs[(r / 2, c)];
                        if r % 2 == 0 {
                            z.re
                        } else {
                            z.im
                        }
                    });
                    f.solve_in_place_with_conj(Conj::No, u.as_mut(), par, MemStack::new(stack));
                    for c in 0..k {
                        for i in 0..n {
                            rhs[(i, c)] = c64::new(u[(2 * i, c)], -u[(2 * i + 1, c)]);
                        }
                    }
                } else {
                    solve_split(rhs.as_mut(), |u| {
                        f.solve_in_place_with_conj(Conj::No, u, par, MemStack::new(stack))
                    });
                }
            }
            (
                Inner::Lu { sym, .. },
                State::Lu {
                    real,
                    complex,
                    stack,
                    ..
                },
            ) => {
                if an.real {
                    let lu = LuRef::new_unchecked(sym, real);
                    solve_split(rhs.as_mut(), |u| {
                        lu.solve_in_place_with_conj(Conj::No, u, par, MemStack::new(stack))
                    });
                } else {
                    let lu = LuRef::new_unchecked(sym, complex);
                    lu.solve_in_place_with_conj(Conj::No, rhs.as_mut(), par, MemStack::new(stack));
                }
            }
            #[cfg(feature = "umfpack")]
            (Inner::Umfpack { .. }, State::Umfpack { num: Some(f), .. }) => {
                let (mut br, mut bi) = (vec![0.0; n], vec![0.0; n]);
                let (mut xr, mut xi) = (vec![0.0; n], vec![0.0; n]);
                for c in 0..k {
                    for i in 0..n {
                        br[i] = rhs[(i, c)].re;
                        bi[i] = rhs[(i, c)].im;
                    }
                    let ok = if an.real {
                        f.solve_real(&br, &mut xr)
                            .and_then(|_| f.solve_real(&bi, &mut xi))
                    } else {
                        f.solve_complex(&br, &bi, &mut xr, &mut xi)
                    };
                    if ok.is_err() {
                        xr.fill(f64::NAN);
                    }
                    for i in 0..n {
                        rhs[(i, c)] = c64::new(xr[i], xi[i]);
                    }
                }
            }
            #[allow(unreachable_patterns)]
            _ => unreachable!("state built by the same analysis"),
        }
    }
}

/// Solves a complex block with a real factorization: [Re B | Im B] (N × 2k) in one solve.
fn solve_split(mut rhs: MatMut<'_, c64>, solve: impl FnOnce(MatMut<'_, f64>)) {
    let (n, k) = (rhs.nrows(), rhs.ncols());
    let mut u = Mat::<f64>::from_fn(n, 2 * k, |r, c| {
        if c < k {
            rhs[(r, c)].re
        } else {
            rhs[(r, c - k)].im
        }
    });
    solve(u.as_mut());
    for c in 0..k {
        for i in 0..n {
            rhs[(i, c)] = c64::new(u[(i, c)], u[(i, c + k)]);
        }
    }
}

/// Writes the interleaved 2N lower values from the N×N lower values (re, im): block (i, j) =
/// [[re, im], [im, −re]]; the diagonal block of column 2j+1 keeps only (2j+1, 2j+1) = −re.
fn interleave(cp: &[usize], re: &[f64], im: &[f64], out: &mut [f64]) {
    let mut q = 0;
    for j in 0..cp.len() - 1 {
        for p in cp[j]..cp[j + 1] {
            out[q] = re[p];
            out[q + 1] = im[p];
            q += 2;
        }
        for p in cp[j]..cp[j + 1] {
            if p == cp[j] {
                out[q] = -re[p];
                q += 1;
            } else {
                out[q] = im[p];
                out[q + 1] = -re[p];
                q += 2;
            }
        }
    }
}

/// Pivot statistics of an intranode LBLᵀ factor: min |pivot| / max |pivot| over the block
/// diagonal B (1×1 pivots and the eigenvalues of 2×2 pivots) and the number of negative
/// eigenvalues of B — by Sylvester's law the number of negative eigenvalues of A.
pub struct PivotStats {
    /// min |pivot| / max |pivot|.
    pub ratio: f64,
    /// Negative eigenvalues of B (= of A).
    pub negative: usize,
}

fn lblt_pivots(sym: &SymbolicCholesky<usize>, l: &[f64], subdiag: &[f64]) -> PivotStats {
    let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
        return PivotStats {
            ratio: f64::NAN,
            negative: 0,
        };
    };
    let (mut lo, mut hi, mut negative) = (f64::INFINITY, 0.0f64, 0usize);
    let mut count = |x: f64| {
        lo = lo.min(x.abs());
        hi = hi.max(x.abs());
        negative += usize::from(x < 0.0);
    };
    let (begin, end, cpv) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
    for sn in 0..s.n_supernodes() {
        let (start, ncols) = (begin[sn], end[sn] - begin[sn]);
        let vals = &l[cpv[sn]..cpv[sn + 1]];
        let nrows = vals.len() / ncols.max(1);
        let d = |t: usize| vals[t * nrows + t];
        let mut t = 0;
        while t < ncols {
            let e = subdiag[start + t];
            if e == 0.0 || t + 1 == ncols {
                count(d(t));
                t += 1;
            } else {
                // eigenvalues of [[a, e], [e, b]]
                let (a, b) = (d(t), d(t + 1));
                let (m, r) = (0.5 * (a + b), (0.25 * (a - b) * (a - b) + e * e).sqrt());
                count(m - r);
                count(m + r);
                t += 2;
            }
        }
    }
    PivotStats {
        ratio: if hi > 0.0 { lo / hi } else { 0.0 },
        negative,
    }
}

/// The number of eigenvalues λ < σ of K φ = λ M φ (M positive definite), exactly, from the
/// inertia of K − σM (Sylvester's law on an LBLᵀ factorization). Used to count the modes up
/// to a frequency instead of guessing.
///
/// # Errors
/// [`Error::Factor`] when the analysis fails; [`Error::Singular`] when σ is an eigenvalue
/// to working precision (a zero pivot: the count would be ambiguous).
pub fn count_eigenvalues_below(pencil: &Pencil, sigma: f64) -> Result<usize> {
    count_eigenvalues_below_with(&symbolic_cholesky(pencil)?, pencil, sigma)
}

/// [`count_eigenvalues_below`] on an existing [`symbolic_cholesky`] of the pencil (no second
/// pattern analysis).
///
/// # Errors
/// As [`count_eigenvalues_below`].
pub fn count_eigenvalues_below_with(
    sym: &SymbolicCholesky<usize>,
    pencil: &Pencil,
    sigma: f64,
) -> Result<usize> {
    let n = pencil.n();
    let mut vals = try_vec::<f64>(pencil.nnz())?;
    pencil.fill_shifted(sigma, &mut vals);
    let (mut l, mut subdiag) = (try_vec::<f64>(sym.len_val())?, try_vec::<f64>(n)?);
    let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
    let mut buf = MemBuffer::try_new(lblt_scratch(sym, 1))
        .map_err(|_| Error::Factor("cannot allocate LBLᵀ workspace".into()))?;
    let a = SparseColMatRef::new(
        unsafe {
            SymbolicSparseColMatRef::new_unchecked(n, n, pencil.col_ptr(), None, pencil.row_idx())
        },
        &vals,
    );
    sym.factorize_numeric_intranode_lblt(
        &mut l,
        &mut subdiag,
        &mut fwd,
        &mut inv,
        a,
        Side::Lower,
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    );
    let st = lblt_pivots(sym, &l, &subdiag);
    if !(st.ratio > f64::EPSILON) {
        return Err(Error::Singular {
            freq_hz: sigma.max(0.0).sqrt() / (2.0 * std::f64::consts::PI),
            detail: format!("K - sigma M is singular to working precision (pivot ratio {:.1e}): sigma is an eigenvalue; move the bound slightly", st.ratio),
        });
    }
    Ok(st.negative)
}

/// The reference of the benches: a real sparse Cholesky LLᵀ of K + σM (σ = (2π·1 Hz)², so
/// that a free body's K becomes definite) on the pencil's AMD-ordered pattern. Returns
/// (nnz(L), seconds of the numeric factorization) — the arithmetic floor a complex
/// factorization of the same pattern is compared with (4× the flops in complex arithmetic).
///
/// # Errors
/// [`Error::Factor`] when the analysis or the factorization fails.
pub fn reference_cholesky(pencil: &Pencil, par: Par) -> Result<(usize, f64)> {
    let sym = symbolic_cholesky(pencil)?;
    let n = pencil.n();
    let mut vals = vec![0.0; pencil.nnz()];
    pencil.fill_shifted(-(2.0 * std::f64::consts::PI).powi(2), &mut vals);
    let mut l = try_vec::<f64>(sym.len_val())?;
    let req = sym.factorize_numeric_llt_scratch::<f64>(par, Default::default());
    let mut buf = MemBuffer::try_new(req)
        .map_err(|_| Error::Factor("cannot allocate Cholesky workspace".into()))?;
    let a = SparseColMatRef::new(
        unsafe {
            SymbolicSparseColMatRef::new_unchecked(n, n, pencil.col_ptr(), None, pencil.row_idx())
        },
        &vals,
    );
    let t = Instant::now();
    sym.factorize_numeric_llt(
        &mut l,
        a,
        Side::Lower,
        Default::default(),
        par,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .map_err(|e| Error::Factor(format!("reference Cholesky: {e:?}")))?;
    Ok((sym.len_val(), t.elapsed().as_secs_f64()))
}
