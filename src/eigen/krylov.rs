//! Krylov–Schur with locking on S = (K − σM)⁻¹ M in the M-inner product: the default
//! iteration of one spectrum slice (docs/design.md §3.6).
//!
//! The basis Q (N × (m+1)) is M-orthonormal. Its first `nl` columns are **locked**: converged
//! Ritz vectors, deflated — every new vector is M-orthogonalized against them, and they take no
//! further part in the Rayleigh–Ritz step. The active columns satisfy the Krylov–Schur relation
//!
//! ```text
//! S Q_a = Q_a T_a + q b_aᵀ,      residual of the Ritz pair (θ_i, Q_a y_i): ‖S x − θ x‖_M = |b_aᵀ y_i|.
//! ```
//!
//! Each restart sorts the Ritz values by |θ| (nearest to σ first), locks the leading run of
//! converged ones, keeps the next best (thick restart) and expands the basis again. M Q is
//! kept beside Q, so a step costs one solve, one product with M and the Gram–Schmidt passes:
//! the block Lanczos step against the columns it couples to, then one full classical pass for
//! the whole block against every column before it (Q and MQ read once per block of b vectors;
//! a second pass only where DGKS's test asks for it), then among the block's own columns.
//! The full pass is the reorthogonalization that keeps Q M-orthonormal to rounding: after the
//! Lanczos step only rounding is left along the older columns, so one pass removes it where
//! classical Gram–Schmidt against the whole basis needs two (the cancellation of S q against
//! its own Ritz directions happens in the Lanczos step).
//!
//! **Convergence.** The pair i is converged when |b_aᵀ y_i| ≤ tol·|θ_i| + 4ε·θ_max, θ_max the
//! largest active |θ| (the norm of S deflated of the locked pairs, on the Krylov space). The first term is ARPACK's
//! criterion (`tol·|θ|`) and SLEPc's relative one; it bounds the relative error of θ, so of
//! λ − σ, by tol. The second is the rounding floor of applying S in floating point: without it a
//! pair with |θ_i| ≪ θ_max (an eigenvalue much farther from σ than the nearest one) could be
//! asked for an accuracy no floating-point iteration reaches, and the iteration would never
//! stop. With both, every wanted pair meets the test in floating point. The floor is taken
//! over the active pairs only: the nearest eigenvalues (rigid modes, for a shift below the
//! spectrum) converge and are locked first, and once deflated they no longer set the floor
//! for the farther ones.
//!
//! **Attainable accuracy.** The solves' rounding (ε times the condition of K − σM, not of S on
//! the active space) can hold a pair's residual a little above that floor, restart after
//! restart. When the leading unconverged pair's relative residual has not halved over two
//! restarts and lies within [`ATTAINABLE`] × tol, it is the accuracy this factor attains: the
//! test's tolerance is raised to twice it (at most [`ATTAINABLE`] × tol) for the rest of the
//! slice, the pair is locked, and the largest relative residual of a locked pair is reported
//! ([`Iteration::residual`]). A symmetric pair's eigenvalue error is at most the residual
//! squared over the gap, so 1e-12 still gives λ far inside the 1e-9 the tests ask.
//!
//! **Counts and multiplicity.** A single-vector Krylov space holds, in exact arithmetic, one
//! direction of each eigenspace only: the second copy of a multiple eigenvalue (the cube's
//! symmetries make many) enters through rounding, slowly. The slice knows from the inertia how
//! many eigenvalues lie in it, so it does not wait for rounding: when a converged pair beyond
//! the slice's reach (farther from σ than any point of the slice) is locked while pairs of the
//! slice are still missing, every nearer eigenvector the Krylov space can see has been
//! found, and the iteration starts again from a fresh random vector M-orthogonal to the locked
//! ones — which has a component along every missing eigenvector.

use super::operator::ShiftInvert;
use super::options::EigenOptions;
use crate::dense::sym_eigen;
use crate::random::Xorshift;
use crate::{Error, Result};
use faer::{Mat, MatRef, Par};

