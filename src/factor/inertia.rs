//! Exact eigenvalue counts of K φ = λ M φ from the inertia of K − σM, and the LBLᵀ factor of
//! an interior shift (docs/design.md §3.6).
//!
//! With M symmetric positive definite, the number of eigenvalues λ < σ equals the number of
//! negative eigenvalues of the symmetric K − σM. By Sylvester's law of inertia a congruence
//! preserves that number, so it is read off an LBLᵀ factorization P (K − σM) Pᵀ = L B Lᵀ as
//! the number of negative eigenvalues of the block diagonal B (1×1 pivots and the
//! eigenvalues of 2×2 pivots). "All modes up to f" is then counted, not guessed, and the same
//! factor is the shift-invert operator of a spectrum slice whose shift lies inside the
//! spectrum (where K − σM is indefinite and has no Cholesky factor).

use super::cholesky::symbolic_cholesky;
use super::lblt::Factor;
use super::{pattern, try_vec};
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::SparseColMatRef;
use faer::{MatMut, Par};
use std::sync::Arc;

/// The number of eigenvalues λ < σ of K φ = λ M φ (M positive definite), exactly, from the
/// inertia of K − σM (Sylvester's law on an LBLᵀ factorization). Used to count the modes up
/// to a frequency instead of guessing.
///
/// # Errors
/// [`Error::Factor`] when the analysis fails; [`Error::Singular`] when σ is an eigenvalue
/// to working precision (a zero pivot: the count would be ambiguous).
pub fn count_eigenvalues_below(pencil: &Pencil, sigma: f64) -> Result<usize> {
    count_eigenvalues_below_with(&Arc::new(symbolic_cholesky(pencil)?), pencil, sigma)
}

/// [`count_eigenvalues_below`] on an existing [`symbolic_cholesky`] of the pencil (no second
/// pattern analysis).
///
/// # Errors
/// As [`count_eigenvalues_below`].
pub fn count_eigenvalues_below_with(
    sym: &Arc<SymbolicCholesky<usize>>,
    pencil: &Pencil,
    sigma: f64,
) -> Result<usize> {
    Ok(ShiftedLblt::new(sym.clone(), pencil, sigma, 1)?.below())
}

/// P (K − σM) Pᵀ = L B Lᵀ for any real σ, on the shared symbolic analysis: its inertia
/// ν(σ) = #{λ < σ} and solves with K − σM.
pub(crate) struct ShiftedLblt {
    sym: Arc<SymbolicCholesky<usize>>,
    factor: Factor,
    below: usize,
}

impl ShiftedLblt {
    /// Factors K − σM, with workspace to solve `rhs` columns at once.
    ///
    /// # Errors
    /// [`Error::Factor`] when the memory cannot be allocated; [`Error::Singular`] when σ is
    /// an eigenvalue to working precision (min |pivot| / max |pivot| ≤ ε: the count would be
    /// ambiguous and the solves meaningless).
    pub(crate) fn new(
        sym: Arc<SymbolicCholesky<usize>>,
        pencil: &Pencil,
        sigma: f64,
        rhs: usize,
    ) -> Result<Self> {
        let mut vals = try_vec::<f64>(pencil.nnz())?;
        pencil.fill_shifted(sigma, &mut vals);
        let mut factor = Factor::new(&sym, rhs)?;
        let a = SparseColMatRef::new(pattern::lower(pencil), &vals);
        let st = factor.factor(&sym, a, Par::Seq);
        if !(st.ratio > f64::EPSILON) {
            return Err(Error::Singular {
                freq_hz: crate::units::lambda_to_hz(sigma.max(0.0)),
                detail: format!("K - sigma M is singular to working precision (pivot ratio {:.1e}): sigma is an eigenvalue; move the bound slightly", st.ratio),
            });
        }
        Ok(ShiftedLblt {
            sym,
            factor,
            below: st.negative,
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

    /// x ← (K − σM)⁻¹ x (sequential).
    pub(crate) fn solve_in_place(&mut self, x: MatMut<'_, f64>) {
        self.factor.solve_in_place(&self.sym, x, Par::Seq);
    }
}
