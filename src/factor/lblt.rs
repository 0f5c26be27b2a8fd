//! faer's supernodal LBLᵀ (intranode Bunch–Kaufman pivoting) of A(iω) = K − ω²M + iωD.
//!
//! P A Pᵀ = L B Lᵀ with L unit lower triangular, B block diagonal with 1×1 and 2×2 pivots
//! (chosen inside each supernode) and P the fill-reducing order followed by the pivoting
//! order. Two forms, chosen by the pencil:
//! - **real N×N** (undamped, D = 0): A = K − ω²M is real symmetric indefinite and is factored
//!   as is, on the ordering of [`symbolic_cholesky`];
//! - **interleaved 2N×2N** (damped): A = Ar + iAi is complex symmetric and faer has no
//!   complex-symmetric LDLᵀ, so the equivalent real symmetric system
//!   [[Ar, Ai], [Ai, −Ar]] [xr; −xi] = [br; bi] is factored with the two unknowns of each
//!   DoF interleaved (every 2×2 block [[a_r, a_i], [a_i, −a_r]] is a scaled reflection, well
//!   conditioned whenever the complex entry is non-zero). The order of the N×N pattern
//!   is expanded pairwise, so pairs stay in one supernode (where 2×2 pivots can form) and
//!   the fill is exactly 4× that of the real factor on the same order (docs/design.md §3.1).
//!
//! The pivots of B also give the inertia of A ([`Factor::pivots`], Sylvester's law), which
//! the eigenvalue count of [`super::inertia`] reads.

use super::backend::{
    require_pivots, solve_split, try_vec, workspace, Analysed, Backend, Factorization, Footprint,
    SymbolicFactorization, Values,
};
use super::ordering::supernodal_params;
use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, IntranodeLbltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{c64, Conj, Mat, MatMut, Par, Side};
use std::sync::Arc;

/// The analysis: the symbolic factor of the real N×N pencil or of its 2N form.
pub(super) struct Symbolic {
    /// Symbolic of the factorized matrix (N×N real, or 2N×2N interleaved).
    sym: Arc<SymbolicCholesky<usize>>,
    /// Lower pattern of the factorized matrix when it is the 2N form.
    pattern2: Option<SymbolicSparseColMat<usize>>,
    max_rhs: usize,
}

impl Symbolic {
    /// The symbolic factorization of the pencil from `sym_n`, the ordered symbolic
    /// Cholesky of its N×N pattern: that one when it is real, the 2N form on the pairwise
    /// expanded order when it is damped.
    pub(super) fn new(
        pencil: &Pencil,
        sym_n: Arc<SymbolicCholesky<usize>>,
        max_rhs: usize,
    ) -> Result<(Self, Footprint)> {
        let n = pencil.n();
        if pencil.is_real() {
            let factor_nnz = sym_n.len_val();
            let bytes =
                8 * factor_nnz + scratch(&sym_n, max_rhs).size_bytes() + 24 * n + 8 * pencil.nnz();
            let symbolic = Symbolic {
                sym: sym_n,
                pattern2: None,
                max_rhs,
            };
            return Ok((symbolic, Footprint { factor_nnz, bytes }));
        }
        let perm = sym_n.perm().expect("AMD ordering yields a permutation");
        let (fwd, _) = perm.arrays();
        let fwd2: Vec<usize> = fwd.iter().flat_map(|&f| [2 * f, 2 * f + 1]).collect();
        let mut inv2 = vec![0usize; 2 * n];
        for (k, &f) in fwd2.iter().enumerate() {
            inv2[f] = k;
        }
        let pattern2 = pattern::interleaved(pencil);
        let sym = factorize_symbolic_cholesky(
            pattern2.as_ref(),
            Side::Lower,
            SymmetricOrdering::Custom(PermRef::new_checked(&fwd2, &inv2, 2 * n)),
            supernodal_params(),
        )
        .map_err(|e| Error::Factor(format!("symbolic analysis (2N form): {e:?}")))?;
        let factor_nnz = sym.len_val();
        let bytes = 8 * factor_nnz
            + scratch(&sym, 2 * max_rhs).size_bytes()
            + 48 * n
            + 8 * pattern2.row_idx().len()
            + 16 * pencil.nnz();
        let symbolic = Symbolic {
            sym: Arc::new(sym),
            pattern2: Some(pattern2),
            max_rhs,
        };
        Ok((symbolic, Footprint { factor_nnz, bytes }))
    }
}