/// The eigenvalues one slice wants: those in (lower, upper] (λ; infinite ends allowed),
/// `count` of them.
#[derive(Clone, Copy, Debug)]
pub(super) struct Target {
    pub lower: f64,
    pub upper: f64,
    pub count: usize,
}

impl Target {
    fn contains(&self, lambda: f64) -> bool {
        lambda > self.lower && lambda <= self.upper
    }

    /// The largest distance from σ of an eigenvalue of the slice: the farther finite end (an
    /// infinite lower end below σ < 0 holds no eigenvalue, K being semi-definite).
    fn reach(&self, sigma: f64) -> f64 {
        let up = if self.upper.is_finite() {
            (self.upper - sigma).abs()
        } else {
            f64::INFINITY
        };
        let lo = if self.lower.is_finite() {
            (sigma - self.lower).abs()
        } else {
            0.0
        };
        up.max(lo)
    }
}

/// What one slice's iteration did.
#[derive(Clone, Debug, Default)]
pub(super) struct Iteration {
    pub solves: usize,
    pub restarts: usize,
    /// Fresh starts after a missed copy of a multiple eigenvalue.
    pub fresh_starts: usize,
    /// Largest relative residual ‖S x − θ x‖_M / |θ| of a returned pair.
    pub residual: f64,
}

/// How far above the requested tolerance a stagnated residual is accepted as the attainable
/// accuracy (see the module doc).
const ATTAINABLE: f64 = 100.0;

