//! Partial eigenpairs K φ = λ M φ — only the ones needed (docs/design.md §3.6).
//!
//! Entry point: [`eigenpairs`]. Both backends ([`EigenBackend`]) iterate on the same
//! shift-invert operator S = (K − σM)⁻¹ M with σ < 0: S is self-adjoint in the M-inner
//! product ⟨x, y⟩_M = xᵀMy, and K − σM is symmetric positive definite even for a free body,
//! so it is factored once by a sparse Cholesky (faer, AMD ordering). The eigenvalues
//! θ = 1/(λ − σ) of S are largest for the λ closest to σ, i.e. the lowest modes (rigid modes
//! first). The backends differ only in the iteration:
//!
//! - [`EigenBackend::Krylov`] (default, pure Rust): Krylov–Schur with thick restart and full
//!   M-orthogonalization (module `krylov`).
//! - [`EigenBackend::Arpack`] (cargo feature `arpack`): ARPACK's implicitly restarted Lanczos
//!   `dsaupd`/`dseupd` in mode 3 (shift-invert, generalized, `bmat = 'G'`, `which = 'LM'`) —
//!   the reference implementation.
//!
//! The factorization, the mode count, and the post-processing (ascending order, residuals,
//! rigid count) are shared here, so the backends cannot disagree on anything but the
//! iteration itself.
//!
//! Why our own Krylov–Schur and not faer's `partial_self_adjoint_eigen`: faer's routine works
//! in the Euclidean inner product, so it would need the Cholesky factor of M as well
//! (L⁻¹ (K − σM)⁻¹ L⁻ᵀ) — a second sparse factorization and 2 extra triangular solves per
//! step — whereas the M-inner product needs only a sparse product with M. Memory:
//! O(nnz(L) + N·m) with m = the Krylov dimension.
//!
//! "All modes up to f" is counted, not guessed: [`crate::factor::count_eigenvalues_below`]
//! gives the number of eigenvalues below (2πf)² from the inertia of K − (2πf)²M (on the same
//! symbolic analysis as the Cholesky of K − σM: the pattern is analysed once).
//!
//! Rigid modes: on a free body with nodes ([`crate::rigid::RigidBody::detect`]) a mode is rigid when most of
//! its M-norm lies in the span of the rigid-body modes V0 (the M-projection onto span V0 has
//! M-norm² ≥ ½; it is ≈ 1 for rigid and ≈ 0 for elastic modes). Without V0 the fallback is
//! |λ| ≤ [`RIGID_RTOL`] · max_i K_ii/M_ii (a scale of the largest eigenvalue) — which cannot
//! separate the rigid modes from the first elastic ones on long, finely meshed bodies, where
//! λ_1 / λ_max is below 10⁻¹⁰.

#[cfg(feature = "arpack")]
mod arpack;
mod krylov;

use crate::body::Body;
use crate::factor::{count_eigenvalues_below_with, Cholesky};
use crate::model::Model;
use crate::pencil::Pencil;
use crate::sparse::mul_dense;
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::linalg::matmul::sparse_dense_matmul;
use faer::sparse::SparseColMatRef;
use faer::{Accum, Mat, MatMut, MatRef, Par, Side};
use std::sync::Arc;
use std::time::Instant;

/// |λ| ≤ RIGID_RTOL · max_i K_ii/M_ii marks a rigid-body mode when the model gives no rigid
/// modes V0 (see the module doc).
pub const RIGID_RTOL: f64 = 1e-10;

/// Which eigenpairs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Request {
    /// The c lowest modes, rigid ones included.
    Lowest(usize),
    /// Every mode with frequency ≤ f_hi (Hz), counted exactly by inertia.
    UpTo(f64),
}

/// Which iteration computes the eigenpairs (the factorization is the same for both).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EigenBackend {
    /// Our Krylov–Schur in the M-inner product (pure Rust, always available).
    #[default]
    Krylov,
    /// ARPACK `dsaupd`/`dseupd`, mode 3; needs the cargo feature `arpack` (libarpack2-dev).
    Arpack,
}

impl std::fmt::Display for EigenBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EigenBackend::Krylov => "krylov",
            EigenBackend::Arpack => "arpack",
        })
    }
}

/// Settings of the eigensolver.
#[derive(Clone, Debug)]
pub struct EigenOptions {
    /// Shift σ < 0; `None` = −0.01·(2π f_hi)² with f_hi the bound of [`Request::UpTo`], or
    /// [`Self::band_end_hz`] for [`Request::Lowest`].
    pub sigma: Option<f64>,
    /// The frequency scale f_hi (Hz) of the default shift for [`Request::Lowest`]: the end of
    /// the scene's band, where the wanted modes lie below; `None` = 1 Hz.
    pub band_end_hz: Option<f64>,
    /// Convergence: Ritz residual ≤ tol · θ (ARPACK: its `tol`, the same criterion).
    pub tol: f64,
    /// Krylov dimension (ARPACK: `ncv`); `None` = max(2·count + 20, 40), capped at N.
    pub krylov_dim: Option<usize>,
    /// Restart limit (ARPACK: `iparam(3)`, the maximum number of Arnoldi update iterations).
    pub max_restarts: usize,
    /// The iteration.
    pub backend: EigenBackend,
}

