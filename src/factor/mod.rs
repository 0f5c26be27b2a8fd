//! Sparse factorization of the pencil A(iω) = K − ω²M + iωD behind one interface
//! (docs/design.md §3.1).
//!
//! [`Analysis::new`] does the pattern work once per model: ordering and symbolic
//! factorization. [`Analysis::numeric`] allocates one numeric factorization ([`Numeric`]),
//! refilled for every frequency by [`Numeric::factor`] (no pattern work, no allocation after
//! the first use) and used by [`Numeric::solve`].
//!
//! One file per backend ([`Backend`]), each with its own symbolic and numeric type:
//! - `ldlt` — **complex-symmetric LDLᵀ** (default when damped): our supernodal LDLᵀ in c64
//!   (transpose, not adjoint) on faer's symbolic Cholesky and dense kernels, static pivoting;
//! - `lblt` — **faer LBLᵀ** (default for large undamped pencils): faer's supernodal symmetric machinery with intranode
//!   Bunch–Kaufman pivoting; the real N×N pencil when D = 0, otherwise the equivalent real
//!   symmetric 2N×2N form [[Ar, Ai], [Ai, −Ar]] with the unknowns interleaved.
//! - `lu` — **faer LU**: faer's sparse LU (COLAMD) of the full pattern, real or complex. Fine
//!   for small undamped models; it blows up on 3-D pencils at 10⁵ DoF (docs/design.md
//!   §3.1), so [`Backend::Auto`] uses it only up to [`LU_MAX_N`].
//! - `umfpack` — **UMFPACK** (cargo feature `umfpack`), real or complex LU.
//! - `mumps` — **MUMPS** (cargo feature `mumps`), complex symmetric, in core or with its
//!   factors on disk (out of core), in this process or shared by the ranks of `mpirun`.
//!
//! Beside them: `ordering` (AMD, a level-set bisection or METIS nested dissection, whichever
//! fills least, the bisection within 5 %, [`symbolic_cholesky_ordered`]), `cholesky` (the real
//! LLᵀ of K − σM of the eigensolver and the benches' reference, [`reference_cholesky`]),
//! `inertia` (exact eigenvalue counts, [`count_eigenvalues_below`]) and `pattern` (the
//! patterns the backends read).
//!
//! Adding a backend: one file whose `analyse` returns its analysis (a type implementing
//! the private `SymbolicFactorization` trait of `backend`, whose numeric type implements
//! `Factorization`), plus its [`Backend`] variant with its names (`backend`) and its line in
//! the registry [`analyse`].
//!
//! Accuracy is not assumed: the sweep verifies every factorization with a probe solve.

mod backend;
mod cholesky;
mod inertia;
mod lblt;
mod ldlt;
mod lu;
#[cfg(feature = "mumps")]
pub mod mumps;
mod on_disk;
mod ordering;
mod pattern;
mod real_ldlt;
mod refine;
#[cfg(feature = "umfpack")]
pub mod umfpack;

pub use backend::{Backend, Storage, LU_MAX_N};
pub use cholesky::{reference_cholesky, symbolic_cholesky, time_real_factor, RealTiming};
pub use inertia::{count_eigenvalues_below, count_eigenvalues_below_with};
pub use lblt::PivotStats;
pub use ordering::{symbolic_cholesky_ordered, Order, OrderingChoice};
pub use refine::{BACKWARD_ERROR_FLOOR, MAX_REFINEMENTS};

pub(crate) use cholesky::Cholesky;
pub(crate) use inertia::{off_an_eigenfrequency, ShiftedIndefinite};
pub use real_ldlt::FactorPlace;
pub(crate) use real_ldlt::{ComplexLdlt, RealLdlt};

use crate::pencil::Pencil;
use crate::Result;
use backend::{try_vec, Analysed, Factorization, SymbolicFactorization, SymbolicN, Values};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::{c64, MatMut, Par};
use std::sync::Arc;
use std::time::Instant;