/// The LBLᵀ analysis of the pencil on `sym_n`, the ordered symbolic Cholesky of its N×N
/// pattern (the registry's entry, `factor::analyse`).
pub(super) fn analyse(
    pencil: &Pencil,
    sym_n: Arc<SymbolicCholesky<usize>>,
    max_rhs: usize,
) -> Result<Analysed> {
    let (symbolic, footprint) = Symbolic::new(pencil, sym_n, max_rhs)?;
    Ok((Box::new(symbolic), footprint))
}

impl SymbolicFactorization for Symbolic {
    fn backend(&self) -> Backend {
        Backend::FaerLblt
    }

    fn numeric(&self, _pencil: &Pencil) -> Result<Box<dyn Factorization + '_>> {
        // the real path solves Re and Im of a complex block side by side
        let rhs = if self.pattern2.is_some() {
            self.max_rhs
        } else {
            2 * self.max_rhs
        };
        Ok(Box::new(Numeric {
            symbolic: self,
            factor: Factor::new(&self.sym, rhs)?,
            vals2: match &self.pattern2 {
                Some(p) => try_vec(p.row_idx().len())?,
                None => Vec::new(),
            },
            pivot_ratio: f64::NAN,
        }))
    }
}

/// The numeric LBLᵀ factor of a [`SymbolicCholesky`]: L, the sub-diagonal of B, the
/// pivoting permutation and the workspace of factorization and solve.
pub(super) struct Factor {
    l: Vec<f64>,
    subdiag: Vec<f64>,
    fwd: Vec<usize>,
    inv: Vec<usize>,
    stack: MemBuffer,
}

impl Factor {
    /// Allocates a factor of `sym` and the workspace to solve `rhs` columns at once.
    pub(super) fn new(sym: &SymbolicCholesky<usize>, rhs: usize) -> Result<Self> {
        let n = sym.nrows();
        Ok(Factor {
            l: try_vec(sym.len_val())?,
            subdiag: try_vec(n)?,
            // a valid permutation before the first factorization overwrites it
            fwd: (0..n).collect(),
            inv: (0..n).collect(),
            stack: workspace(scratch(sym, rhs))?,
        })
    }

    /// Factors `a` (lower triangle) on `sym` and returns its pivot statistics.
    pub(super) fn factor(
        &mut self,
        sym: &SymbolicCholesky<usize>,
        a: SparseColMatRef<'_, usize, f64>,
        par: Par,
    ) -> PivotStats {
        sym.factorize_numeric_intranode_lblt(
            &mut self.l,
            &mut self.subdiag,
            &mut self.fwd,
            &mut self.inv,
            a,
            Side::Lower,
            par,
            MemStack::new(&mut self.stack),
            Default::default(),
        );
        self.pivots(sym)
    }

    /// Solves A X = B in place with the last factorization.
    pub(super) fn solve_in_place(
        &mut self,
        sym: &SymbolicCholesky<usize>,
        rhs: MatMut<'_, f64>,
        par: Par,
    ) {
        // SAFETY: `fwd` and `inv` have `sym.nrows()` entries (allocated in `new` for this
        // `sym`) and always hold a permutation and its inverse: the identity from `new`, then
        // only what faer's intranode LBLᵀ writes there, its pivoting permutation and inverse.
        let perm = unsafe { PermRef::new_unchecked(&self.fwd, &self.inv, sym.nrows()) };
        IntranodeLbltRef::new(sym, &self.l, &self.subdiag, perm).solve_in_place_with_conj(
            Conj::No,
            rhs,
            par,
            MemStack::new(&mut self.stack),
        );
    }