impl EigenOptions {
    /// The defaults with the shift scale of a scene band ending at `band_end_hz`.
    pub fn for_band(band_end_hz: f64) -> Self {
        EigenOptions {
            band_end_hz: Some(band_end_hz),
            ..Default::default()
        }
    }
}

impl Default for EigenOptions {
    fn default() -> Self {
        EigenOptions {
            sigma: None,
            band_end_hz: None,
            tol: 1e-12,
            krylov_dim: None,
            max_restarts: 200,
            backend: EigenBackend::Krylov,
        }
    }
}

/// What the eigensolver did.
#[derive(Clone, Debug, Default)]
pub struct EigenStats {
    /// The iteration used.
    pub backend: EigenBackend,
    /// Cholesky of K − σM (symbolic + numeric), s.
    pub factor_s: f64,
    /// Iterations, s.
    pub iterate_s: f64,
    /// Inertia count (for [`Request::UpTo`]), s.
    pub count_s: f64,
    /// Applications of S.
    pub solves: usize,
    /// Restarts (ARPACK: implicit restarts, its update iterations − 1).
    pub restarts: usize,
    /// Krylov dimension used.
    pub krylov_dim: usize,
    /// Shift used.
    pub sigma: f64,
    /// nnz of the Cholesky factor.
    pub factor_nnz: usize,
}

/// Eigenpairs in ascending order of λ.
#[derive(Clone, Debug)]
pub struct Modes {
    /// Eigenvalues λ = ω².
    pub lambdas: Vec<f64>,
    /// Eigenvectors (N × c), M-orthonormal.
    pub vectors: Mat<f64>,
    /// Normwise backward errors η = ‖Kφ − λMφ‖₂ / ((‖K‖₁ + |λ|‖M‖₁)‖φ‖₂): the pair is an
    /// exact eigenpair of a pencil (K + ΔK, M + ΔM) with ‖ΔK‖ ≲ η‖K‖, ‖ΔM‖ ≲ η‖M‖ (the matrix
    /// 1-norms bound the 2-norms). A backward-stable solve gives a small multiple of ε. It is
    /// not a forward error (the relative error of a low λ can be larger by up to about
    /// ‖K‖/(|λ|‖M‖)), but unlike a residual relative to ‖Kφ‖ it has no rounding floor for the
    /// lowest modes of a fine mesh and stays meaningful for rigid modes (λ ≈ 0), where that
    /// ratio compares two rounding errors.
    pub residuals: Vec<f64>,
    /// How many of them are rigid-body modes (the first ones; see the module doc).
    pub rigid: usize,
    /// Measurements.
    pub stats: EigenStats,
}

impl Modes {
    /// Frequencies f = √λ / 2π (Hz) of the deformation modes; the [`Self::rigid`] rigid
    /// modes are reported as 0 Hz (their computed λ, a rounding-level number of either sign,
    /// stays in [`Self::lambdas`]) — never as a negative frequency.
    pub fn freqs_hz(&self) -> Vec<f64> {
        self.lambdas
            .iter()
            .enumerate()
            .map(|(k, &l)| {
                if k < self.rigid {
                    0.0
                } else {
                    crate::units::lambda_to_hz(l)
                }
            })
            .collect()
    }
}

