//! Real sparse Cholesky factorization of a symmetric positive definite matrix on the pencil's
//! pattern and fill-reducing order (docs/design.md §3.1, §3.6).
//!
//! For σ below the spectrum of K φ = λ M φ (σ < 0 with M positive definite and K positive
//! semi-definite), K − σM is symmetric positive definite, even for a free body, so it has a
//! Cholesky factor P (K − σM) Pᵀ = L Lᵀ; so have K + s₀D + s₀²M (s₀ > 0, D positive
//! semi-definite) and a held stiffness K_ii. Its users ([`Cholesky`]: factor once, solve in
//! place per block): the eigensolver's shift-invert operator (K − σM)⁻¹ M, the shifted and
//! linearized spaces, Craig–Bampton's constraint modes. The kernel is the in-house
//! supernodal LDLᵀ in real arithmetic; the benches' reference ([`reference_cholesky`]) times
//! it beside faer's LLᵀ on the same matrix, the arithmetic floor the complex factorizations
//! of A(iω) are compared with.
//!
//! [`symbolic_cholesky`] is the ordered (AMD, level-set bisection or nested dissection,
//! `ordering`) symbolic analysis of the pencil's N×N lower pattern. It is shared: the LBLᵀ
//! backend factors the real pencil on it and expands its order pairwise for the 2N form, and
//! the inertia count factors K − σM on it.

use super::backend::{try_vec, workspace, Storage};
use super::pattern;
use super::real_ldlt::{FactorPlace, RealLdlt};
use crate::pencil::{solve_through, Congruent, Pencil};
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
    super::ordering::symbolic_cholesky_ordered(pencil.factored()).map(|(sym, _)| sym)
}

/// A numeric factor of a real symmetric positive definite matrix on the pencil's pattern
/// (K − σM below the spectrum, K + s₀D + s₀²M, a held K_ii): allocate once
/// ([`Cholesky::with_rhs`]), factor ([`Cholesky::factor`]), solve in place
/// ([`Cholesky::solve_block`], a block of columns at a time).
///
/// The kernel is the in-house supernodal LDLᵀ in real arithmetic (`ldlt`, every pivot
/// required positive, none perturbed: then L D^{1/2} is the Cholesky factor), faster than
/// faer's LLᵀ on every body measured (docs/performance.md); a pattern without off-diagonal
/// entries, which has no supernodes, takes faer's LLᵀ.
pub(crate) struct Cholesky {
    kernel: Kernel,
    /// The coupling its solves go through ([`Pencil::factored`]).
    coupling: Option<Arc<Congruent>>,
}

enum Kernel {
    InHouse(Box<RealLdlt>),
    Faer {
        sym: Arc<SymbolicCholesky<usize>>,
        l: Vec<f64>,
        stack: MemBuffer,
    },
}

impl Cholesky {
    /// Allocates the factor on the analysis `sym` of the pencil's pattern and the workspace
    /// of a factorization with parallelism `par` and of solves of blocks of up to `rhs`
    /// columns ([`Self::solve_block`]).
    ///
    /// # Errors
    /// [`Error::Factor`] when the memory cannot be allocated.
    pub(crate) fn with_rhs(
        pencil: &Pencil,
        sym: Arc<SymbolicCholesky<usize>>,
        par: Par,
        rhs: usize,
        storage: Storage<'_>,
    ) -> Result<Self> {
        let kernel = match RealLdlt::new(pencil.factored(), sym.clone(), rhs, storage)? {
            Some(f) => Kernel::InHouse(Box::new(f)),
            None => Self::faer(sym, par, rhs)?,
        };
        Ok(Cholesky {
            kernel,
            coupling: pencil.coupling(),
        })
    }

    /// faer's LLᵀ on `sym` (the benches' reference, and a pattern without supernodes).
    fn faer(sym: Arc<SymbolicCholesky<usize>>, par: Par, rhs: usize) -> Result<Kernel> {
        let l = try_vec(sym.len_val())?;
        let stack = workspace(
            sym.factorize_numeric_llt_scratch::<f64>(par, Default::default())
                .or(sym.solve_in_place_scratch::<f64>(rhs.max(1), par)),
        )?;
        Ok(Kernel::Faer { sym, l, stack })
    }

    /// Entries of the factor L.
    pub(crate) fn factor_nnz(&self) -> usize {
        match &self.kernel {
            Kernel::InHouse(f) => f.factor_nnz(),
            Kernel::Faer { l, .. } => l.len(),
        }
    }

    /// The in-house factor, when it is the kernel.
    pub(crate) fn in_house(&self) -> Option<&RealLdlt> {
        match &self.kernel {
            Kernel::InHouse(f) => Some(f),
            Kernel::Faer { .. } => None,
        }
    }

