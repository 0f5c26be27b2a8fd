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
mod modes;
mod operator;
mod options;
mod slicing;
mod stats;

pub use modes::{Modes, MAX_BACKWARD_ERROR, RIGID_RTOL};
pub use options::{EigenBackend, EigenOptions, Request};
pub use stats::{EigenProgress, EigenStats, SliceStats};

pub(crate) use krylov::{lanczos_step_and_full_pass, project_once};
pub(crate) use operator::ShiftInvert;

use crate::body::Body;
use crate::units::hz_to_lambda;
use crate::{Error, Result};
use slicing::{Slicer, Solved};
use std::time::Instant;

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
    let threads = crate::pool::resolve_threads(opts.threads);
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
        stats.residual = stats.residual.max(st.residual);
        stats.krylov_dim = stats.krylov_dim.max(st.krylov_dim);
        stats.factor_nnz = st.factor_nnz;
    }
    stats.slices = slices.iter().map(|s| s.stats.clone()).collect();
    stats.sigma = stats.slices.first().map_or(0.0, |s| s.sigma);
    let (count_s, counts) = slicer.count_cost();
    stats.count_s = count_s;
    stats.factorizations = counts
        + slices.len()
        + slices.iter().map(|s| s.stats.shift_moves).sum::<usize>()
        + usize::from(discarded.is_some());
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
    modes::finish(body, lambdas, vectors, stats)
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
    Ok((
        slicer.solve(&slicer.split(lower, upper, &[])?, progress)?,
        below,
    ))
}

/// The c lowest modes: the bottom slice's c' lowest first (below the spectrum, which also
/// estimates where the c-th lies): c' = c when c fits half a slice, else a twelfth of a slice
/// (at least 8), because this solve runs before the others and alone (the tet10 bracket's 306
/// modes: 3.6 s against 4.0 s with a quarter; ARPACK: c fits
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
    // one slice holds c when it fits in half a slice: a lone slice has no neighbour to run
    // beside it, and its Gram–Schmidt grows as its dimension squared (106 modes of the 10³
    // cube: 1.09 s in one slice of 106, 0.56 s in three; ARPACK computes at most N − 1 pairs
    // of one slice, so there a c whose guard reaches N is sliced too)
    let one_slice = 2 * c <= size && (opts.backend == EigenBackend::Krylov || c + 2 + c / 8 < n);
    let first = if one_slice {
        c
    } else {
        (size / 12).max(8).min(c)
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
    // the step towards B from a bound with k modes below it (Weyl's λ^{3/2} growth)
    let grow = |k: usize| (c as f64 / k.max(1) as f64).powf(2.0 / 3.0).max(1.25) * 1.05;
    // ν(b₁) is nearly always the probe's count below b₁: the first step towards B is counted
    // beside b₁ (one round of factorizations side by side, not two in a row) when it is needed
    let below_b1 = l.iter().filter(|&&x| x < b1).count();
    let ahead = (b1.is_finite() && below_b1 < c).then(|| b1 * grow(below_b1));
    let mut probe = None;
    let mut ahead_count = None;
    let mut bottom = if b1.is_finite() {
        let mut points = vec![b1];
        points.extend(ahead);
        let counted = slicer.count(&points)?;
        let nu = counted[0];
        ahead_count = counted.get(1).copied();
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
    // find B with ν(B) ≥ c, from Weyl's λ^{3/2} growth, then slice (b1, B]; every point
    // counted on the way is handed to the slicing, which places its bounds among them
    let mut counted = Vec::new();
    let mut lower = (b1, bottom.lambdas.len());
    let mut upper;
    loop {
        let step = lower.0 * grow(lower.1);
        upper = match ahead_count.take() {
            Some(ahead) if ahead.0 == step => ahead,
            _ => slicer.count(&[step])?[0],
        };
        counted.push(upper);
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
        let tried = slicer.count(&[at(c as f64 * 1.02), at(c as f64 * 1.06)])?;
        counted.extend_from_slice(&tried);
        if let Some(b) = tried
            .into_iter()
            .filter(|&(l, k)| k >= c && l > lower.0)
            .min_by(|a, b| a.0.total_cmp(&b.0))
        {
            upper = b;
        }
    }
    let targets = slicer.split(Some((b1, bottom.lambdas.len())), upper, &counted)?;
    let mut rest = slicer.solve(&targets, progress)?;
    bottom.stats.count = bottom.lambdas.len();
    rest.insert(0, bottom);
    Ok((rest, probe))
}