/// The eigenpairs of (K, M) asked for.
///
/// ```
/// use sparsemor::body::Body;
/// use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
/// use sparsemor::fe::{bar_model, BoxSpec};
///
/// let model = bar_model(&BoxSpec::paper_bar())?;
/// // every mode up to 1000 Hz, counted exactly by the inertia of K − (2π·1000)²M
/// let modes = eigenpairs(&Body::new(&model)?, Request::UpTo(1000.0), &EigenOptions::default())?;
/// assert_eq!((modes.lambdas.len(), modes.rigid), (12, 6)); // 6 rigid + 6 elastic
/// assert_eq!(modes.freqs_hz()[0], 0.0); // rigid modes are reported at 0 Hz
/// # Ok::<(), sparsemor::Error>(())
/// ```
///
/// # Errors
/// [`Error::InvalidSetting`] for c = 0, c > N (ARPACK: c ≥ N), σ ≥ 0, f ≤ 0 or not finite,
/// no mode at or below f, and [`EigenBackend::Arpack`] in a build without the `arpack`
/// feature; [`Error::Factor`] when K − σM is not positive definite (σ not below the
/// spectrum), the iteration does not converge within the restart limit, or ARPACK reports
/// an error (its `info` code, explained).
pub fn eigenpairs(body: &Body<'_>, req: Request, opts: &EigenOptions) -> Result<Modes> {
    let model = body.model();
    #[cfg(not(feature = "arpack"))]
    if opts.backend == EigenBackend::Arpack {
        return Err(Error::InvalidSetting(
            "eigen backend arpack: this build has no ARPACK; rebuild with `--features arpack` (needs libarpack2-dev)".into(),
        ));
    }
    let n = model.n();
    let pencil = body.pencil();
    let mut stats = EigenStats {
        backend: opts.backend,
        ..Default::default()
    };
    let f_ref = match req {
        Request::UpTo(f) if f.is_finite() && f > 0.0 => f,
        Request::UpTo(f) => {
            return Err(Error::InvalidSetting(format!(
                "modes up to {f} Hz: need a finite bound > 0"
            )))
        }
        Request::Lowest(_) => opts.band_end_hz.unwrap_or(1.0).max(1.0),
    };
    let sigma = opts
        .sigma
        .unwrap_or(-0.01 * (2.0 * std::f64::consts::PI * f_ref).powi(2));
    if !(sigma < 0.0 && sigma.is_finite()) {
        return Err(Error::InvalidSetting(format!("shift sigma = {sigma}: must be finite and < 0 so that K - sigma M is positive definite")));
    }
    let sym = body.symbolic()?;
    let (count, lambda_hi) = match req {
        Request::Lowest(c) => (c, None),
        Request::UpTo(f) => {
            let t = Instant::now();
            let hi = (2.0 * std::f64::consts::PI * f).powi(2);
            let c = count_eigenvalues_below_with(&sym, pencil, hi)?;
            stats.count_s = t.elapsed().as_secs_f64();
            (c, Some(hi))
        }
    };
    if count == 0 {
        return Err(Error::InvalidSetting(match req {
            Request::UpTo(f) => format!(
                "no mode at or below {f} Hz (the lowest eigenfrequency is higher): raise the bound"
            ),
            _ => "mode count 0: ask for at least one mode".into(),
        }));
    }
    if count > n {
        return Err(Error::InvalidSetting(format!(
            "{count} modes asked but the model has only N = {n} DoFs"
        )));
    }
    let m = opts
        .krylov_dim
        .unwrap_or((2 * count + 20).max(40))
        .min(n)
        .max(count);

    let t = Instant::now();
    let mut op = ShiftInvert::new(model, pencil, sym, sigma)?;
    stats.factor_s = t.elapsed().as_secs_f64();
    stats.factor_nnz = op.chol.factor_nnz();
    stats.sigma = sigma;
    stats.krylov_dim = m;

    let t = Instant::now();
    let (lambdas, vectors) = match opts.backend {
        EigenBackend::Krylov => krylov::solve(&mut op, count, m, opts, &mut stats)?,
        #[cfg(feature = "arpack")]
        EigenBackend::Arpack => arpack::solve(&mut op, count, m, opts, &mut stats)?,
        #[cfg(not(feature = "arpack"))]
        EigenBackend::Arpack => unreachable!("rejected above"),
    };
    stats.iterate_s = t.elapsed().as_secs_f64();
    drop(op);
    finish(body, lambdas, vectors, lambda_hi, sigma, stats)
}

/// The shift-invert operator S = (K − σM)⁻¹ M of both backends: one sparse Cholesky of
/// K − σM (AMD ordering, faer) and the mass matrix.
pub(crate) struct ShiftInvert<'a> {
    chol: Cholesky,
    mass: SparseColMatRef<'a, usize, f64>,
    sigma: f64,
}

impl<'a> ShiftInvert<'a> {
    /// Factors K − σM on the symbolic analysis `sym` of the pencil's pattern.
    fn new(
        model: &'a Model,
        pencil: &Pencil,
        sym: Arc<SymbolicCholesky<usize>>,
        sigma: f64,
    ) -> Result<Self> {
        let mut chol = Cholesky::new(sym, Par::Seq)?;
        chol.factor(pencil, sigma, Par::Seq).map_err(|e| {
            Error::Factor(format!(
                "K - sigma M (sigma = {sigma:.3e}) is not positive definite ({e:?}): is M positive definite and K positive semi-definite?"
            ))
        })?;
        Ok(ShiftInvert {
            chol,
            mass: model.mass.as_ref(),
            sigma,
        })
    }

    /// Dimension N.
    fn n(&self) -> usize {
        self.mass.nrows()
    }

