//! Exact eigenvalue counts of K φ = λ M φ from the inertia of K − σM, and the LBLᵀ factor of
//! an interior shift (docs/design.md §3.6).
//!
//! With M symmetric positive definite, the number of eigenvalues λ < σ equals the number of
//! negative eigenvalues of the symmetric K − σM. By Sylvester's law of inertia a congruence
//! preserves that number, so it is read off a factorization P (K − σM) Pᵀ = L B Lᵀ as the
//! number of negative eigenvalues of the (block) diagonal B: the in-house LDLᵀ's static
//! pivots when they can be trusted, else an LBLᵀ's 1×1 pivots and the eigenvalues of its
//! 2×2 pivots ([`ShiftedIndefinite`]). "All modes up to f" is then counted, not guessed,
//! and the same factor is the shift-invert operator of a spectrum slice whose shift lies
//! inside the spectrum (where K − σM is indefinite and has no Cholesky factor).

use super::backend::{try_vec, Storage};
use super::cholesky::symbolic_cholesky;
use super::lblt::Factor;
use super::pattern;
use super::real_ldlt::RealLdlt;
use super::refine::{refine, Buffers, Stop};
use crate::pencil::{solve_through, Congruent, Pencil};
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::SparseColMatRef;
use faer::{Mat, MatMut, Par};
use std::sync::Arc;

/// The number of eigenvalues λ < σ of K φ = λ M φ (M positive definite), exactly, from the
/// inertia of K − σM (Sylvester's law on the factorization of [`ShiftedIndefinite`];
/// docs/design.md §3.6). Used to count the modes up to a frequency instead of guessing.
///
/// # Errors
/// [`Error::Factor`] when the analysis fails; [`Error::Singular`] when σ is an eigenvalue
/// to working precision (a zero pivot: the count would be ambiguous).
pub fn count_eigenvalues_below(pencil: &Pencil, sigma: f64) -> Result<usize> {
    count_eigenvalues_below_with(
        &Arc::new(symbolic_cholesky(pencil)?),
        pencil,
        sigma,
        Storage::available(),
    )
}

/// [`count_eigenvalues_below`] on an existing [`symbolic_cholesky`] of the pencil (no second
/// pattern analysis), its factor kept as `storage` says: on disk when it does not fit the
/// run's memory budget (a count needs the whole LDLᵀ, as large as any other factor).
///
/// # Errors
/// As [`count_eigenvalues_below`].
pub fn count_eigenvalues_below_with(
    sym: &Arc<SymbolicCholesky<usize>>,
    pencil: &Pencil,
    sigma: f64,
    storage: Storage<'_>,
) -> Result<usize> {
    Ok(ShiftedIndefinite::new(sym.clone(), pencil, sigma, 1, pool_par(), storage)?.below())
}

/// `at(f_hz)`, or `at(f_hz (1 + 10⁻⁶))` when (2π f_hz)² is an eigenvalue to working
/// precision ([`Error::Singular`]): a band's top counted, or a space made, a millionth
/// higher, where the count is no longer ambiguous.
pub(crate) fn off_an_eigenfrequency<T>(
    f_hz: f64,
    mut at: impl FnMut(f64) -> Result<T>,
) -> Result<T> {
    match at(f_hz) {
        Err(Error::Singular { .. }) => at(f_hz * (1.0 + 1e-6)),
        r => r,
    }
}

/// The threads of the rayon pool the caller runs in, sequential outside any pool (a C
/// caller's process must not start rayon's global pool).
fn pool_par() -> Par {
    match rayon::current_thread_index() {
        Some(_) => Par::rayon(rayon::current_num_threads()),
        None => Par::Seq,
    }
}

/// Normwise backward error of the probe solve up to which the static-pivot LDLᵀ is kept:
/// L D Lᵀ = P(K − σM)Pᵀ + E with ‖E‖ a few ε‖K − σM‖ where the pivots did not grow; an error
/// of 1e-10 would move only eigenvalues within 1e-10‖K − σM‖ of σ across it, and the solves
/// are refined to [`REFINE_ABOVE`] as the LBLᵀ's are.
const STATIC_PROBE_BACKWARD_ERROR: f64 = 1e-10;