/// The registry: the analysis of each backend (after [`Backend::resolved`]).
fn analyse(
    backend: Backend,
    pencil: &Pencil,
    symbolic_n: SymbolicN<'_>,
    max_rhs: usize,
    storage: Storage<'_>,
) -> Result<Analysed> {
    if storage.dir.is_some() && backend != Backend::Mumps {
        return Err(crate::Error::InvalidSetting(format!(
            "out-of-core factors need backend mumps (--backend mumps), not {backend}"
        )));
    }
    match backend {
        Backend::Ldlt => ldlt::analyse(pencil, symbolic_n()?, max_rhs),
        Backend::FaerLblt => lblt::analyse(pencil, symbolic_n()?, max_rhs),
        Backend::FaerLu => lu::analyse(pencil, max_rhs),
        #[cfg(feature = "umfpack")]
        Backend::Umfpack => umfpack::analyse(pencil),
        #[cfg(not(feature = "umfpack"))]
        Backend::Umfpack => Err(crate::Error::InvalidSetting(
            "backend umfpack: this build has no UMFPACK; rebuild with `--features umfpack` \
             (needs libsuitesparse-dev)"
                .into(),
        )),
        #[cfg(feature = "mumps")]
        Backend::Mumps => mumps::analyse(pencil, storage),
        #[cfg(not(feature = "mumps"))]
        Backend::Mumps => Err(crate::Error::InvalidSetting(
            "backend mumps: this build has no MUMPS; rebuild with `--features mumps` \
             (needs libmumps-dev, libopenmpi-dev and libclang-dev)"
                .into(),
        )),
        Backend::Auto => unreachable!("resolved before the registry is asked"),
    }
}

/// Whether a factorization with `backend` is held whole by this process: not when MUMPS
/// shares each factorization over the ranks of `mpirun` ([`mumps::share`]), so that nothing
/// may keep a whole factor in one process (the sweep's shifted Krylov space does).
pub fn held_whole(backend: Backend) -> bool {
    #[cfg(feature = "mumps")]
    if backend == Backend::Mumps {
        return mumps::ranks() == 1;
    }
    let _ = backend;
    true
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
    /// Estimated bytes of one numeric factorization incl. workspace (in memory: out of core,
    /// without the factors on disk), on the rank that needs most when [`Self::ranks`] > 1.
    pub bytes_per_factor: usize,
    /// True when the factors are kept on disk (backend `mumps`).
    pub out_of_core: bool,
    /// The MPI ranks that hold a part of each factorization (backend `mumps` under `mpirun`
    /// after [`mumps::share`]); 1 otherwise.
    pub ranks: usize,
}

/// The once-per-model part of the factorization: ordering and symbolic analysis.
pub struct Analysis {
    symbolic: Box<dyn SymbolicFactorization>,
    /// The LDLᵀ's pivoting fallback (the 2N LBLᵀ), analysed on first use.
    pivoting: std::sync::OnceLock<lblt::Symbolic>,
    max_rhs: usize,
    n: usize,
    real: bool,
    stats: SymbolicStats,
}

impl Analysis {
    /// Orders and analyses the pencil's pattern for `backend`. `max_rhs` is the largest number
    /// of right-hand sides solved at once (sizes the solve workspace).
    ///
    /// # Errors
    /// [`Error::Factor`](crate::Error::Factor) when the analysis fails (allocation, index overflow), or
    /// [`Error::InvalidSetting`](crate::Error::InvalidSetting) for `umfpack` without the feature.
    pub fn new(pencil: &Pencil, backend: Backend, max_rhs: usize) -> Result<Self> {
        Self::with_symbolic(pencil, backend, max_rhs, || {
            Ok(Arc::new(symbolic_cholesky_ordered(pencil)?.0))
        })
    }

    /// As [`Self::new`], with the ordered symbolic Cholesky of the pencil's N×N pattern
    /// supplied by `symbolic_n` (called only by the backends built on it, LBLᵀ): a prepared
    /// body shares its one analysis with the eigensolver this way.
    ///
    /// # Errors
    /// As [`Self::new`].
    pub fn with_symbolic(
        pencil: &Pencil,
        backend: Backend,
        max_rhs: usize,
        symbolic_n: impl FnOnce() -> Result<Arc<SymbolicCholesky<usize>>>,
    ) -> Result<Self> {
        Self::with_storage(pencil, backend, max_rhs, symbolic_n, Storage::IN_CORE)
    }

