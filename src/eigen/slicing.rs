//! Spectrum slicing (docs/design.md §3.6): the wanted part of the spectrum is cut into
//! slices, each counted exactly by inertia and solved on its own shift-invert factorization.
//!
//! - **Counts.** ν(x) = #{λ < x} is the number of negative pivots of an LBLᵀ factor of
//!   K − xM (Sylvester). A slice (a, b] holds ν(b) − ν(a) eigenvalues; a bound that is an
//!   eigenvalue to working precision (zero pivot) is moved by 10⁻⁷ relative.
//! - **Bounds.** The slices hold equal shares of the modes (their number rounded up to a
//!   multiple of the workers, so that they finish together). Each bound is placed where the
//!   counts known so far say ν reaches its share: interpolated between the two counted points
//!   that bracket it, linearly in λ^{3/2} (Weyl's law of a 3-D body), then counted. A bound
//!   more than an eighth of a slice off its share is placed again from the new counts, which
//!   bracket it more tightly (at most four rounds, all bounds of a round counted in
//!   parallel); the counted point nearest each share becomes the bound. No growth law is
//!   assumed beyond the interpolation inside a bracket: bars, plates and parts of any shape
//!   only change how many rounds it takes.
//! - **Shifts.** The bottom slice (−∞, b] is solved below the spectrum (σ = −b/100, a
//!   Cholesky factor) where its eigenvalues are exactly the ones nearest σ; an interior slice
//!   (a, b] at its midpoint, where the eigenvalues within (b − a)/2 of σ are exactly the
//!   slice's (an LBLᵀ factor).
//! - **Parallel.** Slices are independent: they run on a pool of worker threads, as many at a
//!   time as cores and the memory budget allow (each holds its factor and a basis of 2·m
//!   vectors); a lone slice gets the threads inside its Cholesky factorization instead.
//! - **Across slices.** Vectors of one slice are M-orthonormal by construction; two
//!   eigenvalues on either side of a bound come from different factorizations, so their
//!   vectors are M-orthogonal only to the accuracy of the pair (residual / gap). Where the
//!   M-Gram block of two neighbouring slices exceeds 10⁻¹³, a Rayleigh–Ritz step on the vectors
//!   of those entries (a few next to the bound) restores M-orthonormality and sharpens the
//!   pairs.

use super::krylov::{self, Target};
use super::operator::ShiftInvert;
use super::options::{EigenBackend, EigenOptions};
use super::stats::{EigenProgress, SliceStats};
use crate::body::Body;
use crate::dense::{sym, sym_eigen};
use crate::factor::count_eigenvalues_below_with;
use crate::pencil::Coefficient;
use crate::units::{hz_to_lambda, lambda_to_hz};
use crate::{Error, Result};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::{Mat, Par};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The eigenpairs one slice found (ascending λ) and what it cost.
pub(super) struct Solved {
    pub lambdas: Vec<f64>,
    pub vectors: Mat<f64>,
    pub stats: SliceStats,
}

impl Solved {
    /// Only the pairs with λ < `bound`.
    pub(super) fn below(self, bound: f64) -> Solved {
        let k = self.lambdas.iter().filter(|&&l| l < bound).count();
        Solved {
            lambdas: self.lambdas[..k].to_vec(),
            vectors: self.vectors.as_ref().subcols(0, k).to_owned(),
            stats: SliceStats {
                count: k,
                ..self.stats
            },
        }
    }
}

/// The slicing context of one [`super::eigenpairs`] call.
pub(super) struct Slicer<'b> {
    body: &'b Body,
    sym: Arc<SymbolicCholesky<usize>>,
    opts: &'b EigenOptions,
    /// Workers: the size of the pool [`super::eigenpairs`] runs in (`crate::pool`).
    threads: usize,
    /// Slices that may run at once: the workers, fewer when their factors would pass the
    /// budget.
    at_once: usize,
    budget: usize,
    /// Target modes per slice ([`Self::slice_size`]).
    size: usize,
    /// Seconds and factorizations of the inertia counts.
    counts: Mutex<(f64, usize)>,
}

