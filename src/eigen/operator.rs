//! The shift-invert operator S = (K − σM)⁻¹ M of one spectrum slice (docs/design.md §3.6).
//!
//! S is self-adjoint in the M-inner product ⟨x, y⟩_M = xᵀMy; its eigenvalues θ = 1/(λ − σ)
//! are largest in magnitude for the λ nearest σ, on either side. Two factorizations of the
//! same ordered (AMD or nested dissection) symbolic analysis:
//! - σ below the spectrum (σ < 0: K − σM is positive definite even for a free body): a
//!   sparse Cholesky factor ([`Cholesky`], every pivot positive), the cheapest — the bottom
//!   slice and [`super::Request::Lowest`];
//! - σ inside the spectrum (an interior slice): the LDLᵀ with static pivots where it can be
//!   trusted, else LBLᵀ with Bunch–Kaufman pivots ([`ShiftedIndefinite`]), whose inertia also
//!   gives ν(σ), the number of eigenvalues below σ (Sylvester).

use crate::factor::{Cholesky, FactorPlace, RealLdlt, ShiftedIndefinite, Storage};
use crate::pencil::{Coefficient, Pencil};
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::{MatMut, MatRef, Par};
use std::sync::Arc;

enum Factor<'a> {
    Definite(Cholesky),
    Indefinite(ShiftedIndefinite<'a>),
}

/// S = (K − σM)⁻¹ M: the factor of K − σM and the mass matrix.
pub(crate) struct ShiftInvert<'a> {
    factor: Factor<'a>,
    pencil: &'a Pencil,
    pub(crate) sigma: f64,
    /// The threads of the factorization, also those of the iteration's dense products.
    pub(crate) par: Par,
}

impl<'a> ShiftInvert<'a> {
    /// Factors K − σM on the symbolic analysis `sym` of the pencil's pattern: Cholesky for
    /// σ < 0, LBLᵀ otherwise; `par` parallelizes the Cholesky factorization; solves take up
    /// to `rhs` columns at once.
    ///
    /// # Errors
    /// [`Error::Factor`] when K − σM (σ < 0) is not positive definite or memory is short;
    /// [`Error::Singular`] when σ is an eigenvalue to working precision.
    pub(crate) fn new(
        pencil: &'a Pencil,
        sym: Arc<SymbolicCholesky<usize>>,
        sigma: f64,
        par: Par,
        rhs: usize,
        storage: Storage<'_>,
    ) -> Result<Self> {
        let factor = if sigma < 0.0 {
            let mut chol = Cholesky::with_rhs(pencil, sym, par, rhs, storage)?;
            chol.factor(pencil, sigma, par).map_err(|e| {
                Error::Factor(format!(
                    "K - sigma M (sigma = {sigma:.3e}) is not positive definite ({e}): is M positive definite and K positive semi-definite?"
                ))
            })?;
            Factor::Definite(chol)
        } else {
            Factor::Indefinite(ShiftedIndefinite::new(
                sym, pencil, sigma, rhs, par, storage,
            )?)
        };
        Ok(ShiftInvert {
            factor,
            pencil,
            sigma,
            par,
        })
    }

    /// ν(σ) = #{λ < σ} when the factor is an LBLᵀ (0 below the spectrum).
    pub(crate) fn below(&self) -> usize {
        match &self.factor {
            Factor::Definite(_) => 0,
            Factor::Indefinite(f) => f.below(),
        }
    }

    /// Iterative-refinement steps taken by the solves (LBLᵀ only).
    pub(crate) fn refinements(&self) -> usize {
        match &self.factor {
            Factor::Definite(_) => 0,
            Factor::Indefinite(f) => f.refinements(),
        }
    }

    /// Largest |l_ij| below the diagonal of an LBLᵀ factor (module `factor::lblt`'s
    /// `PivotStats::max_l`): large where a pivot inside a supernode met a nearly singular
    /// block and the solves' backward error grew; 0 for a Cholesky factor and for the static-pivot LDLᵀ.
    pub(crate) fn growth(&self) -> f64 {
        match &self.factor {
            Factor::Definite(_) => 0.0,
            Factor::Indefinite(f) => f.max_l(),
        }
    }

    /// Entries of the factor L.
    pub(crate) fn factor_nnz(&self) -> usize {
        match &self.factor {
            Factor::Definite(f) => f.factor_nnz(),
            Factor::Indefinite(f) => f.factor_nnz(),
        }
    }

    /// The in-house real factor, when it is the kernel.
    fn in_house(&self) -> Option<&RealLdlt> {
        match &self.factor {
            Factor::Definite(f) => f.in_house(),
            Factor::Indefinite(f) => f.in_house(),
        }
    }

    /// Where the factor L is and the bytes it moved (in memory for every kernel but the
    /// in-house LDLᵀ on disk).
    pub(crate) fn place(&self) -> FactorPlace {
        self.in_house().map(|f| f.place()).unwrap_or_default()
    }

    /// Whether every solve so far read its factor (one on disk that could not be read back
    /// left NaN).
    ///
    /// # Errors
    /// [`Error::Factor`] naming the factor's directory and the read error.
    pub(crate) fn check_solves(&self) -> Result<()> {
        self.in_house().map_or(Ok(()), RealLdlt::check_solves)
    }

    /// Dimension N.
    pub(crate) fn n(&self) -> usize {
        self.pencil.n()
    }

    /// y ← M x.
    pub(crate) fn mass_mul(&self, x: MatRef<'_, f64>, y: MatMut<'_, f64>) {
        self.pencil.mul_to(Coefficient::Mass, x, y);
    }

    /// X ← (K − σM)⁻¹ X (at most the `rhs` columns of [`Self::new`]).
    pub(crate) fn solve_in_place(&mut self, x: MatMut<'_, f64>) {
        match &mut self.factor {
            Factor::Definite(f) => f.solve_block(x, Par::Seq),
            Factor::Indefinite(f) => f.solve_in_place(x, Par::Seq),
        }
    }

    /// X ← (K − σM)⁻¹ X as [`Self::solve_in_place`], the solves parallel under `par` (but
    /// an interior shift's LBLᵀ solves, which stay sequential).
    pub(crate) fn solve_with(&mut self, x: MatMut<'_, f64>, par: Par) {
        match &mut self.factor {
            Factor::Definite(f) => f.solve_block(x, par),
            Factor::Indefinite(f) => f.solve_in_place(x, par),
        }
    }

    /// y ← S x = (K − σM)⁻¹ M x (ARPACK's mode 3 asks for it without M x).
    #[cfg(feature = "arpack")]
    pub(crate) fn apply(&mut self, x: MatRef<'_, f64>, mut y: MatMut<'_, f64>) {
        self.mass_mul(x, y.as_mut());
        self.solve_in_place(y);
    }
}