    /// As [`Self::with_symbolic`], with the factors kept where `storage` says.
    ///
    /// # Errors
    /// As [`Self::new`]; [`Error::InvalidSetting`](crate::Error::InvalidSetting) for a
    /// directory with another backend or one that does not exist.
    pub fn with_storage(
        pencil: &Pencil,
        backend: Backend,
        max_rhs: usize,
        symbolic_n: impl FnOnce() -> Result<Arc<SymbolicCholesky<usize>>>,
        storage: Storage<'_>,
    ) -> Result<Self> {
        let start = Instant::now();
        let n = pencil.n();
        let real = pencil.is_real();
        let (symbolic, footprint) = analyse(
            backend.resolved(n, real),
            pencil,
            Box::new(symbolic_n),
            max_rhs,
            storage,
        )?;
        let (backend, out_of_core, ranks) =
            (symbolic.backend(), symbolic.out_of_core(), symbolic.ranks());
        Ok(Analysis {
            symbolic,
            pivoting: std::sync::OnceLock::new(),
            max_rhs,
            n,
            real,
            stats: SymbolicStats {
                backend,
                real,
                seconds: start.elapsed().as_secs_f64(),
                factor_nnz: footprint.factor_nnz,
                bytes_per_factor: footprint.bytes,
                out_of_core,
                ranks,
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
    /// [`Error::Factor`](crate::Error::Factor) when the workspace cannot be allocated.
    pub fn numeric(&self, pencil: &Pencil) -> Result<Numeric<'_>> {
        let factors = self.symbolic.numeric(pencil)?;
        let mut numeric = Numeric {
            analysis: self,
            factors,
            pivoting: None,
            pivoted: false,
            real: self.real,
            re: Vec::new(),
            im: Vec::new(),
            factored_at: None,
            refine_buffers: refine::Buffers::default(),
        };
        if numeric.factors.reads_arrays() {
            numeric.allocate_values(pencil)?;
        }
        Ok(numeric)
    }

    /// The pivoting factorization the LDLᵀ falls back to (the 2N LBLᵀ on its ordering),
    /// analysed on the first call; `None` for the other backends, which pivot themselves.
    fn pivoting(&self, pencil: &Pencil) -> Result<Option<&lblt::Symbolic>> {
        let Some(structure) = self.symbolic.pivoting_structure() else {
            return Ok(None);
        };
        if self.pivoting.get().is_none() {
            let (fallback, _) = lblt::Symbolic::new(pencil, structure, self.max_rhs)?;
            // another thread may have set it meanwhile: either value is the same analysis
            let _ = self.pivoting.set(fallback);
        }
        Ok(self.pivoting.get())
    }
}

/// One numeric factorization of A(iω), refilled per frequency; borrows its [`Analysis`].
pub struct Numeric<'a> {
    analysis: &'a Analysis,
    factors: Box<dyn Factorization + 'a>,
    /// The LDLᵀ's pivoting fallback, allocated on first use, and whether it holds the
    /// factorization of the current frequency.
    pivoting: Option<Box<dyn Factorization + 'a>>,
    pivoted: bool,
    real: bool,
    /// Values of A(iω) on the pencil's lower pattern (`im` empty on the real path), gathered
    /// for the backends that read arrays and for the supported K; empty otherwise
    /// ([`Values`]).
    re: Vec<f64>,
    im: Vec<f64>,
    factored_at: Option<f64>,
    /// Buffers of [`Self::refine`], reused for every frequency this factorization serves.
    refine_buffers: refine::Buffers<c64>,
}

impl<'a> Numeric<'a> {
    /// Factors A(iω) = K − ω²M + iωD in place. `par` is the parallelism inside the
    /// factorization (use `Par::Seq` when frequencies run in parallel).
    ///
    /// The complex LDLᵀ pivots statically ([`Self::perturbed_pivots`]); its solves then need
    /// [`Self::refine`], and where that is not enough [`Self::factor_with_pivoting`].
    ///
    /// # Errors
    /// [`Error::Singular`](crate::Error::Singular) when a pivot breaks down exactly, [`Error::Factor`](crate::Error::Factor) on backend
    /// failure.
    pub fn factor(&mut self, pencil: &Pencil, omega: f64, par: Par) -> Result<()> {
        self.factored_at = None;
        if self.factors.reads_arrays() {
            self.gather(pencil, omega)?;
        } else {
            self.re.clear();
            self.im.clear();
        }
        self.factor_values(pencil, omega, par)
    }

    /// Allocates the arrays of A(iω)'s values (on the first call).
    fn allocate_values(&mut self, pencil: &Pencil) -> Result<()> {
        if self.re.len() != pencil.nnz() {
            self.re = try_vec(pencil.nnz())?;
            self.im = if self.real {
                Vec::new()
            } else {
                try_vec(pencil.nnz())?
            };
        }
        Ok(())
    }

    /// Gathers A(iω)'s values into `re`/`im`.
    fn gather(&mut self, pencil: &Pencil, omega: f64) -> Result<()> {
        self.allocate_values(pencil)?;
        if self.real {
            pencil.fill_real(omega, &mut self.re);
        } else {
            pencil.fill_complex(omega, &mut self.re, &mut self.im);
        }
        Ok(())
    }

    /// Factors the values of A(iω) at ω (0 for the supported K, then gathered).
    fn factor_values(&mut self, pencil: &Pencil, omega: f64, par: Par) -> Result<()> {
        let freq_hz = omega / (2.0 * std::f64::consts::PI);
        self.pivoted = false;
        let values = Values::new(pencil, omega, &self.re, &self.im);
        self.factors.factor(&values, freq_hz, par)?;
        self.factored_at = Some(omega);
        Ok(())
    }

    /// Factors the current frequency again with the pivoting LBLᵀ of the 2N form, when the
    /// backend is the complex LDLᵀ and it has not done so yet: the sweep's remedy when a
    /// solve stays inaccurate after refinement (growth at a small pivot of the static order).
    /// Returns false when there is nothing else to try: another backend, already pivoted, or
    /// the 2N factor (about twice the LDLᵀ's bytes, allocated on the first call and kept)
    /// would take more than half of the memory available now.
    ///
    /// # Errors
    /// As [`Self::factor`].
    pub fn factor_with_pivoting(&mut self, pencil: &Pencil, par: Par) -> Result<bool> {
        let Some(omega) = self.factored_at else {
            return Ok(false);
        };
        if self.pivoted {
            return Ok(false);
        }
        if self.analysis.symbolic.pivoting_structure().is_none() {
            return Ok(false);
        }
        // the 2N factor holds about twice the LDLᵀ's bytes: not tried unless it fits in half
        // of the memory available now, since two sweep workers may allocate it at once (on the
        // 10⁶-DoF bar two 2N factors beside the workers' LDLᵀ factors do not fit in 24 GB)
        let need = 2 * self.analysis.stats.bytes_per_factor;
        if self.pivoting.is_none() && crate::memory::available_bytes().is_some_and(|a| need > a / 2)
        {
            return Ok(false);
        }
        let Some(symbolic) = self.analysis.pivoting(pencil)? else {
            return Ok(false);
        };
        if self.pivoting.is_none() {
            self.pivoting = Some(SymbolicFactorization::numeric(symbolic, pencil)?);
        }
        // the LBLᵀ reads arrays: gathered now unless they are (the supported K never gets
        // here: it is factored with the LDLᵀ's static pivots or not at all)
        if self.re.is_empty() {
            self.gather(pencil, omega)?;
        }
        let values = Values::new(pencil, omega, &self.re, &self.im);
        let freq_hz = omega / (2.0 * std::f64::consts::PI);
        self.factored_at = None;
        let pivoting = self.pivoting.as_mut().expect("allocated above");
        pivoting.factor(&values, freq_hz, par)?;
        self.pivoted = true;
        self.factored_at = Some(omega);
        Ok(true)
    }

    /// True when the current frequency was factored by the pivoting fallback of the complex
    /// LDLᵀ ([`Self::factor_with_pivoting`]).
    pub fn pivoted(&self) -> bool {
        self.pivoted
    }

    /// Factors K with the rows and columns of the `supports` DoFs replaced by those of a
    /// scaled identity (their off-diagonal entries 0, the diagonal `scale`): the static
    /// stiffness of a free body held by a statically determinate support (docs/design.md
    /// §3.2). With supports on which the rigid modes are independent (V0 restricted to the rows s invertible),
    /// the supported K is non-singular, and for a load b without rigid component the solution
    /// x (x_s = 0) differs from every solution of K x = b by a rigid motion only, which Pᵀ
    /// removes. `supports` must be sorted.
    ///
    /// # Errors
    /// As [`Self::factor`].
    pub fn factor_supported(
        &mut self,
        pencil: &Pencil,
        supports: &[usize],
        scale: f64,
        par: Par,
    ) -> Result<()> {
        self.factored_at = None;
        self.gather(pencil, 0.0)?;
        let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
        let held = |d: usize| supports.binary_search(&d).is_ok();
        for j in 0..pencil.n() {
            for p in cp[j]..cp[j + 1] {
                if held(j) || held(ri[p]) {
                    self.re[p] = if ri[p] == j { scale } else { 0.0 };
                    if let Some(v) = self.im.get_mut(p) {
                        *v = 0.0;
                    }
                }
            }
        }
        self.factor_values(pencil, 0.0, par)
    }

    /// min |pivot| / max |pivot| of the last factorization (1×1 pivots and the eigenvalues of
    /// 2×2 pivots for LBLᵀ; UMFPACK's rcond estimate; NaN for faer LU).
    pub fn pivot_ratio(&self) -> f64 {
        match (&self.pivoting, self.pivoted) {
            (Some(p), true) => p.pivot_ratio(),
            _ => self.factors.pivot_ratio(),
        }
    }

    /// Pivots the last factorization replaced by a static perturbation (the LDLᵀ backend;
    /// 0 for the others, which pivot). Its solves then need the refinement of
    /// [`Self::refine`]; the sweep refines whenever its probe solve shows lost digits.
    pub fn perturbed_pivots(&self) -> usize {
        self.factors.perturbed()
    }

    /// Solves A(iω) X = B in place for a complex block (N × k, k ≤ the analysis' max_rhs + 1).
    pub fn solve(&mut self, rhs: MatMut<'_, c64>, par: Par) {
        debug_assert!(self.factored_at.is_some());
        active(&mut self.factors, &mut self.pivoting, self.pivoted).solve(rhs, par);
    }

    /// Refines a solution `x` of A X = B from [`Self::solve`] with the factored matrix
    /// itself by LAPACK xGERFS's rule: while the componentwise backward error exceeds 4ε
    /// ([`BACKWARD_ERROR_FLOOR`]) and halves, at most [`MAX_REFINEMENTS`] steps. Where that
    /// ends at the step limit, GMRES preconditioned by the factorization goes on
    /// (`refine::gmres`: exact in k + 1 steps on a factor with k perturbed pivots). `b`
    /// writes B into the N × k block it is given, once per step, so the caller need not keep
    /// a copy of B.
    pub fn refine(
        &mut self,
        pencil: &Pencil,
        b: impl Fn(MatMut<'_, c64>),
        x: MatMut<'_, c64>,
        par: Par,
    ) -> Refinement<'_> {
        debug_assert!(self.factored_at.is_some());
        let factors = active(&mut self.factors, &mut self.pivoting, self.pivoted);
        let omega = self.factored_at.unwrap_or(0.0);
        let values = Values::new(pencil, omega, &self.re, &self.im);
        let entry = |p| values.entry(p);
        let a = pattern::Lower {
            pencil,
            entry: &entry,
        };
        let mut x = x;
        let steps = refine::refine(
            a,
            refine::Stop::Componentwise,
            &b,
            x.as_mut(),
            |r| factors.solve(r, par),
            &mut self.refine_buffers,
            par,
        );
        if steps < MAX_REFINEMENTS {
            return Refinement {
                steps,
                gmres_solves: 0,
                backward_errors: Some(self.refine_buffers.column_errors()),
            };
        }
        let (gmres_solves, converged) = refine::gmres(
            a,
            &b,
            x.as_mut(),
            |r| factors.solve(r, par),
            &mut self.refine_buffers,
            par,
        );
        let backward_errors = converged.then(|| {
            b(self.refine_buffers.block(x.nrows(), x.ncols()));
            pattern::symmetric_residual(a, x.as_ref(), true, &mut self.refine_buffers, par);
            self.refine_buffers.column_errors()
        });
        Refinement {
            steps,
            gmres_solves,
            backward_errors,
        }
    }

    /// The componentwise backward error ω = maxᵢ,c |B − A X|ᵢc / (|A||X| + |B|)ᵢc of a
    /// solution `x` of A X = B (docs/design.md §3.1), A the factored matrix: by Oettli and
    /// Prager the smallest ω with (A + ΔA) x = b + Δb, |ΔA| ≤ ω|A|, |Δb| ≤ ω|b| for every
    /// column; about ε for a backward-stable solve. Rows whose denominator is 0 are left
    /// out. `b` writes B into the N × k block it is given. One pass over A's pattern, in the
    /// buffers of [`Self::refine`].
    pub fn backward_error(
        &mut self,
        pencil: &Pencil,
        b: impl Fn(MatMut<'_, c64>),
        x: faer::MatRef<'_, c64>,
        par: Par,
    ) -> f64 {
        debug_assert!(self.factored_at.is_some());
        let omega = self.factored_at.unwrap_or(0.0);
        let values = Values::new(pencil, omega, &self.re, &self.im);
        b(self.refine_buffers.block(x.nrows(), x.ncols()));
        pattern::symmetric_residual(
            pattern::Lower {
                pencil,
                entry: &|p| values.entry(p),
            },
            x,
            true,
            &mut self.refine_buffers,
            par,
        )
    }
}

/// What [`Numeric::refine`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refinement<'a> {
    /// Steps taken (0 when the solution's backward error was already at the floor).
    pub steps: usize,
    /// Solves of the GMRES that took over when refinement ended at its step limit (0 when it
    /// did not).
    pub gmres_solves: usize,
    /// The componentwise backward error of each column of the refined solution
    /// ([`Numeric::backward_error`] of that column, bit for bit), from the residual that ended
    /// the refinement; `None` when refinement and GMRES both ended at their step limits.
    pub backward_errors: Option<&'a [f64]>,
}

/// The factorization of the current frequency: the pivoting fallback when it took the
/// frequency, else the backend's own (borrowing only these fields, so the values of A stay
/// readable beside it).
fn active<'s, 'a>(
    factors: &'s mut Box<dyn Factorization + 'a>,
    pivoting: &'s mut Option<Box<dyn Factorization + 'a>>,
    pivoted: bool,
) -> &'s mut (dyn Factorization + 'a) {
    match pivoting {
        Some(p) if pivoted => p.as_mut(),
        _ => factors.as_mut(),
    }
}

/// How well X solves A(iω) X = B, column by column: the certificate of a response computed
/// without a factorization of A(iω) (docs/design.md §3.10).
#[derive(Clone, Debug, PartialEq)]
pub struct Certificate {
    /// maxᵢ |b − A x|ᵢ / (|A||x| + |b|)ᵢ per column (Oettli–Prager, as
    /// [`Numeric::backward_error`]).
    pub backward_error: Vec<f64>,
    /// ‖b − A x‖₂ / ‖b‖₂ per column (0 for a zero column b with x = 0).
    pub relative_residual: Vec<f64>,
    /// maxᵢ |b − A x|ᵢ / maxᵢ (|A||x| + |b|)ᵢ per column: a bound of the normwise backward
    /// error ‖b − A x‖∞ / (‖A‖∞‖x‖∞ + ‖b‖∞).
    pub normwise_backward_error: Vec<f64>,
}

impl Certificate {
    /// Every column passes: componentwise backward error ≤ `backward`, relative residual
    /// ≤ `relative` or normwise backward error ≤ `normwise`.
    pub fn passes(&self, backward: f64, relative: f64, normwise: f64) -> bool {
        (0..self.backward_error.len()).all(|c| {
            self.backward_error[c] <= backward
                || self.relative_residual[c] <= relative
                || self.normwise_backward_error[c] <= normwise
        })
    }
}

/// The buffers of [`certify`] (about 40 N p bytes for p columns), kept by a caller that
/// certifies many responses of one body: fresh blocks of that size cost page faults and
/// zeroing on every call (on the 10⁶-DoF 3 m bar, p = 9, about a quarter of the time of a
/// response from the shifted Krylov space; docs/design.md §3.10).
#[derive(Default)]
pub struct CertifyBuffers(pattern::ResidualScratch<c64>);

/// The [`Certificate`] of `x` as a solution of A(iω) X = B for the real B `b`: one pass over
/// the pencil's pattern with the exact A(iω) (entries by [`Pencil::value`]), the residual's
/// columns in parallel under `par`, in `buffers`.
pub fn certify(
    pencil: &Pencil,
    omega: f64,
    b: faer::MatRef<'_, f64>,
    x: faer::MatRef<'_, c64>,
    par: Par,
    buffers: &mut CertifyBuffers,
) -> Certificate {
    let scratch = &mut buffers.0;
    let mut block = scratch.block(x.nrows(), x.ncols());
    for c in 0..x.ncols() {
        for (d, &v) in block.as_mut().col_mut(c).iter_mut().zip(b.col(c).iter()) {
            *d = c64::new(v, 0.0);
        }
    }
    pattern::symmetric_residual(
        pattern::Lower {
            pencil,
            entry: &|p| pencil.value(omega, p),
        },
        x,
        true,
        scratch,
        par,
    );
    let backward_error = scratch.column_errors().to_vec();
    let normwise_backward_error = scratch.column_normwise().to_vec();
    let r = scratch.block(x.nrows(), x.ncols());
    let r = r.as_ref();
    let relative_residual = (0..x.ncols())
        .map(|c| {
            let (rn, bn) = (r.col(c).norm_l2(), b.col(c).norm_l2());
            if bn > 0.0 {
                rn / bn
            } else if rn == 0.0 {
                0.0
            } else {
                f64::INFINITY
            }
        })
        .collect();
    Certificate {
        backward_error,
        relative_residual,
        normwise_backward_error,
    }
}