impl<'b> Slicer<'b> {
    pub(super) fn new(body: &'b Body, opts: &'b EigenOptions) -> Result<Self> {
        let threads = crate::pool::resolve_threads(opts.threads);
        // the run's budget is for the whole run: the slices get what it has not used
        let budget = opts
            .memory_budget
            .or_else(|| body.memory_left())
            .unwrap_or_else(|| crate::memory::default_budget(2));
        let sym = body.symbolic()?;
        // slices run at once as far as their factors fit the budget (8 bytes per entry of L;
        // a factor that goes to disk past it takes the budget for itself): cutting the band
        // for more slices than run at once only adds factorizations
        let at_once = (budget / (8 * sym.len_val()).max(1)).clamp(1, threads.max(1));
        // a slice of s modes keeps Q and M Q, N × (m + b) with m ≈ 2·(5/4)s: at most half the
        // budget for the bases of the slices at once
        let per_slice = budget / 2 / at_once / (16 * body.n().max(1));
        let fits = per_slice.saturating_sub(opts.block) * 2 / 5;
        let size = opts.slice_size.min(fits.max(16)).max(1);
        Ok(Slicer {
            body,
            sym,
            opts,
            threads,
            at_once,
            budget,
            size,
            counts: Mutex::new((0.0, 0)),
        })
    }