/// The `target.count` eigenpairs of (K, M) in the target interval, by Krylov–Schur with
/// locking on `op` with a basis of `m` vectors (count < m ≤ N, or m = N); (λ, M-orthonormal
/// vectors) in the order they converged. `progress(found)` is called after each restart;
/// `false` cancels.
///
/// `first`, when given, is [`estimate`]'s first expansion on this same `op` and `m`, which
/// the iteration continues instead of expanding again.
pub(super) fn solve(
    op: &mut ShiftInvert<'_>,
    target: Target,
    m: usize,
    opts: &EigenOptions,
    first: Option<Expanded>,
    progress: &mut dyn FnMut(usize) -> bool,
) -> Result<(Vec<f64>, Mat<f64>, Iteration)> {
    let n = op.n();
    let sigma = op.sigma;
    let count = target.count;
    let reach = target.reach(sigma);
    let mut it = Iteration::default();
    let (mut basis, mut expanded) = match first {
        Some(e) => {
            debug_assert_eq!(e.basis.m(), m);
            it.solves = e.solves;
            (e.basis, Some(e.me))
        }
        None => (Basis::new(op, m, block_size(opts, m, n))?, None),
    };
    // locked pairs: λ and whether they belong to the target
    let mut locked: Vec<(f64, bool)> = Vec::new();
    let mut found = 0usize;
    let mut start = 0usize;
    let (mut idle, mut fresh_idle) = (0usize, 0usize);
    // the tolerance in force (raised to an attained stagnation level) and the leading
    // unconverged pair's relative residual at the last restart
    let (mut tol, mut lead) = (opts.tol, f64::INFINITY);
    loop {
        let nl = locked.len();
        let found_before = found;
        let me = match expanded.take() {
            Some(me) => me,
            None => {
                let (solves, me) = basis.expand(op, nl, start)?;
                it.solves += solves;
                me
            }
        };
        let (theta, y, coupling) = basis.ritz(nl, me)?;
        let b: Vec<f64> = (0..coupling.ncols())
            .map(|i| coupling.col(i).norm_l2())
            .collect();
        let ma = me - nl;
        let bs = basis.block;
        let Basis { q, mq, h, seed, .. } = &mut basis;
        let theta_max = theta[0].abs();
        let exhausted = me == n && nl + ma == n;
        let converged =
            |i: usize| exhausted || b[i] <= tol * theta[i].abs() + 4.0 * f64::EPSILON * theta_max;
        // lock the leading converged run
        let (mut nc, mut beyond) = (0usize, false);
        while nc < ma && found < count && converged(nc) {
            let lambda = sigma + 1.0 / theta[nc];
            let inside = target.contains(lambda);
            found += usize::from(inside);
            if inside {
                it.residual = it.residual.max(b[nc] / theta[nc].abs());
            }
            beyond |= !inside && (lambda - sigma).abs() > reach * (1.0 + 1e-9);
            locked.push((lambda, inside));
            nc += 1;
        }
        let done = found == count;
        // columns left after the locked ones; a restart needs room for the continuation block
        let room = m - (nl + nc);
        if !done && room < bs + 1 {
            return Err(Error::NotConverged(format!(
                "{found} of {count} modes found in the slice {}: the basis of {m} vectors is full of converged pairs; \
                 increase the Krylov dimension",
                describe(&target)
            )));
        }
        // thick restart: the locked run, then the best remaining Ritz vectors
        let remaining = count - found;
        // room for the continuation block: at most room − bs kept
        let ma_new = ma - nc;
        let keep_active = if done {
            0
        } else {
            (remaining + ma_new.saturating_sub(remaining) / 2)
                .clamp(1, room - bs)
                .min(ma_new)
        };
        let keep = nc + keep_active;
        // M Q Y from Q Y by one sparse product: cheaper than the dense (MQ) Y, and exact
        let qy = q.as_ref().subcols(nl, ma) * y.as_ref().subcols(0, keep);
        q.as_mut().subcols_mut(nl, keep).copy_from(&qy);
        op.mass_mul(qy.as_ref(), mq.as_mut().subcols_mut(nl, keep));
        if done {
            break;
        }
        let (a0, p) = (nl + nc, nl + keep);
        let last = q.as_ref().subcols(me, bs).to_owned();
        let mlast = mq.as_ref().subcols(me, bs).to_owned();
        q.as_mut().subcols_mut(p, bs).copy_from(&last);
        mq.as_mut().subcols_mut(p, bs).copy_from(&mlast);
        h.fill(0.0);
        for c in 0..keep_active {
            h[(a0 + c, a0 + c)] = theta[nc + c];
            for r in 0..bs {
                h[(p + r, a0 + c)] = coupling[(r, nc + c)];
            }
        }
        start = p;
        it.restarts += 1;
        // idle: restarts in a row that locked nothing and did not halve the leading
        // unconverged pair's relative residual
        let r = if nc < ma {
            b[nc] / theta[nc].abs()
        } else {
            0.0
        };
        idle = if nc == 0 && r > 0.5 * lead {
            idle + 1
        } else {
            0
        };
        lead = r;
        // the leading pair held at the solves' rounding: accept the level it holds
        if idle >= 2 && r <= ATTAINABLE * opts.tol {
            tol = tol.max((2.0 * r).min(ATTAINABLE * opts.tol));
        }
        // every eigenvector this Krylov space sees nearer than the slice's reach is locked yet
        // the inertia counts more (`beyond`), or the leading pair stagnates for 10 restarts (a
        // direction of a repeated eigenvalue the space lacks, which rounding grows too slowly):
        // start again from fresh vectors beside the locked ones
        let stalled = idle > 0 && idle % 10 == 0;
        if found > found_before {
            fresh_idle = 0;
        }
        if beyond || stalled {
            fresh_idle += 1;
            if fresh_idle > 3 {
                return Err(Error::NotConverged(format!(
                    "{found} of {count} modes found in the slice {}: three fresh starts found no further mode; an eigenvalue \
                     may lie within rounding of a slice bound — move the band ends slightly, or use smaller slices",
                    describe(&target)
                )));
            }
            it.fresh_starts += 1;
            h.fill(0.0);
            let a0 = locked.len();
            for r in 0..bs {
                *seed += 1;
                fresh_vector(op, q, mq, a0 + r, *seed)?;
            }
            start = a0;
        }
        if !progress(found) {
            return Err(Error::Cancelled);
        }
        if it.restarts > opts.max_restarts || idle > opts.patience {
            let worst = (nc..ma)
                .take(remaining)
                .map(|i| b[i] / theta[i].abs())
                .fold(0.0, f64::max);
            return Err(Error::NotConverged(format!(
                "{found} of {count} modes found in the slice {} after {} restarts ({} without a newly converged mode or progress); \
                 the largest relative Ritz residual of the rest is {worst:.1e} (tol {:.0e}); increase the Krylov dimension \
                 (now {m}) or use more slices",
                describe(&target),
                it.restarts,
                idle,
                tol
            )));
        }
    }
    let keep: Vec<usize> = (0..locked.len()).filter(|&i| locked[i].1).collect();
    let lambdas = keep.iter().map(|&i| locked[i].0).collect();
    let vectors = Mat::from_fn(n, keep.len(), |r, c| basis.q[(r, keep[c])]);
    Ok((lambdas, vectors, it))
}

