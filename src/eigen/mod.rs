//! Partial eigenpairs K φ = λ M φ — only the ones needed, counted (docs/design.md §3.6).
//!
//! Entry point: [`eigenpairs`] ([`eigenpairs_with_progress`] with a progress callback). The
//! wanted part of the spectrum — every mode up to f ([`Request::UpTo`]), in a band
//! ([`Request::Band`]) or the lowest c ([`Request::Lowest`]) — is cut into **slices** (module
//! `slicing`), each counted exactly by the inertia of an LBLᵀ factor of K − xM at its bounds
//! (Sylvester: ν(x) = #{λ < x}), and each solved on its own shift-invert operator
//! S = (K − σM)⁻¹ M (module `operator`): below the spectrum (σ < 0, Cholesky) for the bottom
//! slice, at the midpoint (LBLᵀ) for the others. S is self-adjoint in the M-inner product
//! ⟨x, y⟩_M = xᵀMy and its eigenvalues θ = 1/(λ − σ) are largest for the λ nearest σ. Two
//! iterations ([`EigenBackend`]):
//!
//! - [`EigenBackend::Krylov`] (default, pure Rust): Krylov–Schur with locking, deflation and
//!   fresh starts for missed copies of multiple eigenvalues (module `krylov`), stopping when the
//!   inertia count of its slice is reached.
//! - [`EigenBackend::Arpack`] (cargo feature `arpack`): ARPACK's implicitly restarted Lanczos
//!   `dsaupd`/`dseupd` in mode 3 (shift-invert, generalized, `bmat = 'G'`, `which = 'LM'`) —
//!   the reference implementation; its result is checked against the slice's count.
//!
//! Why our own Krylov–Schur and not faer's `partial_self_adjoint_eigen`: faer's routine works
//! in the Euclidean inner product, so it would need the Cholesky factor of M as well
//! (L⁻¹ (K − σM)⁻¹ L⁻ᵀ) — a second sparse factorization and 2 extra triangular solves per
//! step — whereas the M-inner product needs only a sparse product with M. Memory per slice:
//! O(nnz(L) + N·m) with m the Krylov dimension of the slice, so many modes cost more slices,
//! not a wider basis.
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
mod operator;
mod slicing;

use crate::body::Body;
use crate::pencil::Coefficient;
use crate::units::hz_to_lambda;
use crate::{Error, Result};
use faer::{Mat, Side};
use slicing::{Slicer, Solved};
use std::time::Instant;

/// |λ| ≤ RIGID_RTOL · max_i K_ii/M_ii marks a rigid-body mode when the model gives no rigid
/// modes V0 (see the module doc).
pub const RIGID_RTOL: f64 = 1e-10;

/// Largest accepted normwise backward error of a returned eigenpair ([`Modes::residuals`]);
/// a backward-stable iteration gives a small multiple of ε.
pub const MAX_BACKWARD_ERROR: f64 = 1e-10;

/// Which eigenpairs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Request {
    /// The c lowest modes, rigid ones included.
    Lowest(usize),
    /// Every mode with frequency ≤ f_hi (Hz), rigid ones included, counted exactly by inertia.
    UpTo(f64),
    /// Every mode with lo ≤ f ≤ hi (Hz), counted exactly by inertia; only these are computed
    /// (lo ≤ 0 includes the rigid modes).
    Band(f64, f64),
}

