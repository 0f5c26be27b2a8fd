//! Exact eigenvalue counts of K φ = λ M φ from the inertia of K − σM (docs/design.md §3.6).
//!
//! With M symmetric positive definite, the number of eigenvalues λ < σ equals the number of
//! negative eigenvalues of the symmetric K − σM. By Sylvester's law of inertia a congruence
//! preserves that number, so it is read off an LBLᵀ factorization P (K − σM) Pᵀ = L B Lᵀ as
//! the number of negative eigenvalues of the block diagonal B (1×1 pivots and the
//! eigenvalues of 2×2 pivots). "All modes up to f" is then counted, not guessed.

use super::cholesky::symbolic_cholesky;
use super::lblt::Factor;
use super::{pattern, try_vec};
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::SparseColMatRef;
use faer::Par;

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
    let mut vals = try_vec::<f64>(pencil.nnz())?;
    pencil.fill_shifted(sigma, &mut vals);
    let mut factor = Factor::new(sym, 1)?;
    let a = SparseColMatRef::new(pattern::lower(pencil), &vals);
    let st = factor.factor(sym, a, Par::Seq);
    if !(st.ratio > f64::EPSILON) {
        return Err(Error::Singular {
            freq_hz: sigma.max(0.0).sqrt() / (2.0 * std::f64::consts::PI),
            detail: format!("K - sigma M is singular to working precision (pivot ratio {:.1e}): sigma is an eigenvalue; move the bound slightly", st.ratio),
        });
    }
    Ok(st.negative)
}
