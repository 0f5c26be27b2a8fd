//! The LDLᵀ of one matrix factored once and solved with many times (docs/design.md §3.1):
//! a shifted or quadratic real pencil, by the in-house supernodal kernel in real arithmetic
//! with L in memory ([`super::ldlt`], left-looking) or in a file when it does not fit the
//! memory budget ([`super::on_disk`], multifrontal) ([`RealLdlt`]); the quadratic pencil of a
//! body with structural damping, by the same kernel in complex arithmetic, L in memory
//! ([`ComplexLdlt`]).

use super::backend::Storage;
use super::ldlt::{in_blocks, Numeric, Pivots, Symbolic};
use super::on_disk;
use crate::pencil::{solve_through, Congruent, Pencil};
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::{c64, MatMut, Par};
use std::path::Path;
use std::sync::Arc;

/// The supernodal LDLᵀ in real arithmetic: P A Pᵀ = L D Lᵀ of a real symmetric A with
/// values on the pencil's lower pattern (K − σM, K + s₀D + s₀²M), with static pivots. For a
/// positive definite A every pivot is positive and this is a Cholesky factorization
/// (L D^{1/2}); the factor owns its analysis, so it lives as long as its user. L is in memory
/// (the left-looking factorization) or, when it does not fit the budget, in a file
/// ([`on_disk`], multifrontal).
pub(crate) struct RealLdlt(Place);

enum Place {
    InCore(Box<Numeric<Box<Symbolic>, f64>>),
    OnDisk(Box<on_disk::OnDisk>),
}

/// The pivots of one [`RealLdlt`] factorization.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RealPivots {
    /// Pivots below 0: by Sylvester's law the number of negative eigenvalues of A when none
    /// was perturbed.
    pub(crate) negative: usize,
    /// Pivots of magnitude below ε·max|aᵢⱼ|, replaced by ±ε·max|aᵢⱼ| (A singular to working
    /// precision).
    pub(crate) perturbed: usize,
    /// min |dᵢ| / max |dᵢ|.
    pub(crate) ratio: f64,
}

/// Where a [`RealLdlt`]'s L is and what it moved.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FactorPlace {
    /// L is in a file.
    pub on_disk: bool,
    /// Bytes of L written to the file so far.
    pub written: u64,
    /// Bytes of L read from the file so far.
    pub read: u64,
}

impl RealLdlt {
    /// The analysis on `sym` (the pencil's [`super::symbolic_cholesky`]) and the factor's
    /// storage, for solves of up to `rhs` columns at once; `None` when `sym` has no
    /// supernodes (a pattern without off-diagonal entries). L is kept in memory when the
    /// in-core factorization fits `storage.budget` and no `storage.dir` is given, else in an
    /// unnamed file in `storage.dir` (the temporary directory by default).
    ///
    /// # Errors
    /// [`Error::Factor`] when the analysis finds an entry outside L's pattern or memory is
    /// short; [`Error::Io`] when no file can be made for a factor on disk.
    pub(crate) fn new(
        pencil: &Pencil,
        sym: Arc<SymbolicCholesky<usize>>,
        rhs: usize,
        storage: Storage<'_>,
    ) -> Result<Option<Self>> {
        if !matches!(sym.raw(), SymbolicCholeskyRaw::Supernodal(_)) {
            return Ok(None);
        }
        let rhs = rhs.max(1);
        let (symbolic, _) = Symbolic::new(pencil, sym, rhs)?;
        symbolic.prepare(pencil)?;
        let place = if storage.dir.is_none() && symbolic.real_bytes(rhs) <= storage.budget {
            Place::InCore(Box::new(Numeric::new(Box::new(symbolic))?))
        } else {
            let plan = on_disk::Plan::new(&symbolic);
            let dir = storage
                .dir
                .map_or_else(std::env::temp_dir, Path::to_path_buf);
            Place::OnDisk(Box::new(on_disk::OnDisk::new(
                Box::new(symbolic),
                plan,
                &dir,
                rhs,
            )?))
        };
        Ok(Some(RealLdlt(place)))
    }

    /// Factors the matrix with values `vals` on the pencil's lower pattern, pivots below
    /// ε·max|aᵢⱼ| perturbed (counted, not repeated with a larger threshold: a caller that
    /// needs a definite or exactly counted A refuses a perturbed factor).
    ///
    /// # Errors
    /// [`Error::Factor`] on a non-finite or all-zero pivot or short memory; [`Error::Io`]
    /// when a factor on disk cannot be written.
    pub(crate) fn factor(&mut self, vals: &[f64], par: Par) -> Result<RealPivots> {
        let amax = vals.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let a = |p: usize| vals[p];
        let tau = f64::EPSILON * amax;
        let pivots = match &mut self.0 {
            Place::InCore(f) => f.factor_once(&a, tau, par)?,
            Place::OnDisk(f) => f.factor(&a, tau, par)?,
        };
        finite(&pivots, "real")?;
        Ok(RealPivots {
            negative: pivots.negative,
            perturbed: pivots.perturbed,
            ratio: pivots.lo / pivots.hi,
        })
    }