/// The first expansion of a Krylov space: what [`solve`] would compute first, kept so that
/// [`solve`] continues from it.
pub(super) struct Expanded {
    basis: Basis,
    /// Columns expanded.
    me: usize,
    solves: usize,
}

impl Expanded {
    /// Solves it took.
    pub(super) fn solves(&self) -> usize {
        self.solves
    }
}

/// A rough λ of the k-th eigenvalue nearest σ: the k-th Ritz value of one Krylov space of
/// dimension m > k from a random start (no restart), and that space, which [`solve`] on the
/// same operator continues. Used to place a first shift when nothing about the spectrum is
/// known yet.
pub(super) fn estimate(
    op: &mut ShiftInvert<'_>,
    k: usize,
    m: usize,
    opts: &EigenOptions,
) -> Result<(f64, Expanded)> {
    let mut basis = Basis::new(op, m, block_size(opts, m, op.n()))?;
    let (solves, me) = basis.expand(op, 0, 0)?;
    let (theta, _, _) = basis.ritz(0, me)?;
    let lambda = op.sigma + 1.0 / theta[(k.max(1) - 1).min(me - 1)];
    Ok((lambda, Expanded { basis, me, solves }))
}

/// The block size: [`EigenOptions::block`], or 1 when m + block vectors do not fit in R^N
/// (the Krylov space may then be all of R^N, which one vector at a time handles exactly).
fn block_size(opts: &EigenOptions, m: usize, n: usize) -> usize {
    let b = opts.block.max(1);
    if m + b <= n {
        b
    } else {
        1
    }
}

/// The block Krylov–Schur basis: Q and M Q (N × (m+b)), the projected matrix H
/// ((m+b) × m, banded upper Hessenberg with b sub-diagonals), the block size b and the seed of
/// the next fresh random vector.
struct Basis {
    q: Mat<f64>,
    mq: Mat<f64>,
    h: Mat<f64>,
    block: usize,
    seed: u64,
}

impl Basis {
    /// m + b columns, the first b random and M-orthonormal.
    fn new(op: &ShiftInvert<'_>, m: usize, block: usize) -> Result<Self> {
        let n = op.n();
        let mut b = Basis {
            q: Mat::zeros(n, m + block),
            mq: Mat::zeros(n, m + block),
            h: Mat::zeros(m + block, m),
            block,
            seed: 0,
        };
        for j in 0..block {
            b.seed = j as u64;
            fresh_vector(op, &mut b.q, &mut b.mq, j, b.seed)?;
        }
        Ok(b)
    }

    /// Krylov dimension m.
    fn m(&self) -> usize {
        self.h.ncols()
    }