/// P (K − σM) Pᵀ = L B Lᵀ for any real σ, on the shared symbolic analysis: its inertia
/// ν(σ) = #{λ < σ} and solves with K − σM.
///
/// Two kernels, the first that can be trusted:
/// - the in-house supernodal LDLᵀ with static pivots (`ldlt`, on the threads of `par`), kept
///   when no pivot was perturbed, min |dᵢ| / max |dᵢ| > ε and a probe solve's normwise
///   backward error is ≤ [`STATIC_PROBE_BACKWARD_ERROR`] (pivots that grew without pivoting
///   show there);
/// - faer's LBLᵀ with Bunch–Kaufman pivots chosen inside each supernode (sequential).
///
/// Neither bounds the growth across supernodes, so an interior shift can meet a nearly
/// singular block and the factor grows: a solve's backward error then reaches 1e-13…7e-12
/// instead of ε. Solves are therefore checked and refined (fixed-precision iterative
/// refinement, as PARDISO does after its perturbed pivots): x ← x + A⁻¹(b − A x) while the
/// normwise backward error ‖b − A x‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞) of a column exceeds
/// [`REFINE_ABOVE`], at most [`MAX_REFINEMENTS`](super::MAX_REFINEMENTS) times (module
/// `refine`).
///
/// Growth is a property of the factor, not of the right-hand side: a factor whose first
/// [`CHECK_FIRST`] solves all met the target unrefined is checked on every [`CHECK_EVERY`]-th
/// solve only, and on every solve again from its first refinement on. The check is a product
/// with K − σM, half the cost of a solve (the tet10 shaft, 306 modes: 1.0 s of 2.9 s of
/// solves, no solve refined).
pub(crate) struct ShiftedIndefinite<'a> {
    sym: Arc<SymbolicCholesky<usize>>,
    kernel: Kernel,
    below: usize,
    /// Largest |l_ij| below the diagonal of the LBLᵀ ([`super::PivotStats::max_l`]); 0 for
    /// the static-pivot LDLᵀ.
    max_l: f64,
    /// The pencil factored ([`Pencil::factored`]).
    pencil: &'a Pencil,
    /// The coupling the solves go through, if any.
    coupling: Option<Arc<Congruent>>,
    /// Lower values of K − σM on the factored pencil's pattern.
    vals: Vec<f64>,
    /// ‖K − σM‖∞.
    norm_inf: f64,
    /// Refinement steps taken over all solves.
    refinements: usize,
    /// Solves so far (calls of [`Self::solve_in_place`]).
    solves: usize,
    /// Buffers of the refinements, reused by every solve (boxed: the struct stays small).
    refine_buffers: Box<Buffers<f64>>,
}

enum Kernel {
    Static(Box<RealLdlt>),
    Pivoted(Factor),
}

impl Kernel {
    fn solve(&mut self, sym: &SymbolicCholesky<usize>, x: MatMut<'_, f64>, par: Par) {
        match self {
            Kernel::Static(f) => f.solve(x, par),
            Kernel::Pivoted(f) => f.solve_in_place(sym, x, Par::Seq),
        }
    }
}

/// Normwise backward error of a solve above which it is refined: the Krylov–Schur iteration
/// resolves Ritz residuals to 1e-14 relative, and an operator applied with a larger backward
/// error stalls it above that (Ritz residuals stay at ~1e-13). Unrefined solves land at
/// 1e-16…5e-14 where the factor is sound and at 1e-13…7e-12 where it grew (docs/design.md
/// §3.6).
const REFINE_ABOVE: f64 = 1e-14;

/// Solves checked (and refined where needed) before a sound factor is only sampled.
const CHECK_FIRST: usize = 4;

/// A factor whose first solves needed no refinement checks every this-many-th solve.
const CHECK_EVERY: usize = 8;

impl<'a> ShiftedIndefinite<'a> {
    /// Factors K − σM (the static-pivot LDLᵀ on the threads of `par`, else the LBLᵀ), with
    /// workspace to solve `rhs` columns at once.
    ///
    /// # Errors
    /// [`Error::Factor`] when the memory cannot be allocated; [`Error::Singular`] when σ is
    /// an eigenvalue to working precision (min |pivot| / max |pivot| ≤ ε: the count would be
    /// ambiguous and the solves meaningless).
    pub(crate) fn new(
        sym: Arc<SymbolicCholesky<usize>>,
        pencil: &'a Pencil,
        sigma: f64,
        rhs: usize,
        par: Par,
        storage: Storage<'_>,
    ) -> Result<Self> {
        let coupling = pencil.coupling();
        let pencil = pencil.factored();
        let mut vals = try_vec::<f64>(pencil.nnz())?;
        pencil.fill_shifted(sigma, &mut vals);
        let norm_inf = pattern::symmetric_norm_inf(pencil, |p| vals[p]);
        let mut refine_buffers = Box::<Buffers<f64>>::default();
        let trusted = static_ldlt(&sym, pencil, &vals, rhs, par, storage, &mut refine_buffers)?;
        let (kernel, below, max_l) = match trusted {
            Some((f, below)) => (Kernel::Static(Box::new(f)), below, 0.0),
            None => {
                let mut lblt = Factor::new(&sym, rhs)?;
                let a = SparseColMatRef::new(pattern::lower(pencil), &vals);
                let st = lblt.factor(&sym, a, Par::Seq);
                if !(st.ratio > f64::EPSILON) {
                    return Err(Error::Singular {
                        freq_hz: crate::units::lambda_to_hz(sigma.max(0.0)),
                        detail: format!("K - sigma M is singular to working precision (pivot ratio {:.1e}): sigma is an eigenvalue; move the bound slightly", st.ratio),
                    });
                }
                (Kernel::Pivoted(lblt), st.negative, st.max_l)
            }
        };
        Ok(ShiftedIndefinite {
            sym,
            kernel,
            below,
            max_l,
            pencil,
            coupling,
            vals,
            norm_inf,
            refinements: 0,
            solves: 0,
            refine_buffers,
        })
    }