    /// The body being solved.
    pub(super) fn body(&self) -> &'b Body {
        self.body
    }

    /// Target modes per slice: [`EigenOptions::slice_size`], lowered when the Krylov bases of
    /// the slices that run at once (Q and M Q, 16·N·(m + b) bytes each, m ≈ 2.5 × the size)
    /// would take more than half the memory budget; never below 16. At N = 10⁶ with 11 GB
    /// left for the slices: 135 when a 10.7 GB factor lets one slice run at a time, 67 for
    /// two slices at once.
    pub(super) fn slice_size(&self) -> usize {
        self.size
    }

    /// (seconds, factorizations) spent on inertia counts so far.
    pub(super) fn count_cost(&self) -> (f64, usize) {
        *self.counts.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// ν at bounds near `lambdas`: each (bound used, ν(bound)), counted in parallel.
    pub(super) fn count(&self, lambdas: &[f64]) -> Result<Vec<(f64, usize)>> {
        let one = |&l: &f64| -> Result<(f64, usize)> {
            let t = Instant::now();
            // a bound that is an eigenvalue to working precision moves by 1e-7, 2e-7, 3e-7
            // relative, alternating sides
            let (mut bound, mut tries) = (l, 0);
            let r = loop {
                match count_eigenvalues_below_with(
                    &self.sym,
                    self.body.pencil(),
                    bound,
                    self.body.factor_storage(),
                ) {
                    Err(Error::Singular { .. }) if tries < 3 => {
                        tries += 1;
                        let side = if tries % 2 == 1 { 1.0 } else { -1.0 };
                        bound = l * (1.0 + side * 1e-7 * f64::from(tries));
                    }
                    r => break r,
                }
            };
            let mut c = self.counts.lock().unwrap_or_else(|p| p.into_inner());
            c.0 += t.elapsed().as_secs_f64();
            c.1 += 1;
            Ok((bound, r?))
        };
        let workers = self.workers(lambdas.len(), 8 * self.sym.len_val() + 64 * self.body.n());
        if workers > 1 {
            lambdas.par_iter().map(one).collect()
        } else {
            lambdas.iter().map(one).collect()
        }
    }

    /// Slices of (lower, upper] (λ; `lower` = None: from below the spectrum) with the counts
    /// ν(lower) and ν(upper) known, holding equal shares of the modes: bounds placed by
    /// interpolating the counts, counted, placed again (see the module doc).
    pub(super) fn split(
        &self,
        lower: Option<(f64, usize)>,
        upper: (f64, usize),
        counted: &[(f64, usize)],
    ) -> Result<Vec<Target>> {
        let (lo, nu_lo) = lower.map_or((0.0, 0), |(l, c)| (l.max(0.0), c));
        let total = upper.1.saturating_sub(nu_lo);
        // a multiple of the slices that run at once: a slice left over for a second round
        // would keep one worker busy while the others idle; a band of more than a quarter
        // slice is shared among them too, as one slice would leave a worker idle
        // (docs/performance.md)
        let mut parts = total.div_ceil(self.size).max(1);
        if parts > 1 || 4 * total > self.size {
            parts = parts.next_multiple_of(self.at_once);
        }
        // the counts ν at which the slices should end, and how far a bound may miss one
        let want: Vec<f64> = (1..parts)
            .map(|k| nu_lo as f64 + (total * k) as f64 / parts as f64)
            .collect();
        let slack = (total as f64 / parts as f64 / 8.0).max(1.0);
        // counted points (λ, ν), ascending; the lower end of a bottom band as (0, 0), for
        // the interpolation only
        let mut known = vec![(lo, nu_lo), upper];
        known.extend(counted.iter().filter(|k| k.0 > lo && k.0 < upper.0));
        known.sort_by(|a, b| a.0.total_cmp(&b.0));
        for _ in 0..COUNT_ROUNDS {
            let guesses: Vec<f64> = want
                .iter()
                .filter(|&&w| (nearest(&known, w).1 as f64 - w).abs() > slack)
                .map(|&w| interpolate(&known, w))
                .filter(|g| known.iter().all(|k| k.0 != *g))
                .collect();
            if guesses.is_empty() {
                break;
            }
            known.extend(self.count(&guesses)?);
            known.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        let mut bounds = vec![lower.unwrap_or((f64::NEG_INFINITY, 0))];
        for &w in &want {
            let b = nearest(&known, w);
            if b.1 > bounds[bounds.len() - 1].1 && b.1 < upper.1 {
                bounds.push(b);
            }
        }
        bounds.push(upper);
        Ok(bounds
            .windows(2)
            .filter(|w| w[1].1 > w[0].1)
            .map(|w| Target {
                lower: w[0].0,
                upper: w[1].0,
                count: w[1].1 - w[0].1,
            })
            .collect())
    }

    /// How many slices of `bytes` each may run at once.
    fn workers(&self, jobs: usize, bytes: usize) -> usize {
        let by_memory = (self.budget / bytes.max(1)).max(1);
        self.threads.min(jobs).min(by_memory).max(1)
    }

    /// The least |σ| of a bottom shift when no band end is given: 10⁻⁸ · max K_ii/M_ii. The
    /// quotients are Rayleigh quotients, so their largest is a lower bound of λ_max, and
    /// cond(K − σM) ≈ λ_max/|σ| stays near 10⁸ or below. Without it a band end far below the spectrum (1 Hz, the
    /// library's default) gave cond ~ 10¹⁴ on a 6³ cube: solves with relative errors of 10⁻²,
    /// an estimate of the wanted modes from noise, and a slice that never converged. With a
    /// band end (the CLI's scene) the floor is not applied: on a large body it can lie above
    /// the lowest wanted modes and place σ among them, where the slice needs far more solves
    /// (docs/performance.md).
    fn conditioning_floor(&self) -> f64 {
        let p = self.body.pencil();
        let (k, m) = (
            p.diagonal(Coefficient::Stiffness),
            p.diagonal(Coefficient::Mass),
        );
        1e-8 * k
            .iter()
            .zip(&m)
            .filter(|(_, &mi)| mi > 0.0)
            .map(|(&ki, &mi)| ki / mi)
            .fold(0.0, f64::max)
    }

    /// Krylov dimension of a slice of `count` eigenvalues: 2·count, and at least 40 or four
    /// blocks beyond it (a restart must add several blocks to the kept vectors).
    fn krylov_dim(&self, count: usize) -> usize {
        let n = self.body.n();
        let blocks = 4 * self.opts.block.max(1);
        self.opts
            .krylov_dim
            .unwrap_or((2 * count).max(count + 40.max(blocks)))
            .max(count + 1)
            .min(n)
    }

    /// Solves every target (in parallel when memory allows) and returns them in order.
    pub(super) fn solve(
        &self,
        targets: &[Target],
        progress: &(dyn Fn(EigenProgress) -> bool + Sync),
    ) -> Result<Vec<Solved>> {
        let n = self.body.n();
        let widest = targets.iter().map(|t| t.count).max().unwrap_or(1);
        let bytes = 8 * self.sym.len_val() + 16 * n * (self.krylov_dim(widest) + 1);
        let workers = self.workers(targets.len(), bytes);
        let par = if workers == 1 && self.threads > 1 {
            Par::rayon(self.threads)
        } else {
            Par::Seq
        };
        let cancel = AtomicBool::new(false);
        let run = |(k, t): (usize, &Target)| {
            if cancel.load(Ordering::Relaxed) {
                return Err(Error::Cancelled);
            }
            let r = self.solve_one(*t, k, targets.len(), par, &|p| {
                let go = !cancel.load(Ordering::Relaxed) && progress(p);
                if !go {
                    cancel.store(true, Ordering::Relaxed);
                }
                go
            });
            if r.is_err() {
                cancel.store(true, Ordering::Relaxed);
            }
            r
        };
        if workers > 1 {
            targets
                .par_iter()
                .enumerate()
                .with_max_len(1)
                .map(run)
                .collect()
        } else {
            // a lone slice: the pool's threads work inside its factorization
            targets.iter().enumerate().map(run).collect()
        }
    }

    /// The factor of an interior slice's operator at `sigma`, or of a bottom slice's; a σ
    /// that is an eigenvalue to working precision moves by 10⁻⁶ of the slice, up to three
    /// times.
    fn factor_at(&self, sigma: f64, target: Target, par: Par) -> Result<ShiftInvert<'b>> {
        let mut attempt = 0;
        loop {
            let s = if attempt == 0 {
                sigma
            } else {
                sigma + 1e-6 * attempt as f64 * (target.upper - target.lower)
            };
            match ShiftInvert::new(
                self.body.pencil(),
                self.sym.clone(),
                s,
                par,
                self.opts.block,
                self.body.factor_storage(),
            ) {
                Err(Error::Singular { .. }) if attempt < 3 && target.lower.is_finite() => {
                    attempt += 1
                }
                r => return r,
            }
        }
    }

    /// One slice: factor at its shift (moved if it hits an eigenvalue or its factor grows),
    /// iterate.
    fn solve_one(
        &self,
        target: Target,
        index: usize,
        slices: usize,
        par: Par,
        progress: &(dyn Fn(EigenProgress) -> bool + Sync),
    ) -> Result<Solved> {
        let base = if target.lower.is_finite() {
            0.5 * (target.lower + target.upper)
        } else {
            let scale = if target.upper.is_finite() {
                target.upper
            } else {
                hz_to_lambda(self.opts.band_end_hz.unwrap_or(1.0).max(1.0))
            };
            // without a band end, the 1 Hz scale may lie far below the spectrum
            self.opts
                .sigma
                .unwrap_or_else(|| match self.opts.band_end_hz {
                    None => -(0.01 * scale.abs()).max(self.conditioning_floor()),
                    Some(_) => -0.01 * scale.abs(),
                })
        };
        if !base.is_finite() || (!target.lower.is_finite() && base >= 0.0) {
            return Err(Error::InvalidSetting(format!(
                "shift sigma = {base}: must be finite and < 0 so that K - sigma M is positive definite"
            )));
        }
        let t = Instant::now();
        let mut op = self.factor_at(base, target, par)?;
        // an interior shift whose factor grew (max |l_ij| > GROWTH_LIMIT: its solves need
        // refinement, each up to four solves) is moved by a twentieth of the slice, at most
        // twice: growth comes from an eigenvalue close to σ inside a supernode's pivoting
        // block, and a factorization costs less than the refinements of a slice's solves
        let mut moves = 0;
        if target.lower.is_finite() {
            for side in [1.0, -1.0] {
                if !(op.growth() > GROWTH_LIMIT) {
                    break;
                }
                op = self.factor_at(
                    base + side * SHIFT_MOVE * (target.upper - target.lower),
                    target,
                    par,
                )?;
                moves += 1;
            }
        }
        let m = self.krylov_dim(target.count);
        let (mut extra_solves, mut first) = (0, None);
        // the estimate's expansion is Krylov work: timed with the iteration, not the factor
        let mut estimate_s = 0.0;
        if !target.upper.is_finite() && self.opts.sigma.is_none() {
            // nothing is known of the spectrum yet: the shift came from the band end. One
            // Krylov space estimates λ of the count-th mode; a shift far below it (|σ| <
            // λ/1000) would leave K − σM badly conditioned in the wanted elastic directions
            // next to the rigid ones, so factor again at −λ/100; otherwise the iteration
            // goes on from that space
            let te = Instant::now();
            let (guess, space) = krylov::estimate(&mut op, target.count, m, self.opts)?;
            estimate_s = te.elapsed().as_secs_f64();
            if op.sigma.abs() >= 1e-3 * guess {
                first = Some(space);
            } else {
                extra_solves = space.solves();
                op = self.factor_at(-0.01 * guess, target, par)?;
            }
        }
        let factor_s = t.elapsed().as_secs_f64() - estimate_s;
        let t = Instant::now();
        let lo_hz = if target.lower.is_finite() {
            lambda_to_hz(target.lower)
        } else {
            0.0
        };
        let hi_hz = if target.upper.is_finite() {
            lambda_to_hz(target.upper)
        } else {
            f64::INFINITY
        };
        let mut report = |found: usize| {
            progress(EigenProgress {
                slice: index,
                slices,
                found,
                wanted: target.count,
                lo_hz,
                hi_hz,
            })
        };
        let (lambdas, vectors, it) = match self.opts.backend {
            EigenBackend::Krylov => {
                krylov::solve(&mut op, target, m, self.opts, first, &mut report)?
            }
            #[cfg(feature = "arpack")]
            EigenBackend::Arpack => {
                // ARPACK starts its own space: the estimate's solves were extra
                extra_solves += first.as_ref().map_or(0, krylov::Expanded::solves);
                let (l, v, it) = super::arpack::solve(&mut op, target.count, m, self.opts)?;
                let inside = l
                    .iter()
                    .filter(|&&x| x > target.lower && x <= target.upper)
                    .count();
                if inside < target.count {
                    return Err(Error::NotConverged(format!(
                        "ARPACK found {inside} of the {} modes counted by inertia in the slice ({lo_hz:.6e}, {hi_hz:.6e}] Hz \
                         (a multiple eigenvalue it did not resolve); use the krylov backend",
                        target.count
                    )));
                }
                report(target.count);
                (l, v, it)
            }
            #[cfg(not(feature = "arpack"))]
            EigenBackend::Arpack => unreachable!("rejected by eigenpairs"),
        };
        let iterate_s = t.elapsed().as_secs_f64() + estimate_s;
        let mut order: Vec<usize> = (0..lambdas.len()).collect();
        order.sort_by(|&a, &b| lambdas[a].total_cmp(&lambdas[b]));
        Ok(Solved {
            lambdas: order.iter().map(|&c| lambdas[c]).collect(),
            vectors: Mat::from_fn(vectors.nrows(), order.len(), |i, c| vectors[(i, order[c])]),
            stats: SliceStats {
                lo_hz,
                hi_hz,
                sigma: op.sigma,
                below_sigma: op.below(),
                count: target.count,
                krylov_dim: m,
                factor_nnz: op.factor_nnz(),
                factor_s,
                iterate_s,
                solves: it.solves + extra_solves,
                restarts: it.restarts,
                fresh_starts: it.fresh_starts,
                refinements: op.refinements(),
                shift_moves: moves,
                residual: it.residual,
            },
        })
    }
}