/// Which iteration computes the eigenpairs (the slicing and factorizations are the same).
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
    /// Shift σ < 0 of the bottom slice; `None` = −b/100 with b the slice's upper bound (or
    /// −0.01·(2π [`Self::band_end_hz`])² while the bound of [`Request::Lowest`] is unknown).
    pub sigma: Option<f64>,
    /// The frequency scale (Hz) of the first shift for [`Request::Lowest`]: the end of the
    /// scene's band, where the wanted modes lie below; `None` = 1 Hz.
    pub band_end_hz: Option<f64>,
    /// Convergence: Ritz residual ≤ tol·|θ| + 4ε·θ_max (module `krylov`; ARPACK: its `tol`).
    pub tol: f64,
    /// Krylov dimension per slice (ARPACK: `ncv`); `None` = max(2c, c + 40) for a slice of c
    /// modes, capped at N.
    pub krylov_dim: Option<usize>,
    /// Restart limit per slice (ARPACK: `iparam(3)`, its update iterations).
    pub max_restarts: usize,
    /// Restarts in a row without a newly converged mode after which a slice gives up.
    pub patience: usize,
    /// Target number of modes per slice; smaller when the Krylov bases of the slices that run
    /// at once would take more than half the memory budget (module `slicing`).
    pub slice_size: usize,
    /// Block size of the Krylov–Schur iteration: vectors solved at once (a block solve costs
    /// far less than as many single ones) and the largest multiplicity resolved without a
    /// fresh start.
    pub block: usize,
    /// Worker threads (slices at once, or threads inside a lone factorization); 0 = all cores.
    pub threads: usize,
    /// Memory the concurrent slices may use (bytes); `None` = half of MemAvailable.
    pub memory_budget: Option<usize>,
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
            tol: 1e-14,
            krylov_dim: None,
            max_restarts: 500,
            patience: 60,
            slice_size: 96,
            block: 4,
            threads: 0,
            memory_budget: None,
            backend: EigenBackend::Krylov,
        }
    }
}

/// Progress of one slice, passed to the callback of [`eigenpairs_with_progress`] after each
/// restart of its iteration.
#[derive(Clone, Copy, Debug)]
pub struct EigenProgress {
    /// The slice (0-based) and how many there are.
    pub slice: usize,
    /// Slices in this solve.
    pub slices: usize,
    /// Modes of the slice converged so far.
    pub found: usize,
    /// Modes in the slice (its inertia count).
    pub wanted: usize,
    /// The slice's frequency range (Hz; 0 for the bottom slice's open lower end).
    pub lo_hz: f64,
    /// Upper end (Hz).
    pub hi_hz: f64,
}

/// What one slice did.
#[derive(Clone, Debug, Default)]
pub struct SliceStats {
    /// Frequency range (Hz) (lo = 0 for the bottom slice).
    pub lo_hz: f64,
    /// Upper end (Hz).
    pub hi_hz: f64,
    /// Shift used.
    pub sigma: f64,
    /// ν(σ) from the LBLᵀ inertia (0 for a shift below the spectrum).
    pub below_sigma: usize,
    /// Modes counted (and found) in the slice.
    pub count: usize,
    /// Krylov dimension.
    pub krylov_dim: usize,
    /// nnz of the factor.
    pub factor_nnz: usize,
    /// Factorization time, s.
    pub factor_s: f64,
    /// Iteration time, s.
    pub iterate_s: f64,
    /// Applications of S.
    pub solves: usize,
    /// Restarts.
    pub restarts: usize,
    /// Fresh starts after missed copies of multiple eigenvalues.
    pub fresh_starts: usize,
    /// Iterative-refinement steps of the interior shift's LBLᵀ solves (0 when every solve
    /// met its backward-error target at once; see `factor::ShiftedLblt`): a large number
    /// means the factor at this shift grew and each solve cost up to four.
    pub refinements: usize,
}

