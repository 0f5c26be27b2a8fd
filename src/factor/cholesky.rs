//! Real sparse Cholesky LLᵀ of the shifted pencil K − σM (faer, supernodal, on the pencil's
//! fill-reducing order).
//!
//! For σ below the spectrum of K φ = λ M φ (σ < 0 with M positive definite and K positive
//! semi-definite), K − σM is symmetric positive definite, even for a free body, so it has a
//! Cholesky factor P (K − σM) Pᵀ = L Lᵀ. Two users (docs/design.md §3.1, §3.6):
//! - the eigensolver's shift-invert operator (K − σM)⁻¹ M ([`Cholesky`]: factor once, solve
//!   in place per Krylov step);
//! - the benches' reference "real Cholesky on the same pattern" ([`reference_cholesky`]),
//!   the arithmetic floor the complex factorizations of A(iω) are compared with.
//!
//! [`symbolic_cholesky`] is the ordered (AMD, level-set bisection or nested dissection,
//! `ordering`) symbolic analysis of the pencil's N×N lower pattern. It is shared: the LBLᵀ
//! backend factors the real pencil on it and expands its order pairwise for the 2N form, and
//! the inertia count factors K − σM on it.

use super::backend::{try_vec, workspace};
use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky};
use faer::sparse::SparseColMatRef;
use faer::{Conj, MatMut, Par, Side};
use std::sync::Arc;
use std::time::Instant;

/// Symbolic Cholesky of the pencil's pattern on its fill-reducing ordering (AMD, a level-set
/// bisection, or METIS's nested dissection with the `metis` feature, as
/// [`super::symbolic_cholesky_ordered`] chooses): the reference "real Cholesky on the same
/// pattern" of the benches, the structure of the complex LDLᵀ and the ordering the 2N form
/// expands.
///
/// # Errors
/// [`Error::Factor`] when the analysis fails (allocation, index overflow).
pub fn symbolic_cholesky(pencil: &Pencil) -> Result<SymbolicCholesky<usize>> {
    super::ordering::symbolic_cholesky_ordered(pencil).map(|(sym, _)| sym)
}

/// A numeric Cholesky factor of K − σM on a [`symbolic_cholesky`] of the pencil: allocate
/// once ([`Cholesky::new`]), factor ([`Cholesky::factor`]), solve in place
/// ([`Cholesky::solve_block`], a block of columns at a time).
pub(crate) struct Cholesky {
    sym: Arc<SymbolicCholesky<usize>>,
    l: Vec<f64>,
    stack: MemBuffer,
}

impl Cholesky {
    /// Allocates the factor and the workspace of a factorization with parallelism `par`
    /// and of one-column solves.
    ///
    /// # Errors
    /// [`Error::Factor`] when the memory cannot be allocated.
    pub(crate) fn new(sym: Arc<SymbolicCholesky<usize>>, par: Par) -> Result<Self> {
        Self::with_rhs(sym, par, 1)
    }

    /// As [`Self::new`], with the workspace of solves of blocks of up to `rhs` columns
    /// ([`Self::solve_block`]).
    ///
    /// # Errors
    /// [`Error::Factor`] when the memory cannot be allocated.
    pub(crate) fn with_rhs(
        sym: Arc<SymbolicCholesky<usize>>,
        par: Par,
        rhs: usize,
    ) -> Result<Self> {
        let l = try_vec(sym.len_val())?;
        let stack = workspace(
            sym.factorize_numeric_llt_scratch::<f64>(par, Default::default())
                .or(sym.solve_in_place_scratch::<f64>(rhs.max(1), par)),
        )?;
        Ok(Cholesky { sym, l, stack })
    }

    /// Entries of the factor L.
    pub(crate) fn factor_nnz(&self) -> usize {
        self.sym.len_val()
    }

    /// Factors K − σM.
    ///
    /// # Errors
    /// faer's error when a pivot is not positive (K − σM is not positive definite).
    pub(crate) fn factor(
        &mut self,
        pencil: &Pencil,
        sigma: f64,
        par: Par,
    ) -> std::result::Result<(), LltError> {
        let mut vals = vec![0.0; pencil.nnz()];
        pencil.fill_shifted(sigma, &mut vals);
        self.factor_values(pencil, &vals, par)
    }

    /// Factors the real matrix with the values `vals` on the pencil's lower pattern (e.g.
    /// K + s₀D + s₀²M, [`Pencil::fill_quadratic`]).
    ///
    /// # Errors
    /// faer's error when a pivot is not positive.
    pub(crate) fn factor_values(
        &mut self,
        pencil: &Pencil,
        vals: &[f64],
        par: Par,
    ) -> std::result::Result<(), LltError> {
        self.sym.factorize_numeric_llt(
            &mut self.l,
            SparseColMatRef::new(pattern::lower(pencil), vals),
            Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut self.stack),
            Default::default(),
        )?;
        Ok(())
    }

    /// X ← (K − σM)⁻¹ X for a block of at most the `rhs` columns of [`Self::with_rhs`].
    pub(crate) fn solve_block(&mut self, x: MatMut<'_, f64>, par: Par) {
        LltRef::new(&self.sym, &self.l).solve_in_place_with_conj(
            Conj::No,
            x,
            par,
            MemStack::new(&mut self.stack),
        );
    }
}

/// The reference of the benches: a real sparse Cholesky LLᵀ of K + σM (σ = (2π·1 Hz)², so
/// that a free body's K becomes definite) on the pencil's ordered pattern. Returns
/// (nnz(L), seconds of the numeric factorization) — the arithmetic floor a complex
/// factorization of the same pattern is compared with (4× the flops in complex arithmetic).
///
/// # Errors
/// [`Error::Factor`] when the analysis or the factorization fails.
pub fn reference_cholesky(pencil: &Pencil, par: Par) -> Result<(usize, f64)> {
    let mut chol = Cholesky::new(Arc::new(symbolic_cholesky(pencil)?), par)?;
    let t = Instant::now();
    chol.factor(pencil, -(2.0 * std::f64::consts::PI).powi(2), par)
        .map_err(|e| Error::Factor(format!("reference Cholesky: {e:?}")))?;
    Ok((chol.factor_nnz(), t.elapsed().as_secs_f64()))
}
