//! faer's sparse LU of A(iω) = K − ω²M + iωD, real (D = 0) or complex.
//!
//! P A Q = L U with Q the COLAMD column order and P the partial-pivoting row order, on the
//! full (both triangles) pattern of the symmetric pencil; the symmetry is not used. The
//! symbolic phase sizes the supernodes from the AᵀA structure, which is fine at 10⁴ DoF but
//! explodes on 3-D pencils at 10⁵ (docs/design.md §3.1), so [`super::Backend::Auto`] uses it only
//! up to [`super::LU_MAX_N`].

use super::backend::{
    solve_split, try_vec, workspace, Analysed, Backend, Factorization, Footprint,
    SymbolicFactorization, Values,
};
use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{
    factorize_symbolic_lu, LuRef, LuSymbolicParams, NumericLu, SymbolicLu,
};
use faer::sparse::linalg::LuError;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::traits::ComplexField;
use faer::{c64, Conj, MatMut, Par};

/// The analysis: COLAMD order and symbolic LU of the full pattern.
pub(super) struct Symbolic {
    sym: SymbolicLu<usize>,
    pattern: SymbolicSparseColMat<usize>,
    /// For each full-pattern entry, the position in the pencil's lower pattern.
    src: Vec<usize>,
    real: bool,
    max_rhs: usize,
}

/// Orders and analyses the full pattern of the pencil (the registry's entry,
/// `factor::analyse`).
pub(super) fn analyse(pencil: &Pencil, max_rhs: usize) -> Result<Analysed> {
    let (symbolic, footprint) = Symbolic::new(pencil, max_rhs)?;
    Ok((Box::new(symbolic), footprint))
}

impl Symbolic {
    /// Orders and analyses the full pattern of the pencil.
    fn new(pencil: &Pencil, max_rhs: usize) -> Result<(Self, Footprint)> {
        let (pattern, src) = pattern::full(pencil);
        let sym = factorize_symbolic_lu(pattern.as_ref(), LuSymbolicParams::default())
            .map_err(|e| Error::Factor(format!("symbolic LU: {e:?}")))?;
        let real = pencil.is_real();
        let footprint = Footprint::full_pattern(real, src.len());
        let symbolic = Symbolic {
            sym,
            pattern,
            src,
            real,
            max_rhs,
        };
        Ok((symbolic, footprint))
    }
}

impl SymbolicFactorization for Symbolic {
    fn backend(&self) -> Backend {
        Backend::FaerLu
    }

    fn numeric(&self, _pencil: &Pencil) -> Result<Box<dyn Factorization + '_>> {
        let (sym, nnz) = (&self.sym, self.src.len());
        let (lu, req) = if self.real {
            // the real path solves Re and Im of a complex block side by side
            let req = sym
                .factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default())
                .or(sym.solve_in_place_scratch::<f64>(2 * self.max_rhs, Par::Seq));
            (Lu::Real(NumericLu::new(), try_vec(nnz)?), req)
        } else {
            let req = sym
                .factorize_numeric_lu_scratch::<c64>(Par::Seq, Default::default())
                .or(sym.solve_in_place_scratch::<c64>(self.max_rhs, Par::Seq));
            (
                Lu::Complex(NumericLu::new(), vec![c64::new(0.0, 0.0); nnz]),
                req,
            )
        };
        Ok(Box::new(Numeric {
            symbolic: self,
            lu,
            stack: workspace(req)?,
        }))
    }
}

impl Symbolic {
    /// Gathers the full-pattern values (`value` of each source position in the lower
    /// pattern) into `vals` and factors them into `lu`.
    fn refactor<T: ComplexField>(
        &self,
        lu: &mut NumericLu<usize, T>,
        vals: &mut [T],
        value: impl Fn(usize) -> T,
        par: Par,
        stack: &mut MemStack,
    ) -> std::result::Result<(), LuError> {
        for (v, &s) in vals.iter_mut().zip(self.src.iter()) {
            *v = value(s);
        }
        let a = SparseColMatRef::new(self.pattern.as_ref(), &*vals);
        self.sym
            .factorize_numeric_lu(lu, a, par, stack, Default::default())
            .map(|_| ())
    }
}

/// The numeric factor and the full-pattern values it is computed from.
enum Lu {
    Real(NumericLu<usize, f64>, Vec<f64>),
    Complex(NumericLu<usize, c64>, Vec<c64>),
}

/// One numeric LU factorization of A(iω), refilled per frequency.
pub(super) struct Numeric<'a> {
    symbolic: &'a Symbolic,
    lu: Lu,
    stack: MemBuffer,
}

impl Factorization for Numeric<'_> {
    fn factor(&mut self, a: &Values<'_>, freq_hz: f64, par: Par) -> Result<()> {
        let stack = MemStack::new(&mut self.stack);
        let res = match &mut self.lu {
            Lu::Real(lu, vals) => self.symbolic.refactor(lu, vals, |s| a.re[s], par, stack),
            Lu::Complex(lu, vals) => {
                let value = |s: usize| c64::new(a.re[s], a.im[s]);
                self.symbolic.refactor(lu, vals, value, par, stack)
            }
        };
        res.map_err(|e| Error::Singular {
            freq_hz,
            detail: format!("sparse LU failed: {e:?}"),
        })
    }

    fn solve(&mut self, rhs: MatMut<'_, c64>, par: Par) {
        let sym = &self.symbolic.sym;
        let stack = MemStack::new(&mut self.stack);
        match &self.lu {
            Lu::Real(lu, _) => {
                let lu = LuRef::new_unchecked(sym, lu);
                solve_split(rhs, |u| {
                    lu.solve_in_place_with_conj(Conj::No, u, par, stack)
                });
            }
            Lu::Complex(lu, _) => {
                LuRef::new_unchecked(sym, lu).solve_in_place_with_conj(Conj::No, rhs, par, stack);
            }
        }
    }

    /// faer's LU reports no pivot statistics.
    fn pivot_ratio(&self) -> f64 {
        f64::NAN
    }
}