    /// y ← M x (one column).
    fn mass_mul(&self, x: MatRef<'_, f64>, y: MatMut<'_, f64>) {
        sparse_dense_matmul(y, Accum::Replace, self.mass, x, 1.0, Par::Seq);
    }

    /// x ← (K − σM)⁻¹ x (one column).
    fn solve_in_place(&mut self, x: MatMut<'_, f64>) {
        self.chol.solve_in_place(x);
    }

    /// y ← S x = (K − σM)⁻¹ M x (one column).
    fn apply(&mut self, x: MatRef<'_, f64>, mut y: MatMut<'_, f64>) {
        self.mass_mul(x, y.as_mut());
        self.solve_in_place(y);
    }
}

/// A deterministic pseudo-random vector (xorshift, uniform in [−½, ½)); `seed` 0 is the start
/// vector of both backends.
fn random_vector(n: usize, seed: u64) -> Mat<f64> {
    let mut seed = 0x2545f4914f6cdd1du64 ^ seed.wrapping_mul(0x9e3779b97f4a7c15);
    Mat::from_fn(n, 1, |_, _| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    })
}

/// The shared post-processing: ascending order, the check against the counted bound,
/// residuals and the rigid count.
fn finish(
    body: &Body<'_>,
    lambdas: Vec<f64>,
    vectors: Mat<f64>,
    lambda_hi: Option<f64>,
    sigma: f64,
    stats: EigenStats,
) -> Result<Modes> {
    let model = body.model();
    let n = model.n();
    let mut order: Vec<usize> = (0..lambdas.len()).collect();
    order.sort_by(|&a, &b| lambdas[a].total_cmp(&lambdas[b]));
    let lambdas: Vec<f64> = order.iter().map(|&c| lambdas[c]).collect();
    let vectors = Mat::from_fn(n, order.len(), |i, c| vectors[(i, order[c])]);
    if let (Some(hi), Some(&top)) = (lambda_hi, lambdas.last()) {
        // the inertia count says every wanted λ is < hi; a larger one means a wanted mode was
        // missed (e.g. one copy of a multiple eigenvalue) and replaced by the next one
        if top > hi + 1e-8 * (hi - sigma) {
            return Err(Error::Factor(format!(
                "eigensolver: {} modes counted below {hi:.6e} but the largest computed eigenvalue is {top:.6e}: a mode was missed \
                 (multiple eigenvalue?); increase the Krylov dimension",
                lambdas.len()
            )));
        }
    }
    let kphi = mul_dense(model.stiffness.as_ref(), vectors.as_ref());
    let mphi = mul_dense(model.mass.as_ref(), vectors.as_ref());
    let (norm_k, norm_m) = (norm_1(&model.stiffness), norm_1(&model.mass));
    let residuals = (0..lambdas.len())
        .map(|c| {
            let r = kphi.col(c) - mphi.col(c) * lambdas[c];
            r.norm_l2() / ((norm_k + lambdas[c].abs() * norm_m) * vectors.col(c).norm_l2())
        })
        .collect();
    let rigid = match body.rigid() {
        Some(rb) => {
            // M-norm² of the M-orthogonal projection onto span V0: cᵀ M0⁻¹ c with c = V0ᵀ M φ
            let c = rb.modes().transpose() * &mphi;
            let llt = rb.mass().llt(Side::Lower).map_err(|_| {
                Error::InvalidModel("rigid modes: V0ᵀ M V0 is not positive definite".into())
            })?;
            let y = faer::linalg::solvers::Solve::solve(&llt, &c);
            (0..lambdas.len())
                .filter(|&j| {
                    (0..6).map(|i| c[(i, j)] * y[(i, j)]).sum::<f64>()
                        >= 0.5 * (vectors.col(j).transpose() * mphi.col(j))
                })
                .count()
        }
        None => {
            let scale = (0..n)
                .map(|i| diag(&model.stiffness, i) / diag(&model.mass, i))
                .fold(0.0, f64::max);
            lambdas
                .iter()
                .filter(|&&l| l.abs() <= RIGID_RTOL * scale)
                .count()
        }
    };
    Ok(Modes {
        lambdas,
        vectors,
        residuals,
        rigid,
        stats,
    })
}

/// ‖A‖₁ = max column sum of |a_ij| (= ‖A‖_∞ for a symmetric A, ≥ ‖A‖₂).
fn norm_1(a: &crate::sparse::Csc) -> f64 {
    (0..a.ncols())
        .map(|j| a.val_of_col(j).iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

fn diag(a: &crate::sparse::Csc, i: usize) -> f64 {
    let rows = a.symbolic().row_idx_of_col_raw(i);
    rows.binary_search(&i)
        .map(|p| a.val_of_col(i)[p])
        .unwrap_or(0.0)
}