    /// Pivot statistics of the last factorization: min |pivot| / max |pivot| over the
    /// block diagonal B (1×1 pivots and the eigenvalues of 2×2 pivots) and the number of
    /// negative eigenvalues of B.
    fn pivots(&self, sym: &SymbolicCholesky<usize>) -> PivotStats {
        let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
            return PivotStats {
                ratio: f64::NAN,
                negative: 0,
                max_l: f64::NAN,
            };
        };
        let (mut lo, mut hi, mut negative) = (f64::INFINITY, 0.0f64, 0usize);
        let mut max_l = 0.0f64;
        let mut count = |x: f64| {
            lo = lo.min(x.abs());
            hi = hi.max(x.abs());
            negative += usize::from(x < 0.0);
        };
        let (begin, end, cpv) = (s.supernode_begin(), s.supernode_end(), s.col_ptr_for_val());
        for sn in 0..s.n_supernodes() {
            let (start, ncols) = (begin[sn], end[sn] - begin[sn]);
            let vals = &self.l[cpv[sn]..cpv[sn + 1]];
            let nrows = vals.len() / ncols.max(1);
            let d = |t: usize| vals[t * nrows + t];
            for t in 0..ncols {
                // below the diagonal of column t; a 2×2 pivot's off-diagonal is in `subdiag`
                let first = t + 1 + usize::from(self.subdiag[start + t] != 0.0);
                for &v in &vals[t * nrows + first.min(nrows)..(t + 1) * nrows] {
                    max_l = max_l.max(v.abs());
                }
            }
            let mut t = 0;
            while t < ncols {
                let e = self.subdiag[start + t];
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
            max_l,
            negative,
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
    /// Largest |l_ij| below the diagonal of L: Bunch–Kaufman bounds it by about 2.8 when it
    /// may pivot anywhere; a pivot restricted to its supernode's block that is nearly
    /// singular shows as a large entry, and the solves' backward error grows with it.
    pub max_l: f64,
}

/// Workspace of one factorization and of a solve with `rhs` columns.
fn scratch(sym: &SymbolicCholesky<usize>, rhs: usize) -> StackReq {
    sym.factorize_numeric_intranode_lblt_scratch::<f64>(Par::Seq, Default::default())
        .or(sym.solve_in_place_scratch::<f64>(rhs.max(1), Par::Seq))
}

/// One numeric LBLᵀ factorization of A(iω), refilled per frequency.
pub(super) struct Numeric<'a> {
    symbolic: &'a Symbolic,
    factor: Factor,
    /// Values of the 2N form (empty on the real path).
    vals2: Vec<f64>,
    pivot_ratio: f64,
}

impl Factorization for Numeric<'_> {
    fn factor(&mut self, a: &Values<'_>, freq_hz: f64, par: Par) -> Result<()> {
        let sym = &self.symbolic.sym;
        let a = match &self.symbolic.pattern2 {
            None => SparseColMatRef::new(a.pattern, a.re),
            Some(p) => {
                interleave(a.pattern.col_ptr(), a.re, a.im, &mut self.vals2);
                SparseColMatRef::new(p.as_ref(), &self.vals2)
            }
        };
        self.pivot_ratio = self.factor.factor(sym, a, par).ratio;
        require_pivots(
            self.pivot_ratio,
            freq_hz,
            "a zero pivot occurred in the LBLᵀ factorization (undamped at an eigenfrequency?)",
        )
    }

    fn solve(&mut self, mut rhs: MatMut<'_, c64>, par: Par) {
        let sym = &self.symbolic.sym;
        if self.symbolic.pattern2.is_none() {
            solve_split(rhs, |u| self.factor.solve_in_place(sym, u, par));
            return;
        }
        // [br; bi] interleaved; the solution is [xr; −xi] interleaved
        let (n, k) = (rhs.nrows(), rhs.ncols());
        let mut u = Mat::<f64>::from_fn(2 * n, k, |r, c| {
            let z = rhs[(r / 2, c)];
            if r % 2 == 0 {
                z.re
            } else {
                z.im
            }
        });
        self.factor.solve_in_place(sym, u.as_mut(), par);
        for c in 0..k {
            for i in 0..n {
                rhs[(i, c)] = c64::new(u[(2 * i, c)], -u[(2 * i + 1, c)]);
            }
        }
    }

    fn pivot_ratio(&self) -> f64 {
        self.pivot_ratio
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