    /// Factors K − σM.
    ///
    /// # Errors
    /// As [`Self::factor_values`].
    pub(crate) fn factor(&mut self, pencil: &Pencil, sigma: f64, par: Par) -> Result<()> {
        let mut vals = try_vec(pencil.factored().nnz())?;
        pencil.factored().fill_shifted(sigma, &mut vals);
        self.factor_values(pencil, &vals, par)
    }

    /// Factors the real matrix with the values `vals` on the lower pattern of
    /// [`Pencil::factored`] (e.g. K + s₀D + s₀²M, [`Pencil::fill_quadratic`]).
    ///
    /// # Errors
    /// [`Error::Factor`] when a pivot is not positive (the matrix is not positive definite,
    /// or singular to working precision) or memory is short.
    pub(crate) fn factor_values(&mut self, pencil: &Pencil, vals: &[f64], par: Par) -> Result<()> {
        match &mut self.kernel {
            Kernel::InHouse(f) => {
                let pivots = f.factor(vals, par)?;
                if pivots.negative + pivots.perturbed > 0 {
                    return Err(Error::Factor(format!(
                        "{} negative and {} zero pivots",
                        pivots.negative, pivots.perturbed
                    )));
                }
            }
            Kernel::Faer { sym, l, stack } => {
                sym.factorize_numeric_llt(
                    l,
                    SparseColMatRef::new(pattern::lower(pencil.factored()), vals),
                    Side::Lower,
                    Default::default(),
                    par,
                    MemStack::new(stack),
                    Default::default(),
                )
                .map_err(|e: LltError| Error::Factor(format!("faer's LLᵀ: {e:?}")))?;
            }
        }
        Ok(())
    }

    /// X ← A⁻¹ X for a block of at most the `rhs` columns of [`Self::with_rhs`] (through the
    /// coupling: A⁻¹ = S A₁⁻¹ Sᵀ, [`Pencil::factored`]).
    pub(crate) fn solve_block(&mut self, x: MatMut<'_, f64>, par: Par) {
        let kernel = &mut self.kernel;
        solve_through(self.coupling.as_deref(), x, |x| match kernel {
            Kernel::InHouse(f) => f.solve(x, par),
            Kernel::Faer { sym, l, stack } => {
                LltRef::new(sym, l).solve_in_place_with_conj(Conj::No, x, par, MemStack::new(stack))
            }
        })
    }
}

/// The references of the benches: a real factorization of K + σM (σ = (2π·1 Hz)², so that a
/// free body's K becomes definite) on the pencil's ordered pattern, by faer's sparse LLᵀ and by
/// the in-house supernodal LDLᵀ in real arithmetic (`ldlt`, the kernel of the complex
/// factorization), one thread each. Returns (nnz(L), faer's seconds, the in-house seconds) of
/// the numeric factorizations — the arithmetic floor a complex factorization of the same
/// pattern is compared with (4× the flops in complex arithmetic).
///
/// # Errors
/// [`Error::Factor`] when the analysis or a factorization fails, or the in-house factor finds
/// K + σM not positive definite.
pub fn reference_cholesky(pencil: &Pencil) -> Result<(usize, f64, f64)> {
    let pencil = pencil.factored();
    let sym = Arc::new(symbolic_cholesky(pencil)?);
    let nnz = sym.len_val();
    let sigma = -(2.0 * std::f64::consts::PI).powi(2);
    let mut vals = try_vec(pencil.nnz())?;
    pencil.fill_shifted(sigma, &mut vals);
    let time = |mut f: Cholesky| {
        let t = Instant::now();
        f.factor_values(pencil, &vals, Par::Seq)
            .map_err(|e| Error::Factor(format!("reference factorization of K + σM: {e}")))?;
        Ok::<f64, Error>(t.elapsed().as_secs_f64())
    };
    let alone = |kernel| Cholesky {
        kernel,
        coupling: None,
    };
    let faer_s = time(alone(Cholesky::faer(sym.clone(), Par::Seq, 1)?))?;
    let in_house_s = match RealLdlt::new(pencil, sym, 1, Storage::IN_CORE)? {
        Some(f) => time(alone(Kernel::InHouse(Box::new(f))))?,
        None => f64::NAN,
    };
    Ok((nnz, faer_s, in_house_s))
}