/// What the eigensolver did.
#[derive(Clone, Debug, Default)]
pub struct EigenStats {
    /// The iteration used.
    pub backend: EigenBackend,
    /// Factorizations of the slices (summed over slices), s.
    pub factor_s: f64,
    /// Iterations (summed over slices), s.
    pub iterate_s: f64,
    /// Inertia counts (summed), s.
    pub count_s: f64,
    /// Wall-clock time of the whole solve, s.
    pub wall_s: f64,
    /// Applications of S (all slices).
    pub solves: usize,
    /// Restarts (all slices).
    pub restarts: usize,
    /// Largest Krylov dimension of a slice.
    pub krylov_dim: usize,
    /// Shift of the first slice.
    pub sigma: f64,
    /// nnz of the Cholesky/LBLᵀ factor.
    pub factor_nnz: usize,
    /// Sparse factorizations in all: one per slice and one per counted bound.
    pub factorizations: usize,
    /// Neighbouring slices whose vectors needed the Rayleigh–Ritz step to be M-orthonormal.
    pub repaired_bounds: usize,
    /// Per slice, in ascending order.
    pub slices: Vec<SliceStats>,
    /// Modes below the ones returned (ν(lo) of a [`Request::Band`], else 0): the first
    /// returned mode is mode number `modes_below + 1` of the body.
    pub modes_below: usize,
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
/// [`Error::InvalidSetting`] for c = 0, c > N, σ ≥ 0, bounds not finite or reversed, no mode
/// in the band, and [`EigenBackend::Arpack`] in a build without the `arpack` feature;
/// [`Error::NotConverged`] when a slice's iteration stops short of its count (it names the
/// slice, the modes found and the largest residual); [`Error::Factor`] when a factorization
/// fails.
pub fn eigenpairs(body: &Body, req: Request, opts: &EigenOptions) -> Result<Modes> {
    eigenpairs_with_progress(body, req, opts, &|_| true)
}

/// [`eigenpairs`] with a progress callback per slice and restart; returning `false` cancels
/// ([`Error::Cancelled`]).
///
/// # Errors
/// As [`eigenpairs`], and [`Error::Cancelled`].
pub fn eigenpairs_with_progress(
    body: &Body,
    req: Request,
    opts: &EigenOptions,
    progress: &(dyn Fn(EigenProgress) -> bool + Sync),
) -> Result<Modes> {
    #[cfg(not(feature = "arpack"))]
    if opts.backend == EigenBackend::Arpack {
        return Err(Error::InvalidSetting(
            "eigen backend arpack: this build has no ARPACK; rebuild with `--features arpack` (needs libarpack2-dev)".into(),
        ));
    }
    if let Some(s) = opts.sigma {
        if !(s < 0.0 && s.is_finite()) {
            return Err(Error::InvalidSetting(format!("shift sigma = {s}: must be finite and < 0 so that K - sigma M is positive definite")));
        }
    }
    // every worker runs in a pool that lives for this call (`crate::pool`)
    let threads = crate::sweep::resolve_threads(opts.threads);
    crate::pool::with_pool(threads, || solve_request(body, req, opts, progress))?
}

/// [`eigenpairs_with_progress`] inside its pool.
fn solve_request(
    body: &Body,
    req: Request,
    opts: &EigenOptions,
    progress: &(dyn Fn(EigenProgress) -> bool + Sync),
) -> Result<Modes> {
    let wall = Instant::now();
    let n = body.n();
    let slicer = Slicer::new(body, opts)?;
    let (mut modes_below, mut discarded) = (0, None);
    let (slices, keep) = match req {
        Request::Lowest(c) => {
            if c == 0 {
                return Err(Error::InvalidSetting(
                    "mode count 0: ask for at least one mode".into(),
                ));
            }
            if c > n {
                return Err(Error::InvalidSetting(format!(
                    "{c} modes asked but the model has only N = {n} DoFs"
                )));
            }
            let (slices, probe) = lowest(&slicer, c, opts, progress)?;
            discarded = probe;
            (slices, Some(c))
        }
        Request::UpTo(f) => (band(&slicer, None, f, progress)?.0, None),
        Request::Band(lo, hi) => {
            if !(lo.is_finite() && lo < hi) {
                return Err(Error::InvalidSetting(format!(
                    "modes in [{lo}, {hi}] Hz: need finite bounds with lo < hi"
                )));
            }
            let (slices, below) = band(&slicer, (lo > 0.0).then_some(lo), hi, progress)?;
            modes_below = below;
            (slices, None)
        }
    };
    let mut stats = EigenStats {
        backend: opts.backend,
        modes_below,
        ..Default::default()
    };
    for st in discarded.iter().chain(slices.iter().map(|s| &s.stats)) {
        stats.factor_s += st.factor_s;
        stats.iterate_s += st.iterate_s;
        stats.solves += st.solves;
        stats.restarts += st.restarts;
        stats.krylov_dim = stats.krylov_dim.max(st.krylov_dim);
        stats.factor_nnz = st.factor_nnz;
    }
    stats.slices = slices.iter().map(|s| s.stats.clone()).collect();
    stats.sigma = stats.slices.first().map_or(0.0, |s| s.sigma);
    let (count_s, counts) = slicer.count_cost();
    stats.count_s = count_s;
    stats.factorizations = counts + slices.len() + usize::from(discarded.is_some());
    let (mut lambdas, mut vectors, repaired) = slicing::join(body, slices)?;
    stats.repaired_bounds = repaired;
    if let Some(c) = keep {
        lambdas.truncate(c);
        vectors = vectors
            .as_ref()
            .subcols(0, c.min(vectors.ncols()))
            .to_owned();
    }
    stats.wall_s = wall.elapsed().as_secs_f64();
    finish(body, lambdas, vectors, stats)
}

/// Every mode in [lo, hi] Hz (lo = None: from the bottom of the spectrum, rigid modes
/// included), counted at both ends and sliced; also returns ν(lo).
fn band(
    slicer: &Slicer<'_>,
    lo: Option<f64>,
    hi: f64,
    progress: &(dyn Fn(EigenProgress) -> bool + Sync),
) -> Result<(Vec<Solved>, usize)> {
    if !(hi.is_finite() && hi > 0.0) {
        return Err(Error::InvalidSetting(format!(
            "modes up to {hi} Hz: need a finite bound > 0"
        )));
    }
    let mut ends = vec![hz_to_lambda(hi)];
    ends.extend(lo.map(hz_to_lambda));
    let counts = slicer.count(&ends)?;
    let (upper, lower) = (counts[0], counts.get(1).copied());
    if upper.1 == lower.map_or(0, |l| l.1) {
        return Err(Error::InvalidSetting(match lo {
            None => format!("no mode at or below {hi} Hz (the lowest eigenfrequency is higher): raise the bound"),
            Some(lo) => format!("no mode in [{lo}, {hi}] Hz (the inertia counts agree at both ends): widen the band"),
        }));
    }
    let below = lower.map_or(0, |l| l.1);
    Ok((slicer.solve(&slicer.split(lower, upper)?, progress)?, below))
}

/// The c lowest modes: the bottom slice's c' lowest first (below the spectrum, which also
/// estimates where the c-th lies): c' = c when c fits one slice, else a quarter of a slice
/// (at least 8), because this solve runs before the others and alone (ARPACK: c fits one slice
/// only when c with its guard stays below N). Then a bound B with
/// ν(B) ≥ c is found by counting (Weyl's growth, then brought down towards c), and (b₁, B] is
/// sliced as a band, its slices in parallel. Every slice is checked against its count, so
/// copies of multiple eigenvalues are not lost. Also returns the cost of the first solve when
/// it served only as the estimate.
fn lowest(
    slicer: &Slicer<'_>,
    c: usize,
    opts: &EigenOptions,
    progress: &(dyn Fn(EigenProgress) -> bool + Sync),
) -> Result<(Vec<Solved>, Option<SliceStats>)> {
    let n = slicer.body().n();
    let size = slicer.slice_size();
    // one slice holds c when it fits (ARPACK computes at most N − 1 pairs of one slice, so
    // there a c whose guard reaches N is sliced too)
    let one_slice = c <= size && (opts.backend == EigenBackend::Krylov || c + 2 + c / 8 < n);
    let first = if one_slice {
        c
    } else {
        (size / 4).max(8).min(c)
    };
    let probe = krylov::Target {
        lower: f64::NEG_INFINITY,
        upper: f64::INFINITY,
        count: (first + 2 + first / 8).min(n),
    };
    let est = slicer.solve(&[probe], progress)?.remove(0);
    // a bound in the gap above the `first`-th computed eigenvalue
    let l = &est.lambdas;
    let bound_after = |k: usize| -> Option<f64> {
        let top = l[k - 1];
        let gap = (top.abs() * 1e-6).max(1e-300);
        l[k..]
            .iter()
            .find(|&&x| x > top + gap)
            .map(|&x| 0.5 * (top + x))
    };
    let b1 = match bound_after(first) {
        Some(b) => b,
        None if first == n => f64::INFINITY,
        None => l[l.len() - 1] * 1.01 + 1e-300,
    };
    let mut probe = None;
    let mut bottom = if b1.is_finite() {
        let nu = slicer.count(&[b1])?[0];
        let have = l.iter().filter(|&&x| x < nu.0).count();
        // the first shift came from the band end, not from the spectrum: a shift far below
        // the modes found (|σ| < b/1000) leaves the elastic directions of K − σM badly
        // conditioned next to the rigid ones, so the probe is only an estimate then
        let scaled = opts.sigma.is_some() || est.stats.sigma.abs() >= 1e-3 * nu.0;
        if have == nu.1 && scaled {
            est.below(nu.0)
        } else {
            // a missed copy of a multiple eigenvalue, or a badly scaled first shift: solve
            // the counted bottom slice at σ = −b/100
            let t = krylov::Target {
                lower: f64::NEG_INFINITY,
                upper: nu.0,
                count: nu.1,
            };
            probe = Some(est.stats);
            slicer.solve(&[t], progress)?.remove(0)
        }
    } else {
        est
    };
    if bottom.lambdas.len() >= c || !b1.is_finite() {
        return Ok((vec![bottom], probe));
    }
    // find B with ν(B) ≥ c, from Weyl's λ^{3/2} growth, then slice (b1, B]
    let mut lower = (b1, bottom.lambdas.len());
    let mut upper;
    loop {
        let grow = (c as f64 / lower.1.max(1) as f64).powf(2.0 / 3.0).max(1.25) * 1.05;
        upper = slicer.count(&[lower.0 * grow])?[0];
        if upper.1 >= c {
            break;
        }
        lower = upper;
    }
    // a step of the loop may overshoot c by a third or more, and every mode above the c-th
    // costs Krylov work: count two bounds interpolated (in ν ~ λ^{3/2}) towards c + 2 % and
    // c + 6 % at once, and keep the lowest with ν ≥ c
    if upper.1 > c + c / 10 {
        let (nl, nu) = (lower.1 as f64, upper.1 as f64);
        let at = |target: f64| {
            let t = ((target - nl) / (nu - nl)).clamp(0.0, 1.0);
            slicing::weyl_between(lower.0, upper.0, t)
        };
        let tries = [at(c as f64 * 1.02), at(c as f64 * 1.06)];
        if let Some(b) = slicer
            .count(&tries)?
            .into_iter()
            .filter(|&(l, k)| k >= c && l > lower.0)
            .min_by(|a, b| a.0.total_cmp(&b.0))
        {
            upper = b;
        }
    }
    let targets = slicer.split(Some((b1, bottom.lambdas.len())), upper)?;
    let mut rest = slicer.solve(&targets, progress)?;
    bottom.stats.count = bottom.lambdas.len();
    rest.insert(0, bottom);
    Ok((rest, probe))
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

/// The shared post-processing: ascending order, residuals and the rigid count.
fn finish(body: &Body, lambdas: Vec<f64>, vectors: Mat<f64>, stats: EigenStats) -> Result<Modes> {
    let (pencil, n) = (body.pencil(), body.n());
    let mut order: Vec<usize> = (0..lambdas.len()).collect();
    order.sort_by(|&a, &b| lambdas[a].total_cmp(&lambdas[b]));
    let lambdas: Vec<f64> = order.iter().map(|&c| lambdas[c]).collect();
    let vectors = Mat::from_fn(n, order.len(), |i, c| vectors[(i, order[c])]);
    let kphi = pencil.mul(Coefficient::Stiffness, vectors.as_ref());
    let mphi = pencil.mul(Coefficient::Mass, vectors.as_ref());
    let (norm_k, norm_m) = (
        pencil.norm_1(Coefficient::Stiffness),
        pencil.norm_1(Coefficient::Mass),
    );
    let residuals: Vec<f64> = (0..lambdas.len())
        .map(|c| {
            let r = kphi.col(c) - mphi.col(c) * lambdas[c];
            r.norm_l2() / ((norm_k + lambdas[c].abs() * norm_m) * vectors.col(c).norm_l2())
        })
        .collect();
    // the iteration's residual estimate is not the true residual: a pair that passed it but
    // is not an eigenpair of the pencil to far better than 1e-10 is an error, never a result
    if let Some((k, &worst)) = residuals
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .filter(|(_, &r)| !(r <= MAX_BACKWARD_ERROR))
    {
        return Err(Error::NotConverged(format!(
            "mode {} ({:.6e} Hz) has backward error {worst:.1e} > {MAX_BACKWARD_ERROR:.0e} although its Ritz estimate \
             converged; use smaller slices (slice_size) or a larger block",
            stats.modes_below + k + 1,
            crate::units::lambda_to_hz(lambdas[k])
        )));
    }
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
            let (k, m) = (
                pencil.diagonal(Coefficient::Stiffness),
                pencil.diagonal(Coefficient::Mass),
            );
            let scale = k.iter().zip(&m).map(|(k, m)| k / m).fold(0.0, f64::max);
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