    /// Entries of L.
    pub(crate) fn factor_nnz(&self) -> usize {
        match &self.0 {
            Place::InCore(f) => f.l.len(),
            Place::OnDisk(f) => f.factor_nnz(),
        }
    }

    /// Where L is, and the bytes it moved.
    pub(crate) fn place(&self) -> FactorPlace {
        match &self.0 {
            Place::InCore(_) => FactorPlace::default(),
            Place::OnDisk(f) => FactorPlace {
                on_disk: true,
                written: f.written,
                read: f.read,
            },
        }
    }

    /// X ← A⁻¹X in place, in blocks of the `rhs` columns of [`Self::new`]. A factor on disk
    /// that cannot be read leaves X NaN and keeps the error for [`Self::check_solves`].
    pub(crate) fn solve(&mut self, x: MatMut<'_, f64>, par: Par) {
        match &mut self.0 {
            Place::InCore(f) => f.solve_all(x, par),
            Place::OnDisk(f) => {
                let width = f.width();
                in_blocks(x, width, |b| f.solve_block(b, par));
            }
        }
    }

    /// Whether every solve so far read its factor.
    ///
    /// # Errors
    /// [`Error::Factor`] naming the directory and the read error of a factor on disk that
    /// could not be read back (those solutions are NaN).
    pub(crate) fn check_solves(&self) -> Result<()> {
        match &self.0 {
            Place::OnDisk(f) => f.failure().map_or(Ok(()), Err),
            Place::InCore(_) => Ok(()),
        }
    }
}

/// A factorization's pivots are finite and not all zero.
fn finite(pivots: &Pivots, arithmetic: &str) -> Result<()> {
    if pivots.hi.is_finite() && pivots.hi > 0.0 {
        Ok(())
    } else {
        Err(Error::Factor(format!(
            "the {arithmetic} LDLᵀ factorization met a non-finite or all-zero pivot (NaN in the \
             model?)"
        )))
    }
}

/// The in-house supernodal LDLᵀ in complex arithmetic of a complex symmetric A = R + iS
/// given on the pencil's lower pattern: the linearized space's K₀ = K + iH + s₀D + s₀²M of a
/// body with structural damping (docs/design.md §3.13), whose real part is positive definite,
/// so that every pivot exists without pivoting. L is in memory: twice the real factor's
/// bytes.
pub(crate) struct ComplexLdlt {
    numeric: Box<Numeric<Box<Symbolic>, c64>>,
    /// The coupling its solves go through ([`Pencil::factored`]).
    coupling: Option<Arc<Congruent>>,
}

impl ComplexLdlt {
    /// The analysis on `sym` (the pencil's [`super::symbolic_cholesky`]), for solves of up
    /// to `rhs` columns at once; `None` when `sym` has no supernodes.
    ///
    /// # Errors
    /// [`Error::Factor`] as [`RealLdlt::new`], and when the factor and its buffers would take
    /// more than `budget` bytes.
    pub(crate) fn new(
        pencil: &Pencil,
        sym: Arc<SymbolicCholesky<usize>>,
        rhs: usize,
        budget: usize,
    ) -> Result<Option<Self>> {
        if !matches!(sym.raw(), SymbolicCholeskyRaw::Supernodal(_)) {
            return Ok(None);
        }
        let coupling = pencil.coupling();
        let pencil = pencil.factored();
        let rhs = rhs.max(1);
        let (symbolic, _) = Symbolic::new(pencil, sym, rhs)?;
        let bytes = 2 * symbolic.real_bytes(rhs);
        if bytes > budget {
            return Err(Error::Factor(format!(
                "the complex factor would take {:.2} GB, more than the {:.2} GB the memory \
                 budget leaves",
                bytes as f64 / 1e9,
                budget as f64 / 1e9
            )));
        }
        symbolic.prepare(pencil)?;
        Ok(Some(ComplexLdlt {
            numeric: Box::new(Numeric::new(Box::new(symbolic))?),
            coupling,
        }))
    }

    /// Factors A = R + iS, the values `re` and `im` on the lower pattern of
    /// [`Pencil::factored`]; returns
    /// the pivots below ε·max|aᵢⱼ|, perturbed to it (the caller refuses such a factor).
    ///
    /// # Errors
    /// [`Error::Factor`] on a non-finite or all-zero pivot or short memory.
    pub(crate) fn factor(&mut self, re: &[f64], im: &[f64], par: Par) -> Result<usize> {
        let amax = re
            .iter()
            .zip(im)
            .fold(0.0f64, |m, (r, i)| m.max(r.hypot(*i)));
        let a = |p: usize| c64::new(re[p], im[p]);
        let pivots = self.numeric.factor_once(&a, f64::EPSILON * amax, par)?;
        finite(&pivots, "complex")?;
        Ok(pivots.perturbed)
    }

    /// X ← A⁻¹X in place (through the coupling: A⁻¹ = S A₁⁻¹ Sᵀ, [`Pencil::factored`]).
    pub(crate) fn solve(&mut self, x: MatMut<'_, c64>, par: Par) {
        let numeric = &mut self.numeric;
        solve_through(self.coupling.as_deref(), x, |x| numeric.solve_all(x, par));
    }
}