/// How far an interior shift whose factor grew is moved, as a fraction of its slice.
const SHIFT_MOVE: f64 = 0.05;

/// The largest |l_ij| of an interior shift's LBLᵀ factor that is kept without moving the
/// shift. Measured on the 10⁴-DoF tet10 parts (VM-B, 2026-11-28): slice factors whose
/// solves needed refinement on nearly every solve had 1.3e3 and 1.7e4; the factors at the
/// ~100 bounds counted for their slices mostly 10…300, a few 5e2…1.5e3 and one 1.3e4. A
/// move costs one factorization; a limit of 500 moved 4 shifts of slices of 64 modes on the
/// tet10 bracket whose solves had not needed refinement.
const GROWTH_LIMIT: f64 = 1000.0;

/// Rounds of counts that place the slice bounds (each round counts the bounds still off their
/// share by more than an eighth of a slice, in parallel).
const COUNT_ROUNDS: usize = 4;

/// Where ν reaches `want`, interpolated between the counted points (ascending λ) that bracket
/// it, linearly in λ^{3/2} (Weyl's law for a 3-D body; on other bodies the next round's count
/// corrects it, the bracket shrinking each round).
fn interpolate(known: &[(f64, usize)], want: f64) -> f64 {
    let above = known
        .iter()
        .position(|k| k.1 as f64 >= want)
        .unwrap_or(known.len() - 1);
    let below = above.saturating_sub(1);
    let ((la, na), (lb, nb)) = (known[below], known[above]);
    if nb <= na {
        return 0.5 * (la + lb);
    }
    // strictly inside the bracket: a bound on a counted point adds nothing
    let t = ((want - na as f64) / (nb - na) as f64).clamp(0.05, 0.95);
    weyl_between(la, lb, t)
}