    /// ν(σ): the number of eigenvalues λ < σ.
    pub(crate) fn below(&self) -> usize {
        self.below
    }

    /// Entries of the factor L.
    pub(crate) fn factor_nnz(&self) -> usize {
        self.sym.len_val()
    }

    /// The static-pivot LDLᵀ, when it is the kernel.
    pub(crate) fn in_house(&self) -> Option<&RealLdlt> {
        match &self.kernel {
            Kernel::Static(f) => Some(f),
            Kernel::Pivoted(_) => None,
        }
    }

    /// Largest |l_ij| below the diagonal of the LBLᵀ: the growth of a pivot restricted to
    /// its supernode ([`super::PivotStats::max_l`]); 0 for the static-pivot LDLᵀ, whose growth
    /// its probe solve checked.
    pub(crate) fn max_l(&self) -> f64 {
        self.max_l
    }

    /// Refinement steps taken so far (over all solves and column blocks).
    pub(crate) fn refinements(&self) -> usize {
        self.refinements
    }

    /// x ← (K − σM)⁻¹ x (the LDLᵀ's on the threads of `par`, the LBLᵀ's sequential), checked
    /// as the type's doc says and refined to a normwise backward error ≤ [`REFINE_ABOVE`]
    /// when [`MAX_REFINEMENTS`](super::MAX_REFINEMENTS) steps reach it (module `refine`).
    pub(crate) fn solve_in_place(&mut self, x: MatMut<'_, f64>, par: Par) {
        let check =
            self.refinements > 0 || self.solves < CHECK_FIRST || self.solves % CHECK_EVERY == 0;
        self.solves += 1;
        let (sym, kernel, vals) = (&self.sym, &mut self.kernel, &self.vals);
        let (pencil, norm_inf) = (self.pencil, self.norm_inf);
        let (refinements, buffers) = (&mut self.refinements, &mut self.refine_buffers);
        // through the coupling, the system solved and refined is the factored pencil's
        solve_through(self.coupling.as_deref(), x, |mut x| {
            if !check {
                kernel.solve(sym, x, par);
                return;
            }
            let b = x.to_owned();
            kernel.solve(sym, x.as_mut(), par);
            *refinements += refine(
                pattern::Lower {
                    pencil,
                    entry: &|p: usize| vals[p],
                },
                Stop::Normwise {
                    norm_inf,
                    above: REFINE_ABOVE,
                },
                |mut out| out.copy_from(&b),
                x,
                |r| kernel.solve(sym, r, par),
                buffers,
                par,
            );
        });
    }
}

/// The static-pivot LDLᵀ of the matrix with lower values `vals` and its count of negative
/// pivots, when it can be trusted ([`ShiftedIndefinite`]'s doc); `None` otherwise and for a
/// pattern without supernodes.
fn static_ldlt(
    sym: &Arc<SymbolicCholesky<usize>>,
    pencil: &Pencil,
    vals: &[f64],
    rhs: usize,
    par: Par,
    storage: Storage<'_>,
    buffers: &mut Buffers<f64>,
) -> Result<Option<(RealLdlt, usize)>> {
    let Some(mut f) = RealLdlt::new(pencil, sym.clone(), rhs, storage)? else {
        return Ok(None);
    };
    let pivots = f.factor(vals, par)?;
    if pivots.perturbed > 0 || !(pivots.ratio > f64::EPSILON) {
        return Ok(None);
    }
    let n = pencil.n();
    let b = Mat::<f64>::from_fn(n, 1, |i, _| ((i * 7919) % 13) as f64 - 6.0);
    let mut x = b.clone();
    f.solve(x.as_mut(), par);
    buffers.block(n, 1).copy_from(&b);
    let entry = |p: usize| vals[p];
    let a = pattern::Lower {
        pencil,
        entry: &entry,
    };
    pattern::symmetric_residual(a, x.as_ref(), false, buffers, par);
    let trusted = buffers.column_normwise()[0] <= STATIC_PROBE_BACKWARD_ERROR;
    Ok(trusted.then_some((f, pivots.negative)))
}