    /// Expands from column `start` in blocks of b: the b columns j..j+b go through one block
    /// solve W = S Q_j, then are M-orthogonalized (coefficients recorded from column `nl` on):
    /// 1. **the Lanczos step**, one classical Gram–Schmidt pass against the columns W couples
    ///    to in exact arithmetic: H is symmetric and banded, so the previous block and Q_j for
    ///    j > `start`; every active column for the first block after a restart (the arrow of
    ///    the kept Ritz vectors);
    /// 2. **full reorthogonalization**, one pass for the whole block against every column
    ///    before it (locked ones included), which removes what rounding left (Q and MQ are read
    ///    once per block);
    /// 3. its columns against each other, and column c becomes j + b + c. Where the full pass
    ///    removed more than it left (DGKS's test, η = 1/√2: the cancellation was in the full
    ///    pass, not in the Lanczos step) the column goes through the full pass once more.
    ///
    /// Stops at m_e = start + b⌊(m − start)/b⌋; returns (solves, m_e).
    fn expand(
        &mut self,
        op: &mut ShiftInvert<'_>,
        nl: usize,
        start: usize,
    ) -> Result<(usize, usize)> {
        let (n, m, bs) = (op.n(), self.m(), self.block);
        let me = start + bs * ((m - start) / bs);
        let mut mw = Mat::<f64>::zeros(n, 1);
        for j in (start..me).step_by(bs) {
            let mut w = self.mq.as_ref().subcols(j, bs).to_owned();
            op.solve_in_place(w.as_mut());
            let base = j + bs;
            let lo = if j == start { nl } else { (j - bs).max(nl) };
            let (mut coef, full) = lanczos_step_and_full_pass(
                self.q.as_ref().subcols(0, base),
                self.mq.as_ref().subcols(0, base),
                &mut w,
                lo,
                op.par,
            );
            for c in 0..bs {
                let top = base + c;
                // then against the block's earlier columns
                let mut wc = w.as_ref().subcols(c, 1).to_owned();
                let mut inner = project_out(
                    self.q.as_ref().subcols(base, c),
                    self.mq.as_ref().subcols(base, c),
                    &mut wc,
                    Par::Seq,
                );
                op.mass_mul(wc.as_ref(), mw.as_mut());
                let mut beta = (wc.col(0).transpose() * mw.col(0)).max(0.0).sqrt();
                if full.col(c).squared_norm_l2() > inner.squared_norm_l2() + beta * beta {
                    let again = project_once(
                        self.q.as_ref().subcols(0, top),
                        self.mq.as_ref().subcols(0, top),
                        &mut wc,
                        op.par,
                    );
                    let mut before = coef.as_mut().col_mut(c);
                    before += again.as_ref().subrows(0, base).col(0);
                    let mut within = inner.as_mut().col_mut(0);
                    within += again.as_ref().subrows(base, c).col(0);
                    op.mass_mul(wc.as_ref(), mw.as_mut());
                    beta = (wc.col(0).transpose() * mw.col(0)).max(0.0).sqrt();
                }
                let projected = coef.col(c).squared_norm_l2() + inner.squared_norm_l2();
                let norm0 = (projected + beta * beta).sqrt();
                for i in nl..base {
                    self.h[(i, j + c)] = coef[(i, c)];
                }
                for d in 0..c {
                    self.h[(base + d, j + c)] = inner[(d, 0)];
                }
                if beta > 1e-12 * norm0 {
                    self.h[(top, j + c)] = beta;
                    self.q.as_mut().col_mut(top).copy_from(wc.col(0) / beta);
                    self.mq.as_mut().col_mut(top).copy_from(mw.col(0) / beta);
                } else {
                    // S q ∈ span Q: an invariant subspace; go on from a fresh direction
                    self.h[(top, j + c)] = 0.0;
                    self.seed += 1;
                    if top < n {
                        fresh_vector(op, &mut self.q, &mut self.mq, top, self.seed)?;
                    }
                }
            }
        }
        Ok((me - start, me))
    }