/// The counted point whose ν is nearest `want` (the lowest λ among equals).
fn nearest(known: &[(f64, usize)], want: f64) -> (f64, usize) {
    known
        .iter()
        .copied()
        .min_by(|a, b| {
            (a.1 as f64 - want)
                .abs()
                .total_cmp(&(b.1 as f64 - want).abs())
        })
        .unwrap_or((0.0, 0))
}

/// The point a fraction `t` of the way from λ = `a` to `b` in λ^{3/2} (negative λ as 0): where
/// a 3-D body's count ν(λ) (Weyl's law) has grown by the fraction t of ν(b) − ν(a).
pub(super) fn weyl_between(a: f64, b: f64, t: f64) -> f64 {
    let u = |l: f64| l.max(0.0).powf(1.5);
    (u(a) + (u(b) - u(a)) * t).powf(2.0 / 3.0)
}

/// Concatenates the slices (ascending) and restores M-orthonormality across each bound
/// where it is lost (module doc): returns (λ, vectors, bounds repaired).
pub(super) fn join(body: &Body, slices: Vec<Solved>) -> Result<(Vec<f64>, Mat<f64>, usize)> {
    let n = body.n();
    let total: usize = slices.iter().map(|s| s.lambdas.len()).sum();
    let mut lambdas = Vec::with_capacity(total);
    let mut v = Mat::<f64>::zeros(n, total);
    let mut starts = Vec::new();
    for s in &slices {
        starts.push(lambdas.len());
        v.as_mut()
            .subcols_mut(lambdas.len(), s.lambdas.len())
            .copy_from(&s.vectors);
        lambdas.extend_from_slice(&s.lambdas);
    }
    starts.push(total);
    let mut repaired = 0;
    for k in 1..slices.len() {
        let (a, mid, b) = (starts[k - 1], starts[k], starts[k + 1]);
        let (left, right) = (
            v.as_ref().subcols(a, mid - a),
            v.as_ref().subcols(mid, b - mid),
        );
        let gram = left.transpose() * body.pencil().mul(Coefficient::Mass, right);
        // the columns of a pair whose M-inner product exceeds 1e-13: a combination of them is
        // M-orthogonal to every other column (within 1e-13 across the bound, to rounding in its
        // own slice), so the Rayleigh–Ritz step needs only them
        let lost = |i: usize, j: usize| gram[(i, j)].abs() > 1e-13;
        let cols: Vec<usize> = (0..gram.nrows())
            .filter(|&i| (0..gram.ncols()).any(|j| lost(i, j)))
            .map(|i| a + i)
            .chain(
                (0..gram.ncols())
                    .filter(|&j| (0..gram.nrows()).any(|i| lost(i, j)))
                    .map(|j| mid + j),
            )
            .collect();
        if cols.is_empty() {
            continue;
        }
        let w = Mat::from_fn(n, cols.len(), |r, c| v[(r, cols[c])]);
        let (l, x) = rayleigh_ritz(body, &w)?;
        // the columns are ascending and the new pairs too: each keeps its place in the order
        for (c, &col) in cols.iter().enumerate() {
            lambdas[col] = l[c];
            v.as_mut().col_mut(col).copy_from(x.col(c));
        }
        repaired += 1;
    }
    Ok((lambdas, v, repaired))
}