/// One real factorization and block solve measured ([`time_real_factor`]).
#[derive(Clone, Copy, Debug)]
pub struct RealTiming {
    /// Entries of L.
    pub factor_nnz: usize,
    /// Seconds of the numeric factorization.
    pub factor_s: f64,
    /// Seconds of one solve of `rhs` columns.
    pub solve_s: f64,
    /// Negative pivots: the eigenvalues below σ (Sylvester) when none was perturbed.
    pub negative: usize,
    /// Pivots replaced by ±ε·max|aᵢⱼ| (the matrix singular to working precision).
    pub perturbed: usize,
    /// Where L was and the bytes it moved.
    pub place: FactorPlace,
}

/// Times the in-house real LDLᵀ of K − σM kept where `storage` says, on `par`: its
/// factorization and one solve of `rhs` columns (`sparsemor bench real`: σ = −(2π·1 Hz)², a
/// positive definite matrix as [`reference_cholesky`]'s, in memory and on disk, and σ at the
/// band's top, the indefinite matrix whose inertia counts the band's modes, §3.10).
///
/// # Errors
/// [`Error::Factor`] when the analysis or the factorization fails or the pattern has no
/// supernodes; [`Error::Io`] when a factor on disk cannot be written or read.
pub fn time_real_factor(
    pencil: &Pencil,
    sym: Arc<SymbolicCholesky<usize>>,
    sigma: f64,
    storage: Storage<'_>,
    rhs: usize,
    par: Par,
) -> Result<RealTiming> {
    let pencil = pencil.factored();
    let mut vals = try_vec(pencil.nnz())?;
    pencil.fill_shifted(sigma, &mut vals);
    let mut f = RealLdlt::new(pencil, sym, rhs, storage)?
        .ok_or_else(|| Error::Factor("a pattern without supernodes".into()))?;
    let t = Instant::now();
    let pivots = f.factor(&vals, par)?;
    let factor_s = t.elapsed().as_secs_f64();
    drop(vals);
    let mut x = faer::Mat::<f64>::from_fn(pencil.n(), rhs, |i, j| ((i + 3 * j) % 7) as f64 - 3.0);
    let t = Instant::now();
    f.solve(x.as_mut(), par);
    let solve_s = t.elapsed().as_secs_f64();
    f.check_solves()?;
    Ok(RealTiming {
        factor_nnz: f.factor_nnz(),
        factor_s,
        solve_s,
        negative: pivots.negative,
        perturbed: pivots.perturbed,
        place: f.place(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::factor::inertia::ShiftedIndefinite;
    use crate::fe::{assemble, BoxSpec};
    use crate::model::{Damping, Model};
    use faer::Mat;

    /// A free steel bar of 2 × 3 × 30 hex8 elements (N = 1116): supernodal.
    fn bar_pencil() -> Pencil {
        let body = assemble(&BoxSpec {
            elements: [2, 3, 30],
            ..BoxSpec::paper_bar()
        })
        .unwrap();
        let model = Model::new(
            "bar".into(),
            body.mass,
            body.stiffness,
            Damping::None,
            None,
            3,
        )
        .unwrap()
        .0;
        Pencil::new(&model)
    }

    /// The worst column's bound maxᵢ |r|ᵢ / maxᵢ (|A||x| + |b|)ᵢ of the normwise backward
    /// error of x as a solution of (K − σM)x = b ([`pattern::symmetric_residual`]).
    fn backward_error(pencil: &Pencil, sigma: f64, x: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let mut vals = vec![0.0; pencil.nnz()];
        pencil.fill_shifted(sigma, &mut vals);
        let mut scratch = pattern::ResidualScratch::<f64>::default();
        scratch.block(b.nrows(), b.ncols()).copy_from(b);
        let entry = |p: usize| vals[p];
        let a = pattern::Lower {
            pencil,
            entry: &entry,
        };
        pattern::symmetric_residual(a, x.as_ref(), true, &mut scratch, Par::Seq);
        scratch.column_normwise().iter().fold(0.0, |m, &e| m.max(e))
    }

    /// L in memory, and in a file of the temporary directory (the multifrontal factorization
    /// of `factor::on_disk`, forced by a zero budget).
    fn places() -> [Storage<'static>; 2] {
        [
            Storage::IN_CORE,
            Storage {
                dir: None,
                budget: 0,
            },
        ]
    }

    /// The in-house real LDLᵀ (the supernodal path; 1 and 2 threads, in blocks of 3 columns;
    /// L in memory and on disk) solves K − σM below the spectrum to a normwise backward error
    /// of a few ε, as faer's LLᵀ does, with every pivot positive; the second factorization of
    /// the same factor (its work buffers freed after the first) solves as well, and the
    /// factor on disk solves as the one in memory to rounding.
    #[test]
    fn in_house_ldlt_solves_like_faer() {
        let pencil = bar_pencil();
        let sym = Arc::new(symbolic_cholesky(&pencil).unwrap());
        let sigma = -(2.0 * std::f64::consts::PI * 50.0).powi(2);
        let mut vals = vec![0.0; pencil.nnz()];
        pencil.fill_shifted(sigma, &mut vals);
        let b = Mat::<f64>::from_fn(pencil.n(), 5, |i, j| ((i * 7 + j * 13) % 11) as f64 - 5.0);
        let mut reference = Cholesky {
            kernel: Cholesky::faer(sym.clone(), Par::Seq, 5).unwrap(),
            coupling: None,
        };
        reference.factor(&pencil, sigma, Par::Seq).unwrap();
        let mut y = b.clone();
        reference.solve_block(y.as_mut(), Par::Seq);
        let ey = backward_error(&pencil, sigma, &y, &b);
        let mut solutions = Vec::new();
        for storage in places() {
            let mut f = RealLdlt::new(&pencil, sym.clone(), 3, storage)
                .unwrap()
                .expect("the bar is supernodal");
            for par in [Par::Seq, Par::rayon(2)] {
                let pivots = f.factor(&vals, par).unwrap();
                assert_eq!((pivots.negative, pivots.perturbed), (0, 0));
                let mut x = b.clone();
                f.solve(x.as_mut(), par);
                let ex = backward_error(&pencil, sigma, &x, &b);
                assert!(
                    ex <= 1e-15 && ex <= 10.0 * ey,
                    "in-house {ex:.1e}, faer {ey:.1e}"
                );
                solutions.push(x);
            }
            f.check_solves().unwrap();
            let place = f.place();
            let bytes = 8 * f.factor_nnz() as u64;
            match storage.budget {
                0 => {
                    // written by both factorizations; each of the 4 block solves (5 columns in
                    // blocks of 3, twice) reads L forward and back, but for the chunk it
                    // turns on
                    assert!(place.on_disk);
                    assert_eq!(place.written, 2 * bytes);
                    assert!(
                        place.read > 6 * bytes && place.read < 8 * bytes,
                        "{} of {bytes} bytes read",
                        place.read
                    );
                }
                _ => assert_eq!(place, FactorPlace::default()),
            }
        }
        // in memory the thread count does not change the solution; on disk it differs from
        // it by rounding, as faer's does (K − σM of a free bar shifted by only (2π·50 Hz)²
        // is ill-conditioned)
        let rounding = (&y - &solutions[0]).norm_max();
        assert_eq!(solutions[1], solutions[0]);
        for x in &solutions[2..] {
            let d = (x - &solutions[0]).norm_max();
            assert!(d <= 10.0 * rounding, "{d:.1e}, faer's {rounding:.1e}");
        }
    }

    /// Its negative pivots count the eigenvalues below an interior shift exactly (Sylvester),
    /// as faer's Bunch–Kaufman LBLᵀ does, on one and two threads; the interior-shift factor
    /// keeps it (its probe solve passes).
    #[test]
    fn negative_pivots_count_the_eigenvalues_below() {
        let pencil = bar_pencil();
        let sym = Arc::new(symbolic_cholesky(&pencil).unwrap());
        let mut lblt = crate::factor::lblt::Factor::new(&sym, 1).unwrap();
        let [mut f, mut on_disk] =
            places().map(|s| RealLdlt::new(&pencil, sym.clone(), 1, s).unwrap().unwrap());
        for hz in [500.0, 3000.0, 9000.0] {
            let sigma = (2.0 * std::f64::consts::PI * hz).powi(2);
            let mut vals = vec![0.0; pencil.nnz()];
            pencil.fill_shifted(sigma, &mut vals);
            let a = SparseColMatRef::new(pattern::lower(&pencil), &vals);
            let pivoted = lblt.factor(&sym, a, Par::Seq).negative;
            assert!(pivoted >= 6, "{hz} Hz: above the rigid modes");
            for par in [Par::Seq, Par::rayon(2)] {
                for f in [&mut f, &mut on_disk] {
                    let pivots = f.factor(&vals, par).unwrap();
                    assert_eq!(pivots.perturbed, 0);
                    assert_eq!(pivots.negative, pivoted, "{hz} Hz");
                }
            }
            let counted = crate::pool::with_pool(2, || {
                ShiftedIndefinite::new(
                    sym.clone(),
                    &pencil,
                    sigma,
                    1,
                    Par::rayon(2),
                    Storage::IN_CORE,
                )
                .map(|f| (f.below(), f.max_l()))
            })
            .unwrap()
            .unwrap();
            assert_eq!(counted, (pivoted, 0.0), "{hz} Hz: the static pivots kept");
        }
    }
}