    /// Rayleigh–Ritz on the active block (columns nl..m_e): Ritz values θ by |θ| descending,
    /// their vectors Y and the coupling H[m_e..m_e+b, nl..m_e]·Y (b × active), whose column
    /// norms are the residuals ‖S x − θ x‖_M.
    fn ritz(&self, nl: usize, me: usize) -> Result<(Vec<f64>, Mat<f64>, Mat<f64>)> {
        let (h, bs) = (&self.h, self.block);
        let ma = me - nl;
        let (s, u) = sym_eigen(h.as_ref().submatrix(nl, nl, ma, ma)).ok_or_else(|| {
            Error::NotConverged("the dense Ritz eigenproblem did not converge".into())
        })?;
        let mut order: Vec<usize> = (0..ma).collect();
        order.sort_by(|&a, &b| s[b].abs().total_cmp(&s[a].abs()));
        let theta: Vec<f64> = order.iter().map(|&i| s[i]).collect();
        let y = Mat::from_fn(ma, ma, |r, c| u[(r, order[c])]);
        let coupling = h.as_ref().submatrix(me, nl, bs, ma) * &y;
        Ok((theta, y, coupling))
    }
}

/// "(lo, hi] Hz" of a target, for messages.
fn describe(t: &Target) -> String {
    let hz = |l: f64| {
        if l.is_finite() {
            format!("{:.6e}", crate::units::lambda_to_hz(l))
        } else if l < 0.0 {
            "-inf".into()
        } else {
            "inf".into()
        }
    };
    format!("({}, {}] Hz", hz(t.lower), hz(t.upper))
}

/// Writes at column `j` of (Q, MQ) a random unit vector M-orthogonal to columns 0..j.
fn fresh_vector(
    op: &ShiftInvert<'_>,
    q: &mut Mat<f64>,
    mq: &mut Mat<f64>,
    j: usize,
    seed: u64,
) -> Result<()> {
    let mut w = random_vector(op.n(), seed);
    project_out(
        q.as_ref().subcols(0, j),
        mq.as_ref().subcols(0, j),
        &mut w,
        op.par,
    );
    let mut mw = Mat::<f64>::zeros(w.nrows(), 1);
    op.mass_mul(w.as_ref(), mw.as_mut());
    let beta = (w.col(0).transpose() * mw.col(0)).max(0.0).sqrt();
    if !(beta > 0.0) {
        return Err(Error::NotConverged(
            "no start vector M-orthogonal to the converged modes is left (the basis spans R^N)"
                .into(),
        ));
    }
    q.as_mut().col_mut(j).copy_from(w.col(0) / beta);
    mq.as_mut().col_mut(j).copy_from(mw.col(0) / beta);
    Ok(())
}

/// W ← W − Q (MQ)ᵀ W: one classical Gram–Schmidt pass in the M-inner product against the
/// M-orthonormal columns of Q (MQ = M Q), reading Q and MQ once for all the columns of W;
/// returns the coefficients (MQ)ᵀ W.
pub(crate) fn project_once(
    q: MatRef<'_, f64>,
    mq: MatRef<'_, f64>,
    w: &mut Mat<f64>,
    par: Par,
) -> Mat<f64> {
    use faer::linalg::matmul::matmul;
    use faer::Accum;
    let mut coef = Mat::<f64>::zeros(q.ncols(), w.ncols());
    matmul(
        coef.as_mut(),
        Accum::Replace,
        mq.transpose(),
        w.as_ref(),
        1.0,
        par,
    );
    matmul(w.as_mut(), Accum::Add, q, coef.as_ref(), -1.0, par);
    coef
}