/// Rayleigh–Ritz of (K, M) on span W (W nearly M-orthonormal): B = WᵀMW = U D Uᵀ,
/// B^{-1/2} = U D^{-1/2} Uᵀ, C = B^{-1/2} WᵀKW B^{-1/2} = Y Θ Yᵀ, X = W B^{-1/2} Y.
fn rayleigh_ritz(body: &Body, w: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>)> {
    let k = w.ncols();
    let b = w.transpose() * body.pencil().mul(Coefficient::Mass, w.as_ref());
    let a = w.transpose() * body.pencil().mul(Coefficient::Stiffness, w.as_ref());
    let fail = || Error::NotConverged("dense Rayleigh–Ritz across slices did not converge".into());
    let (db, ub) = sym_eigen(b.as_ref()).ok_or_else(fail)?;
    if db.iter().any(|&d| !(d > 0.5)) {
        return Err(Error::NotConverged(
            "vectors of neighbouring slices are nearly dependent (M-Gram eigenvalue below 1/2): a mode was found twice".into(),
        ));
    }
    let half = Mat::from_fn(k, k, |i, j| {
        (0..k)
            .map(|l| ub[(i, l)] * ub[(j, l)] / db[l].sqrt())
            .sum::<f64>()
    });
    let (theta, y) = sym_eigen((&half * sym(a.as_ref()) * &half).as_ref()).ok_or_else(fail)?;
    Ok((theta, w * (&half * y)))
}