/// The block Lanczos step and the full reorthogonalization (module doc): W is first
/// M-orthogonalized by one classical pass against the columns `near..` of Q (those it couples
/// to in exact arithmetic), then by one pass against all of Q. Returns the coefficients summed
/// over both passes, (MQ)ᵀ W of the W given, and those of the full pass alone: where they
/// outweigh what is left of W, DGKS's test asks for one more pass.
pub(crate) fn lanczos_step_and_full_pass(
    q: MatRef<'_, f64>,
    mq: MatRef<'_, f64>,
    w: &mut Mat<f64>,
    near: usize,
    par: Par,
) -> (Mat<f64>, Mat<f64>) {
    let k = q.ncols() - near;
    let local = project_once(q.subcols(near, k), mq.subcols(near, k), w, par);
    let full = project_once(q, mq, w, par);
    let mut coef = full.clone();
    let mut rows = coef.as_mut().subrows_mut(near, k);
    rows += &local;
    (coef, full)
}

/// W ← W − Q (MQ)ᵀ W, twice: classical Gram–Schmidt in the M-inner product against the
/// M-orthonormal columns of Q (MQ = M Q), with the second pass that makes it as accurate as
/// the modified one (CGS2); returns the coefficients summed over both passes. Each pass reads
/// Q and MQ once for all the columns of W, on the threads `par` (one per slice when slices
/// run side by side: nested parallel products only contend).
fn project_out(q: MatRef<'_, f64>, mq: MatRef<'_, f64>, w: &mut Mat<f64>, par: Par) -> Mat<f64> {
    let mut coef = project_once(q, mq, w, par);
    coef += project_once(q, mq, w, par);
    coef
}

/// A deterministic pseudo-random vector (xorshift, uniform in [−½, ½)); `seed` 0 is the start
/// vector of both backends.
pub(super) fn random_vector(n: usize, seed: u64) -> Mat<f64> {
    let mut rng = Xorshift::new(0x2545f4914f6cdd1d ^ seed.wrapping_mul(0x9e3779b97f4a7c15));
    Mat::from_fn(n, 1, |_, _| rng.next_centred())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::Body;
    use crate::fe::{bar_model, BoxSpec};

    /// After an expansion, Q is M-orthonormal and the recorded H is the projection
    /// (MQ)ᵀ S Q of S: the Lanczos step's coefficients and the full pass's are both in H, and
    /// one full pass leaves Q orthonormal to rounding (`Basis::expand`).
    #[test]
    fn one_full_pass_keeps_q_orthonormal_and_h_the_projection() {
        let spec = BoxSpec {
            elements: [1, 2, 24],
            ..BoxSpec::paper_bar()
        };
        let body = Body::new(&bar_model(&spec).unwrap()).unwrap();
        // below the spectrum (free bar: K − σM positive definite for σ < 0)
        let sigma = -1e4;
        let mut op = ShiftInvert::new(
            body.pencil(),
            body.symbolic().unwrap(),
            sigma,
            Par::Seq,
            4,
            body.factor_storage(),
        )
        .unwrap();
        let (m, b) = (80, 4);
        let mut basis = Basis::new(&op, m, b).unwrap();
        let (solves, me) = basis.expand(&mut op, 0, 0).unwrap();
        assert_eq!((solves, me), (m, m));
        let (q, mq) = (
            basis.q.as_ref().subcols(0, me + b),
            basis.mq.as_ref().subcols(0, me + b),
        );
        let gram = q.transpose() * mq;
        let lost = (0..me + b)
            .flat_map(|i| (0..me + b).map(move |j| (i, j)))
            .map(|(i, j)| (gram[(i, j)] - f64::from(u8::from(i == j))).abs())
            .fold(0.0, f64::max);
        assert!(lost < 1e-13, "Q is M-orthonormal only to {lost:.1e}");
        let mut sq = basis.mq.as_ref().subcols(0, me).to_owned();
        for j in (0..me).step_by(b) {
            op.solve_in_place(sq.as_mut().subcols_mut(j, b));
        }
        let projection = mq.transpose() * &sq;
        let h = basis.h.as_ref().submatrix(0, 0, me + b, me);
        let scale = projection.norm_max();
        let off = (&projection - h).norm_max() / scale;
        assert!(off < 1e-12, "H differs from (MQ)ᵀSQ by {off:.1e} relative");
    }
}
