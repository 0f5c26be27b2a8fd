//! Responses of a body with proportional damping at any frequency from one real
//! factorization (docs/design.md §3.10); with a loss factor, fitted coefficients of an
//! explicit D, and a low-rank remainder answered beside the load (§3.12), the same holds with
//! A_p(iω) = c_k(K − μM), μ = c_m/c_k, and an r × r correction per frequency.
//!
//! With D = αM + βK (or D = 0), A(iω) = (1 + iωβ)(K − μM) with μ(ω) = (ω² − iωα)/(1 + iωβ):
//! every frequency is a shift of one real pencil. With a real σ that is no eigenvalue (below
//! the spectrum K − σM is positive definite and its factor a Cholesky factor; inside it the
//! factor is an indefinite LDLᵀ, whose inertia also counts the eigenvalues below σ, so that
//! σ at the band's top gives line-fitting its count of the band's modes with the same
//! factorization) and the M-self-adjoint S = (K − σM)⁻¹M,
//!
//! ```text
//! (K − μM) x = b   ⇔   (I − τS) x = b₀,     τ = μ − σ,   b₀ = (K − σM)⁻¹ b,
//! ```
//!
//! and the block Krylov space K_k(S, b₀) does not depend on τ (shift invariance): one space
//! serves every frequency. Block Lanczos with full M-reorthogonalization (the Lanczos step,
//! then one classical Gram–Schmidt pass against the whole basis, as in
//! [`crate::eigen`]'s Krylov–Schur) builds an M-orthonormal basis Q with
//!
//! ```text
//! S Q = Q T + R E_lastᵀ,     T = QᵀMSQ (k × k, symmetric),     b₀ = Q E₁ R₀,
//! ```
//!
//! R the part of the last block's image outside the space. The Lanczos relation's Galerkin
//! solution x = Q y, (I − τT) y = E₁R₀, then has the residual
//!
//! ```text
//! (I − τS) x − b₀ = −τ R y_last,     ‖·‖_M² = |τ|² y_lastᴴ G y_last,   G = RᵀMR
//! ```
//!
//! (times K − σM, the residual b − (K − μM)x itself), known at every frequency for O(b²p)
//! work, nothing of size N, relative to ‖b₀‖_M = ‖R₀ e_j‖. With T = ZΘZᵀ,
//! y(τ) = Z (I − τΘ)⁻¹ ZᵀE₁R₀. The space grows by blocks until this estimated relative
//! residual at the frequencies asked is ≤ [`GROW_TO`] (or a tighter target the caller asks
//! for after a failed certificate).
//!
//! The responses themselves are read from the space with the pencil's own projection,
//! QᵀKQ = ZΛZᵀ formed with K (one product with each new block; QᵀMQ = I):
//!
//! ```text
//! x(μ) = Q Z (Λ − μI)⁻¹ ZᵀQᵀb,
//! ```
//!
//! the Galerkin solution of (K − μM)x = b in the same space, which matches the moments of
//! the response about σ as the Lanczos one does (Grimme 1997): a superposition of the
//! space's Ritz pairs (λ_j, QZe_j), converged (the band's modes) or not (they carry the
//! residual flexibility of the modes above). The Lanczos relation holds only to the rounding
//! of the solves, which is relative to ‖S q‖ and, next to an interior shift, σ/|λ − σ| times
//! the response's scale: its solution carries that (on the 3 m bar, normwise backward errors
//! of 4–9e-14 about the band's top, and every frequency factored), while the projection
//! with K carries the rounding of K's products (5e-15–1e-14 there, every frequency
//! answered). Each response is certified by its true residual
//! b − A(iω)x, computed with the exact pencil ([`crate::factor::certify`]): componentwise
//! backward error ≤ [`CERTIFIED_BACKWARD_ERROR`], relative residual ≤
//! [`CERTIFIED_RELATIVE_RESIDUAL`] or normwise backward error ≤
//! [`CERTIFIED_NORMWISE_BACKWARD_ERROR`] per column. A response that fails is left to a factorization of A(iω) by the caller.
//!
//! Next to an undamped eigenvalue the backward error stays small while the response is
//! meaningless: [`Solution::forward_error_estimate`] multiplies it by the amplification of
//! the mode nearest μ, with the rounding of τ in it ([`amplification`]), and a caller factors
//! such a frequency instead.
//!
//! Cost: one real factorization (a quarter of a complex one's flops), and one block solve
//! and one product with K per block of the basis; per frequency a k × p solve, the product
//! Q y (O(N k p)) and the certificate (one pass over the pattern). Memory: Q and MQ, 16 N k bytes, and per worker
//! the blocks of one response ([`SolutionBuffers`], kept from one frequency to the next).
//!
//! The shift-invariant Krylov space for shifted systems: Freund, "Solution of shifted linear
//! systems by quasi-minimal residual iterations" (1993); the same Galerkin space is the
//! moment-matching projection about σ (Grimme 1997, rational Krylov with one pole).

use crate::dense::{scaled_products_into, sym_eigen, MatStack};
use crate::eigen::{lanczos_step_and_full_pass, project_once, ShiftInvert};
use crate::factor::{certify, Certificate, CertifyBuffers, FactorPlace};
use crate::pencil::{Coefficient, Pencil};
use crate::proportional::{Proportional, Remainder};
use crate::rigid::RigidBody;
use crate::units::hz_to_omega;
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::{c64, Accum, Mat, MatRef, Par};
use std::sync::Arc;

/// The space grows until the estimated (M-norm, preconditioned) relative residual at every
/// frequency asked is at most this: [`ResponseSpace::rows_at`] answers such a frequency
/// (uncertified rows that rank the sampling loop's candidates need no more), and the sweep
/// certifies the responses it keeps from there, asking for a target 100× tighter for those
/// that fail. The certificate measures the residual itself in another norm, so the estimate
/// is no proof either way: on the 3 m bar (N = 16 236) at 975–1000 Hz an estimate of 2–4e-13
/// came with componentwise backward errors of 1.1–2.2e-12, just above
/// [`CERTIFIED_BACKWARD_ERROR`]; on the 77 229-DoF crank with dashpots (§3.12) an estimate of
/// 7.3e-12 at 1 536 Hz, next to a mode, passed its certificate, where growing to 1e-12 had
/// taken the space from 180 to 270 vectors.
pub const GROW_TO: f64 = 1e-10;

/// A response passes when each column's relative residual ‖b − A x‖₂/‖b‖₂ is at most this…
pub const CERTIFIED_RELATIVE_RESIDUAL: f64 = 1e-10;

/// …or its componentwise backward error is at most this (the test a lightly damped,
/// ill-conditioned A(iω) needs: its exact solution's residual in floating point is about
/// ε‖A‖‖x‖, far above ε‖b‖)…
pub const CERTIFIED_BACKWARD_ERROR: f64 = 1e-12;

/// …or its normwise backward error (bounded by maxᵢ |r|ᵢ / maxᵢ (|A||x| + |b|)ᵢ) is at most
/// this, about 45ε: what a backward-stable solve achieves. A response x = Q c carries
/// rounding of about ε‖x‖ in every entry, so where |A||x| is small its componentwise backward
/// error has a floor no larger space lowers (1.6e-12 at 13 kHz on the 77 229-DoF crank, whose
/// normwise one is 1.4e-15; docs/design.md §3.10).
pub const CERTIFIED_NORMWISE_BACKWARD_ERROR: f64 = 1e-14;

/// A new basis vector is dropped when Gram–Schmidt leaves less than this fraction of the
/// M-norm of the block image it came from: its direction is already in the space to
/// rounding (deflation; the space is then invariant in that direction).
pub(crate) const DEFLATE: f64 = 1e-12;

/// A remainder whose relative load on the rigid modes ([`Remainder::rigid_load`]) is above
/// this does not leave a free body's elastic response to a low-rank update.
const RIGID_LOAD: f64 = 1e-8;

/// A projected resolvent: at the shift τ the coefficients are Z diag(1/(a_j − τb_j)) C.
/// The Lanczos matrix T = ZΘZᵀ gives a = 1, b = θ, C = ZᵀE₁R₀ (the estimates); the
/// pencil's projection QᵀKQ = ZΛZᵀ (QᵀMQ = I) gives a = λ − σ, b = 1, C = ZᵀQᵀ[B U] (the
/// answers; module doc).
struct Ritz {
    a: Vec<f64>,
    b: Vec<f64>,
    z: Mat<f64>,
    c: Mat<f64>,
}

/// A solution at one frequency and how it was certified; X itself is in the
/// [`SolutionBuffers`] it was computed in.
pub(crate) struct Solution {
    /// X in the space's basis: X = Q c (k × p, k the basis's dimension when answered;
    /// [`ShiftedSpace::basis`]). The basis only grows, so c stays valid as it does.
    pub coefficients: Mat<c64>,
    /// Its true residual's measures.
    pub certificate: Certificate,
    /// How much K − μM amplifies a relative perturbation of K and M along the space's mode
    /// nearest μ, with the rounding of the shift in it ([`amplification`]; infinite at an
    /// undamped eigenvalue).
    pub amplification: f64,
}

impl Solution {
    /// The response passes ([`CERTIFIED_BACKWARD_ERROR`], [`CERTIFIED_RELATIVE_RESIDUAL`] or
    /// [`CERTIFIED_NORMWISE_BACKWARD_ERROR`] per column).
    pub fn certified(&self) -> bool {
        self.certificate.passes(
            CERTIFIED_BACKWARD_ERROR,
            CERTIFIED_RELATIVE_RESIDUAL,
            CERTIFIED_NORMWISE_BACKWARD_ERROR,
        )
    }

    /// An estimate of the relative forward error: the worst componentwise backward error
    /// times [`Self::amplification`] (at least 1). Next to an undamped eigenvalue the
    /// backward error stays small while the solution is meaningless; this is what shows it,
    /// as the probe shows it for a factored frequency.
    pub fn forward_error_estimate(&self) -> f64 {
        let worst = self
            .certificate
            .backward_error
            .iter()
            .copied()
            .fold(0.0, f64::max);
        worst * self.amplification.max(1.0)
    }
}

/// The N-sized blocks of [`ShiftedSpace::solve`], kept by a worker from one frequency to
/// the next: allocated anew, their pages are faulted in and zeroed on every call.
pub(crate) struct SolutionBuffers {
    /// Q [Re c, Im c] (N × 2p).
    parts: Mat<f64>,
    /// X = Pᵀ A(iω)⁻¹ P B (N × p) of the last response.
    x: Mat<c64>,
    certify: CertifyBuffers,
}

impl Default for SolutionBuffers {
    fn default() -> Self {
        SolutionBuffers {
            parts: Mat::zeros(0, 0),
            x: Mat::zeros(0, 0),
            certify: CertifyBuffers::default(),
        }
    }
}

impl SolutionBuffers {
    /// X of the last [`ShiftedSpace::solve`] (N × p).
    pub fn x(&self) -> MatRef<'_, c64> {
        self.x.as_ref()
    }
}

/// `m` as an `r` × `c` matrix: kept when it has that shape (its values then stale), else
/// a new one.
fn shaped<T: faer::traits::ComplexField>(m: &mut Mat<T>, r: usize, c: usize) {
    if m.nrows() != r || m.ncols() != c {
        *m = Mat::zeros(r, c);
    }
}

/// What the sweep asks of a space that answers every frequency from one factorization: the
/// shifted space (§3.10, §3.12) and the linearized one (§3.13, [`crate::linearized_space`]).
pub(crate) trait ResponseSpace: Send + Sync {
    /// The basis Q (N × k) that [`Solution::coefficients`] refer to. It only grows: a
    /// response's coefficients index its first columns for the space's whole life.
    fn basis(&self) -> MatRef<'_, f64>;

    /// Vectors in the basis.
    fn dim(&self) -> usize;

    /// The basis alone, the factor and the rest of the space dropped.
    fn into_basis(self: Box<Self>) -> Mat<f64>;

    /// The space may still grow (it is neither invariant nor full).
    fn can_grow(&self) -> bool;

    /// Its shift lies inside the spectrum (line-fitting's count made it, §3.10): its
    /// responses carry the solves' rounding amplified by σ/|λ − σ| next to the shift, which a
    /// space below the spectrum does not.
    fn interior(&self) -> bool;

    /// Block solves with the space's factorization so far.
    fn block_solves(&self) -> usize;

    /// Where the space's factor is, and the bytes it moved.
    fn factor_place(&self) -> FactorPlace;

    /// Grows the space until the estimated relative residual at every frequency of
    /// `freqs_hz` is ≤ `target`, the space is invariant, or it is full.
    ///
    /// # Errors
    /// [`Error::NotConverged`] when the projected matrix has no eigendecomposition.
    fn grow_for(&mut self, freqs_hz: &[f64], target: f64) -> Result<()>;

    /// The response at `freq_hz` (X left in `buffers`) with its certificate; after
    /// [`Self::grow_for`].
    ///
    /// # Errors
    /// [`Error::NotConverged`] when the space was not grown first.
    fn solve(&self, freq_hz: f64, par: Par, buffers: &mut SolutionBuffers) -> Result<Solution>;

    /// The response at the rows `rows` at each of `freqs_hz`, not certified; `None` where the
    /// estimated residual is above [`GROW_TO`].
    fn rows_at(&mut self, freqs_hz: &[f64], rows: &[usize]) -> Arc<Rows>;

    /// [`Self::rows_at`]'s answer when it was last asked the same and the space has not
    /// grown since.
    fn answer(&self, freqs_hz: &[f64], rows: &[usize]) -> Option<Arc<Rows>>;
}

/// The growing Krylov space of one body and load; see the module doc.
pub(crate) struct ShiftedSpace<'a> {
    pencil: &'a Pencil,
    op: ShiftInvert<'a>,
    rigid: Option<&'a RigidBody>,
    sigma: f64,
    /// A(iω) = c_k(K − μM) + the remainder (§3.12).
    proportional: Proportional,
    /// The damping's low-rank remainder U G(ω) Uᵀ: the space answers U beside the load and
    /// [`Remainder::correction`] adds it to every response (§3.12).
    remainder: Option<&'a Remainder>,
    /// P B (N × p), real.
    load: Mat<f64>,
    /// M-orthonormal basis (N × k) and M Q.
    q: Mat<f64>,
    mq: Mat<f64>,
    /// T = QᵀMSQ as computed (symmetrized when decomposed).
    t: Mat<f64>,
    /// QᵀM b₀ (k × p; only the first block's rows are non-zero).
    r0: Mat<f64>,
    /// QᵀKQ (k × k), formed with K: the answers' projection (module doc).
    kq: Mat<f64>,
    /// Qᵀ[B U] (k × (p + r)).
    qb: Mat<f64>,
    /// First column of the last block.
    last: usize,
    /// R (N × b): the last block's image outside the space; no columns when the space is
    /// invariant.
    next: Mat<f64>,
    /// M R, kept for the next block's orthonormalization.
    next_m: Mat<f64>,
    /// G = RᵀMR.
    next_gram: Mat<f64>,
    /// The M-norm of each column of the block image R came from (of b₀ for the first block):
    /// the scale of the deflation test ([`DEFLATE`]).
    next_scale: Vec<f64>,
    /// T's decomposition, for the estimates.
    lanczos: Option<Ritz>,
    /// QᵀKQ's, for the answers.
    ritz: Option<Ritz>,
    max_dim: usize,
    /// Columns Q and MQ have room for: they grow by doubling, not by a copy per block (each
    /// copy of 16 N k bytes faults in fresh pages; a sixth of the 10⁶-DoF bar's seed step).
    capacity: usize,
    block_solves: usize,
    par: Par,
    /// The last [`Self::rows_at`] answer, kept for [`Self::answer`]: the same question to a
    /// space that has not grown has the same answer (the sampling loop asks its candidate
    /// grid at every step).
    answered: Option<RowsAnswer>,
    /// The estimates [`Self::grow_for`] ended on (the space's dimension, the frequencies,
    /// the estimates): [`Self::rows_at`] asks the same right after it.
    estimated: Option<(usize, Vec<f64>, Vec<f64>)>,
}

/// [`ResponseSpace::rows_at`]'s question (frequencies, rows, the space's dimension) and its
/// answer.
pub(crate) struct RowsAnswer {
    pub freqs_hz: Vec<f64>,
    pub rows: Vec<usize>,
    pub dim: usize,
    pub h: Arc<Rows>,
}

impl RowsAnswer {
    /// The answer, when asked the same at the same dimension.
    pub fn same(&self, freqs_hz: &[f64], rows: &[usize], dim: usize) -> Option<Arc<Rows>> {
        (self.dim == dim && self.freqs_hz == freqs_hz && self.rows == rows)
            .then(|| Arc::clone(&self.h))
    }
}

/// The response at some rows at each of a set of frequencies, from a shifted Krylov space
/// ([`ShiftedSpace::rows_at`]): `None` at a frequency the space does not answer.
#[derive(Debug)]
pub struct Rows {
    h: MatStack,
    answered: Vec<bool>,
}

impl Rows {
    /// The responses `h` (one per frequency) and whether the space answers each.
    pub(crate) fn new(h: MatStack, answered: Vec<bool>) -> Self {
        Rows { h, answered }
    }

    /// The number of frequencies asked.
    pub fn len(&self) -> usize {
        self.answered.len()
    }

    /// The response at the k-th frequency (rows × inputs), where the space answers it.
    pub fn get(&self, k: usize) -> Option<MatRef<'_, c64>> {
        self.answered[k].then(|| self.h.get(k))
    }
}

impl<'a> ShiftedSpace<'a> {
    /// Factors K − σM and starts the space from b₀ = (K − σM)⁻¹ [`load`, U], where `load`
    /// is P B (rigid-free on a free body) and U spans the damping's low-rank remainder, if
    /// any (§3.12). σ < 0 gives a Cholesky factor; σ inside the spectrum an indefinite one
    /// whose inertia counts the eigenvalues below σ ([`Self::below`]). The basis holds at
    /// most `max_dim` vectors.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] for a σ that is not finite, a damping that is not
    /// proportional but for a low-rank remainder, or a remainder that loads the rigid motion
    /// of a free body; [`Error::Singular`] when σ is an eigenvalue to working precision; the
    /// factorization's errors.
    pub fn new(
        body: &'a crate::body::Body,
        load: Mat<f64>,
        sigma: f64,
        max_dim: usize,
        par: Par,
    ) -> Result<Self> {
        let pencil = body.pencil();
        let Some(&proportional) = pencil.proportional() else {
            return Err(Error::InvalidSetting(
                "the shifted Krylov space needs a damping proportional to M and K but for a \
                 low-rank remainder"
                    .into(),
            ));
        };
        let remainder = pencil.remainder();
        if let (Some(r), Some(rb)) = (remainder, body.rigid()) {
            let e = r.rigid_load(rb.modes());
            if !(e <= RIGID_LOAD) {
                return Err(Error::InvalidSetting(format!(
                    "the damping's remainder loads the free body's rigid motion ({e:.1e} \
                     relative): the elastic response has no exact low-rank update"
                )));
            }
        }
        if !sigma.is_finite() {
            return Err(Error::InvalidSetting(format!(
                "shift sigma = {sigma}: must be finite"
            )));
        }
        let n = pencil.n();
        let mut b0 = match remainder {
            Some(r) => {
                let u = r.loads(n);
                Mat::from_fn(n, load.ncols() + r.rank(), |i, j| {
                    if j < load.ncols() {
                        load[(i, j)]
                    } else {
                        u[(i, j - load.ncols())]
                    }
                })
            }
            None => load.clone(),
        };
        let p = b0.ncols();
        let op = ShiftInvert::new(
            pencil,
            body.symbolic()?,
            sigma,
            par,
            p,
            body.factor_storage(),
        )?;
        let mut space = ShiftedSpace {
            pencil,
            op,
            rigid: body.rigid(),
            sigma,
            proportional,
            remainder,
            load,
            q: Mat::zeros(n, 0),
            mq: Mat::zeros(n, 0),
            t: Mat::zeros(0, 0),
            r0: Mat::zeros(0, p),
            kq: Mat::zeros(0, 0),
            qb: Mat::zeros(0, p),
            last: 0,
            next: Mat::zeros(n, 0),
            next_m: Mat::zeros(n, 0),
            next_gram: Mat::zeros(0, 0),
            next_scale: Vec::new(),
            lanczos: None,
            ritz: None,
            max_dim: max_dim.min(n),
            capacity: 0,
            block_solves: 0,
            par,
            answered: None,
            estimated: None,
        };
        space.apply_s(b0.as_mut(), false);
        space.set_next(b0, None);
        space.extend();
        space.op.check_solves()?;
        Ok(space)
    }

    /// ν(σ) = #{λ < σ}, the eigenvalues of K − λM below the shift, rigid ones included,
    /// from the inertia of the factor (Sylvester; 0 for σ < 0).
    pub fn below(&self) -> usize {
        self.op.below()
    }

    /// x ← (K − σM)⁻¹ (M x when `mass`, else x), without its rigid part.
    fn apply_s(&mut self, mut x: faer::MatMut<'_, f64>, mass: bool) {
        if mass {
            let y = self.pencil.mul(Coefficient::Mass, x.as_ref());
            x.copy_from(&y);
        }
        self.op.solve_with(x.as_mut(), self.par);
        self.block_solves += 1;
        if let Some(rb) = self.rigid {
            rb.project_response_real(x);
        }
    }

    /// Adds the columns of `next` (M-orthonormalized, deflated) as a new block and computes
    /// its image; returns false when nothing was added (the space is invariant or full).
    fn extend(&mut self) -> bool {
        let (n, k) = (self.q.nrows(), self.q.ncols());
        if self.next.ncols() == 0 || k >= self.max_dim {
            return false;
        }
        let (qn, mqn, coef) = m_orthonormalize(
            self.pencil,
            self.next.as_ref(),
            Some(self.next_m.as_ref()),
            &self.next_scale,
        );
        let bn = qn.ncols().min(self.max_dim - k);
        if bn == 0 {
            self.set_next(Mat::zeros(n, 0), None);
            return false;
        }
        let kn = k + bn;
        append_columns(
            [&mut self.q, &mut self.mq],
            [qn.subcols(0, bn), mqn.subcols(0, bn)],
            &mut self.capacity,
            self.max_dim,
        );
        self.project_block(k);
        self.t.resize_with(kn, kn, |_, _| 0.0);
        self.r0.resize_with(kn, self.r0.ncols(), |_, _| 0.0);
        if k == 0 {
            self.r0
                .as_mut()
                .subrows_mut(0, bn)
                .copy_from(coef.subrows(0, bn));
        } else {
            let prev = k - self.last;
            self.t
                .as_mut()
                .submatrix_mut(k, self.last, bn, prev)
                .copy_from(coef.subrows(0, bn));
        }
        let before = self.last;
        self.last = k;
        // the image of the new block: the block Lanczos step against the blocks it couples
        // to (T is banded), then one full pass of reorthogonalization, and a second where
        // DGKS's test asks for it; the coefficients are T's new columns
        let mut w = self.mq.subcols(k, bn).to_owned();
        self.apply_s(w.as_mut(), false);
        let (c, full) =
            lanczos_step_and_full_pass(self.q.as_ref(), self.mq.as_ref(), &mut w, before, self.par);
        self.add_image(k, w, c.as_ref());
        let left = (0..bn).all(|j| full.col(j).squared_norm_l2() <= self.next_gram[(j, j)]);
        if !left {
            let mut w = std::mem::replace(&mut self.next, Mat::zeros(n, 0));
            let again = project_once(self.q.as_ref(), self.mq.as_ref(), &mut w, self.par);
            self.add_image(k, w, again.as_ref());
        }
        self.lanczos = None;
        self.ritz = None;
        true
    }

    /// Extends QᵀKQ and Qᵀ[B U] by the new columns k.. of Q: one product of K with them and
    /// one pass over Q, the answers' projection formed with K itself (module doc).
    fn project_block(&mut self, k: usize) {
        let kn = self.dim();
        let qn = self.q.subcols(k, kn - k);
        let kqn = self.pencil.mul(Coefficient::Stiffness, qn);
        let mut cross = Mat::<f64>::zeros(kn, kn - k);
        matmul(
            cross.as_mut(),
            Accum::Replace,
            self.q.transpose(),
            kqn.as_ref(),
            1.0,
            self.par,
        );
        // both triangles (the eigensolver reads the lower one)
        self.kq.resize_with(kn, kn, |_, _| 0.0);
        self.kq
            .as_mut()
            .submatrix_mut(0, k, kn, kn - k)
            .copy_from(&cross);
        self.kq
            .as_mut()
            .submatrix_mut(k, 0, kn - k, kn)
            .copy_from(cross.transpose());
        let p = self.load.ncols();
        let mut qbn = Mat::<f64>::zeros(kn - k, self.qb.ncols());
        matmul(
            qbn.as_mut().subcols_mut(0, p),
            Accum::Replace,
            qn.transpose(),
            self.load.as_ref(),
            1.0,
            self.par,
        );
        if let Some(r) = self.remainder {
            // U = P_J W: its products from the rows J alone
            let qj = Mat::<f64>::from_fn(r.dofs.len(), kn - k, |i, a| qn[(r.dofs[i], a)]);
            let uq = r.basis.transpose() * &qj;
            qbn.as_mut()
                .subcols_mut(p, r.rank())
                .copy_from(uq.transpose());
        }
        let cols = self.qb.ncols();
        self.qb.resize_with(kn, cols, |i, j| qbn[(i - k, j)]);
    }

    /// Adds the coefficients `c` of the image of the block at column k to T's columns and
    /// makes `w`, what is left of the image, the next block.
    fn add_image(&mut self, k: usize, w: Mat<f64>, c: MatRef<'_, f64>) {
        let mut tc = self.t.as_mut().subcols_mut(k, w.ncols());
        tc += c;
        let image = self.t.as_ref().subcols(k, w.ncols()).to_owned();
        self.set_next(w, Some(image.as_ref()));
    }

    /// Makes `w` the part of the next block outside the space: its M-Gram matrix G = wᵀMw
    /// and the scale of each column, the M-norm of the image it came from,
    /// ‖W e_j‖_M² = ‖coefficients_j‖² + G_jj (W = Q C + w with Q M-orthonormal and w
    /// M-orthogonal to Q; `coefficients` C = None for b₀, which is its own image).
    fn set_next(&mut self, w: Mat<f64>, coefficients: Option<MatRef<'_, f64>>) {
        self.next_m = self.pencil.mul(Coefficient::Mass, w.as_ref());
        self.next_gram = w.transpose() * &self.next_m;
        self.next_scale = (0..w.ncols())
            .map(|j| {
                let inside = coefficients.map_or(0.0, |c| c.col(j).squared_norm_l2());
                (inside + self.next_gram[(j, j)].max(0.0)).sqrt()
            })
            .collect();
        self.next = w;
    }

    /// Decomposes the current T = ZΘZᵀ and QᵀKQ = ZΛZᵀ (once per basis).
    fn decompose(&mut self) -> Result<()> {
        if self.ritz.is_some() {
            return Ok(());
        }
        let failed = || {
            Error::NotConverged(
                "the dense eigensolver failed on a projected matrix (NaN in the Krylov basis?)"
                    .into(),
            )
        };
        let (theta, z) = sym_eigen(self.t.as_ref()).ok_or_else(failed)?;
        self.lanczos = Some(Ritz {
            a: vec![1.0; theta.len()],
            b: theta,
            c: z.transpose() * &self.r0,
            z,
        });
        let (lambda, z) = sym_eigen(self.kq.as_ref()).ok_or_else(failed)?;
        self.ritz = Some(Ritz {
            b: vec![1.0; lambda.len()],
            a: lambda.iter().map(|l| l - self.sigma).collect(),
            c: z.transpose() * &self.qb,
            z,
        });
        Ok(())
    }

    /// τ = μ(ω) − σ and the factor c_k of A_p(iω) = c_k(K − μM), μ = c_m/c_k (§3.12).
    fn shift(&self, omega: f64) -> (c64, c64) {
        let (ck, cm) = self.proportional.coefficients(omega);
        (cm / ck - self.sigma, ck)
    }

    /// The response's coefficients c = c_b − c_u w (k × p) from the proportional ones of the
    /// load and of U (`all`, k × (p + r)), with w from the remainder's r × r correction
    /// (§3.12); `all` itself without a remainder.
    fn corrected(&self, omega: f64, all: Mat<c64>) -> Mat<c64> {
        let Some(r) = self.remainder else {
            return all;
        };
        let p = self.load.ncols();
        let qj = Mat::<f64>::from_fn(r.dofs.len(), all.nrows(), |i, j| self.q[(r.dofs[i], j)]);
        let at_j = complex_product(qj.as_ref(), all.as_ref());
        let w = r.correction(
            omega,
            r.project(at_j.as_ref().subcols(0, p)).as_ref(),
            r.project(at_j.as_ref().subcols(p, r.rank())).as_ref(),
        );
        all.as_ref().subcols(0, p) - all.as_ref().subcols(p, r.rank()) * &w
    }

    /// y(τ) restricted to the rows `rows` of the basis (k × p complex over those rows).
    fn coefficients(ritz: &Ritz, tau: c64, rows: std::ops::Range<usize>) -> Mat<c64> {
        let mut d = vec![c64::new(0.0, 0.0); ritz.a.len()];
        resolvent(ritz, tau, c64::new(1.0, 0.0), &mut d);
        let dc = Mat::<c64>::from_fn(ritz.c.nrows(), ritz.c.ncols(), |j, col| {
            d[j] * ritz.c[(j, col)]
        });
        let z = ritz.z.subrows(rows.start, rows.len());
        let (re, im) = (dc.as_ref().map(|x| x.re), dc.as_ref().map(|x| x.im));
        let (yr, yi) = (z * &re, z * &im);
        Mat::from_fn(rows.len(), ritz.c.ncols(), |i, col| {
            c64::new(yr[(i, col)], yi[(i, col)])
        })
    }

    /// The estimated relative residual ‖(I − τS)x − b₀‖_M/‖b₀‖_M (worst column) of the
    /// Lanczos relation's Galerkin response at each of `freqs_hz` (module doc): how far the
    /// space holds the response, which the answers read with K's projection; with a
    /// low-rank remainder, of the corrected response: its residual is e_b − E_u w exactly
    /// (§3.12), the same form over the last block's coefficients y_b − Y_u w;
    /// infinite before the space was decomposed by [`Self::grow_for`]. The last block's
    /// coefficients at all of them come from one pair of products
    /// ([`scaled_products_into`]).
    fn estimates(&self, freqs_hz: &[f64]) -> Vec<f64> {
        let Some(ritz) = &self.lanczos else {
            return vec![f64::INFINITY; freqs_hz.len()];
        };
        if self.next.ncols() == 0 {
            return vec![0.0; freqs_hz.len()];
        }
        let taus: Vec<c64> = freqs_hz
            .iter()
            .map(|&f| self.shift(hz_to_omega(f)).0)
            .collect();
        let last = ritz.z.subrows(self.last, self.dim() - self.last);
        let p = self.r0.ncols();
        // yᴴGy = ‖G^{1/2} y‖² for the next block's M-Gram matrix G = VΛVᵀ ⪰ 0 (its rounding
        // below 0 clamped): with G^{1/2} = Λ^{1/2}Vᵀ folded into the coefficients' left
        // factor, each frequency's form is a sum of squares of its product
        let Some((lambda, v)) = sym_eigen(self.next_gram.as_ref()) else {
            return vec![f64::INFINITY; freqs_hz.len()];
        };
        let root = Mat::<f64>::from_fn(lambda.len(), v.nrows(), |i, j| {
            lambda[i].max(0.0).sqrt() * v[(j, i)]
        });
        let left = &root * last;
        let b = left.nrows();
        let norms: Vec<f64> = (0..p).map(|c| self.r0.col(c).norm_l2()).collect();
        // with a remainder, the rows J of the solutions too: the corrected response's residual
        // is e_b − E_u w (§3.12), w from the rows J
        let j_rows = self.remainder.map_or(&[][..], |r| &r.dofs[..]);
        let qzj =
            Mat::<f64>::from_fn(j_rows.len(), self.dim(), |i, j| self.q[(j_rows[i], j)]) * &ritz.z;
        let a = Mat::<f64>::from_fn(b + j_rows.len(), self.dim(), |i, j| {
            if i < b {
                left[(i, j)]
            } else {
                qzj[(i - b, j)]
            }
        });
        let m = a.nrows();
        let loads = self.load.ncols();
        let mut out = vec![0.0f64; taus.len()];
        let row = |f: usize, d: &mut [c64]| resolvent(ritz, taus[f], c64::new(1.0, 0.0), d);
        scaled_products_into(
            a.as_ref(),
            ritz.c.as_ref(),
            row,
            &mut out,
            1,
            |f, _, yr, yi, worst| {
                let residual = |c: usize| {
                    let col = c * m..c * m + b;
                    let q: f64 = yr[col.clone()].iter().chain(&yi[col]).map(|y| y * y).sum();
                    taus[f].norm() * q.sqrt()
                };
                let Some(r) = self.remainder else {
                    for (c, &bn) in norms.iter().enumerate().filter(|(_, &bn)| bn > 0.0) {
                        worst[0] = worst[0].max(residual(c) / bn);
                    }
                    return;
                };
                let omega = hz_to_omega(freqs_hz[f]);
                let inv = self.shift(omega).1.inv();
                let z = Mat::<c64>::from_fn(j_rows.len(), p, |i, c| {
                    c64::new(yr[c * m + b + i], yi[c * m + b + i]) * inv
                });
                let w = r.correction(
                    omega,
                    r.project(z.as_ref().subcols(0, loads)).as_ref(),
                    r.project(z.as_ref().subcols(loads, r.rank())).as_ref(),
                );
                // the corrected response's last-block coefficients y_b − Y_u w, whose
                // G^{1/2}-weighted norm times |τ| is its residual: the parts' residuals
                // cancel where the correction moves a resonance (a triangle-inequality bound
                // ‖e_b‖ + Σ_j ‖e_{u,j}‖|w_j| asked the crank's space for twice the blocks)
                let at = |c: usize, i: usize| c64::new(yr[c * m + i], yi[c * m + i]);
                for c in (0..loads).filter(|&c| norms[c] > 0.0) {
                    let q: f64 = (0..b)
                        .map(|i| {
                            let u: c64 = (0..r.rank()).map(|j| at(loads + j, i) * w[(j, c)]).sum();
                            (at(c, i) - u).norm_sqr()
                        })
                        .sum();
                    worst[0] = worst[0].max(taus[f].norm() * q.sqrt() / norms[c]);
                }
            },
        );
        out
    }
}

impl ResponseSpace for ShiftedSpace<'_> {
    /// The M-orthonormal basis Q (N × k). It only grows: a response's
    /// [`Solution::coefficients`] index its first columns for the space's whole life.
    fn basis(&self) -> MatRef<'_, f64> {
        self.q.as_ref()
    }

    /// Vectors in the basis.
    fn dim(&self) -> usize {
        self.q.ncols()
    }

    /// The space may still grow (it is neither invariant nor full).
    fn can_grow(&self) -> bool {
        self.next.ncols() > 0 && self.dim() < self.max_dim
    }

    fn interior(&self) -> bool {
        self.sigma > 0.0
    }

    fn into_basis(self: Box<Self>) -> Mat<f64> {
        self.q
    }

    /// Block solves with K − σM so far.
    fn block_solves(&self) -> usize {
        self.block_solves
    }

    /// Grows the space until the estimated relative residual at every frequency of
    /// `freqs_hz` is ≤ `target` ([`GROW_TO`] first), the space is invariant, or it holds
    /// `max_dim` vectors;
    /// leaves it decomposed. Blocks are added in batches of about a quarter of the basis, so
    /// the Ritz decompositions cost O(k³) in all.
    ///
    /// # Errors
    /// [`Error::NotConverged`] when T has no eigendecomposition.
    fn grow_for(&mut self, freqs_hz: &[f64], target: f64) -> Result<()> {
        let growth = Growth {
            decompose: Self::decompose,
            estimates: Self::estimates,
            extend: Self::extend,
            sizes: |s: &Self| (s.next.ncols(), s.dim()),
        };
        let estimated = growth.grow(self, freqs_hz, target)?;
        self.op.check_solves()?;
        if let Some(e) = estimated {
            self.estimated = Some((self.dim(), freqs_hz.to_vec(), e));
        }
        Ok(())
    }

    fn factor_place(&self) -> FactorPlace {
        self.op.place()
    }

    /// X = Pᵀ A(iω)⁻¹ P B at `freq_hz` from the space, with its certificate (module doc);
    /// after [`Self::grow_for`]. X is left in `buffers` ([`SolutionBuffers::x`]).
    ///
    /// # Errors
    /// [`Error::NotConverged`] when the space was not decomposed by [`Self::grow_for`].
    fn solve(&self, freq_hz: f64, par: Par, buffers: &mut SolutionBuffers) -> Result<Solution> {
        let omega = hz_to_omega(freq_hz);
        let (tau, scale) = self.shift(omega);
        let ritz = self.ritz.as_ref().ok_or_else(|| {
            Error::NotConverged(
                "the shifted Krylov space was not decomposed (grow_for first)".into(),
            )
        })?;
        let y = Self::coefficients(ritz, tau, 0..self.dim());
        let amplification = amplification(ritz, self.sigma, tau);
        let inv = scale.inv();
        let coefficients = self.corrected(
            omega,
            Mat::from_fn(y.nrows(), y.ncols(), |i, c| y[(i, c)] * inv),
        );
        let certificate = lift(
            Lifted {
                pencil: self.pencil,
                q: self.q.as_ref(),
                rigid: self.rigid,
                load: self.load.as_ref(),
            },
            omega,
            coefficients.as_ref(),
            par,
            buffers,
        );
        Ok(Solution {
            coefficients,
            certificate,
            amplification,
        })
    }

    /// The response at the rows `rows` (the outputs) at each of `freqs_hz`, from the space
    /// without lifting it to N rows: C Q Z (Λ − μI)⁻¹ ZᵀQᵀB / c_k (and the remainder's
    /// correction, §3.12), O(q k p) per
    /// frequency after one q × k product. `None` where the estimated residual is above
    /// [`GROW_TO`] (grow the space for those frequencies first). Not certified: the
    /// sampling loop uses it to find where the ROM's error is largest, and certifies the
    /// responses it keeps. The answer is kept for [`Self::answer`].
    fn rows_at(&mut self, freqs_hz: &[f64], rows: &[usize]) -> Arc<Rows> {
        let Some(ritz) = &self.ritz else {
            return Arc::new(Rows {
                h: MatStack::default(),
                answered: vec![false; freqs_hz.len()],
            });
        };
        let k = self.dim();
        // the rows asked, then the remainder's J (its correction needs them)
        let j_rows = self.remainder.map_or(&[][..], |r| &r.dofs[..]);
        let all_rows: Vec<usize> = rows.iter().chain(j_rows).copied().collect();
        let qz = Mat::<f64>::from_fn(all_rows.len(), k, |i, j| self.q[(all_rows[i], j)]) * &ritz.z;
        let (taus, scales): (Vec<c64>, Vec<c64>) = freqs_hz
            .iter()
            .map(|&f| {
                let (tau, scale) = self.shift(hz_to_omega(f));
                (tau, scale.inv())
            })
            .unzip();
        let row = |f: usize, d: &mut [c64]| resolvent(ritz, taus[f], scales[f], d);
        let mut h = MatStack::scaled_products(qz.as_ref(), ritz.c.as_ref(), taus.len(), row);
        if let Some(r) = self.remainder {
            let (q, p) = (rows.len(), self.load.ncols());
            h = MatStack::from_fn(q, p, taus.len(), |f| {
                let all = h.get(f);
                let at_j = all.subrows(q, r.dofs.len());
                let w = r.correction(
                    hz_to_omega(freqs_hz[f]),
                    r.project(at_j.subcols(0, p)).as_ref(),
                    r.project(at_j.subcols(p, r.rank())).as_ref(),
                );
                all.submatrix(0, 0, q, p) - all.submatrix(0, p, q, r.rank()) * &w
            });
        }
        let answered = match self.estimated.take() {
            Some((dim, f, e)) if dim == k && f == freqs_hz => e,
            _ => self.estimates(freqs_hz),
        }
        .into_iter()
        .map(|e| e <= GROW_TO)
        .collect();
        let h = Arc::new(Rows { h, answered });
        self.answered = Some(RowsAnswer {
            freqs_hz: freqs_hz.to_vec(),
            rows: rows.to_vec(),
            dim: k,
            h: Arc::clone(&h),
        });
        h
    }

    /// [`Self::rows_at`]'s answer when it was last asked the same, and the space has not
    /// grown since.
    fn answer(&self, freqs_hz: &[f64], rows: &[usize]) -> Option<Arc<Rows>> {
        self.answered
            .as_ref()
            .and_then(|a| a.same(freqs_hz, rows, self.dim()))
    }
}

/// M-orthonormalizes the columns of `w`, M-orthogonal to the basis already (the image's
/// passes in [`ShiftedSpace::extend`]; b₀ comes before any basis): [`orthonormalize`] with
/// the product by M, from `mw` = M w when the caller has it (one blocked product otherwise);
/// returns the new columns, M times them and the coefficients.
pub(crate) fn m_orthonormalize(
    pencil: &Pencil,
    w: MatRef<'_, f64>,
    mw: Option<MatRef<'_, f64>>,
    scale: &[f64],
) -> (Mat<f64>, Mat<f64>, Mat<f64>) {
    let fresh;
    let mw = match mw {
        Some(mw) => mw,
        None => {
            fresh = pencil.mul(Coefficient::Mass, w);
            fresh.as_ref()
        }
    };
    orthonormalize(w, mw, scale, |v| pencil.mul(Coefficient::Mass, v.as_mat()))
}

/// A column that Gram–Schmidt leaves with less than this fraction of its G-norm has its
/// image G v computed again from v ([`orthonormalize`]).
const RECOMPUTE_IMAGE: f64 = 0.5;

/// Orthonormalizes the columns of `w` (orthogonal to the basis already) against each other in
/// the inner product ⟨x, y⟩ = xᵀ G y, `gw` = G w: two passes per column against the new
/// columns only, dropping a column left with less than [`DEFLATE`] of `scale`. G v is
/// updated with the same combinations as v, unless v kept less than [`RECOMPUTE_IMAGE`] of
/// its column's G-norm: then it is `image(v)` = G v (N × 1), since the difference would
/// lose digits to cancellation (on the 50k crank the certificates failed and frequencies
/// were factored, when every image came from combinations). Returns the new columns, G
/// times them and the coefficients C with w ≈ W_new C (rows: kept columns).
pub(crate) fn orthonormalize(
    w: MatRef<'_, f64>,
    gw: MatRef<'_, f64>,
    scale: &[f64],
    image: impl Fn(&faer::Col<f64>) -> Mat<f64>,
) -> (Mat<f64>, Mat<f64>, Mat<f64>) {
    let (n, b) = (w.nrows(), w.ncols());
    let mut qn = Mat::<f64>::zeros(n, 0);
    let mut mqn = Mat::<f64>::zeros(n, 0);
    qn.reserve(n, b);
    mqn.reserve(n, b);
    let mut coef = Mat::<f64>::zeros(b, b);
    for j in 0..b {
        let mut v = w.col(j).to_owned();
        let mut gv = gw.col(j).to_owned();
        let start = (v.transpose() * &gv).max(0.0);
        for _ in 0..2 {
            let cn = mqn.transpose() * &v;
            v -= &qn * &cn;
            gv -= &mqn * &cn;
            for (i, &x) in cn.iter().enumerate() {
                coef[(i, j)] += x;
            }
        }
        let mut norm2 = (v.transpose() * &gv).max(0.0);
        if !(norm2 >= RECOMPUTE_IMAGE * RECOMPUTE_IMAGE * start) {
            gv = image(&v).col(0).to_owned();
            norm2 = (v.transpose() * &gv).max(0.0);
        }
        let norm = norm2.sqrt();
        if !(norm > DEFLATE * scale[j]) {
            continue;
        }
        let i = qn.ncols();
        qn.resize_with(n, i + 1, |r, _| v[r] / norm);
        mqn.resize_with(n, i + 1, |r, _| gv[r] / norm);
        coef[(i, j)] = norm;
    }
    let kept = qn.ncols();
    (qn, mqn, coef.subrows(0, kept).to_owned())
}

/// Appends the columns `new` to the basis Q and M Q (`q`), their room grown by doubling up
/// to `max` columns (`capacity` keeps it): a copy of 16 N k bytes per block would fault in
/// fresh pages each time (a sixth of the 10⁶-DoF bar's seed step).
pub(crate) fn append_columns(
    q: [&mut Mat<f64>; 2],
    new: [MatRef<'_, f64>; 2],
    capacity: &mut usize,
    max: usize,
) {
    let (n, k) = (q[0].nrows(), q[0].ncols());
    let kn = k + new[0].ncols();
    if kn > *capacity {
        *capacity = (2 * kn).min(max).max(kn);
    }
    for (m, c) in q.into_iter().zip(new) {
        // a no-op while the room suffices
        m.reserve(n, *capacity);
        m.resize_with(n, kn, |i, j| c[(i, j - k)]);
    }
}

/// How a space grows by blocks: [`Growth::grow`] is both spaces' `grow_for`.
pub(crate) struct Growth<S> {
    /// Decomposes the projected matrix (once per basis).
    pub decompose: fn(&mut S) -> Result<()>,
    /// The estimated relative residuals at the frequencies.
    pub estimates: fn(&S, &[f64]) -> Vec<f64>,
    /// Adds a block; false when the space is invariant or full.
    pub extend: fn(&mut S) -> bool,
    /// The next block's columns and the space's vectors.
    pub sizes: fn(&S) -> (usize, usize),
}

impl<S> Growth<S> {
    /// Grows `space` until the estimate at every frequency of `freqs_hz` is ≤ `target`, the
    /// estimates stall at their rounding floor ([`STALLED`]), the space is invariant, or it is
    /// full; leaves it decomposed. Blocks are added in batches of about a quarter of the
    /// space, so the decompositions cost O(k³) in all. Returns the estimates it ended on, but
    /// for an invariant or full space.
    ///
    /// # Errors
    /// The decomposition's.
    pub fn grow(&self, space: &mut S, freqs_hz: &[f64], target: f64) -> Result<Option<Vec<f64>>> {
        let mut before: Option<Vec<f64>> = None;
        loop {
            (self.decompose)(space)?;
            let e = (self.estimates)(space, freqs_hz);
            if e.iter().all(|&e| e <= target) || before.is_some_and(|b| stalled(&b, &e, target)) {
                return Ok(Some(e));
            }
            let (b, k) = (self.sizes)(space);
            for _ in 0..(k / (4 * b.max(1))).max(1) {
                if !(self.extend)(space) {
                    return (self.decompose)(space).map(|()| None);
                }
            }
            before = Some(e);
        }
    }
}

/// A batch of blocks that lowered no estimate still above the growth target by more than 2×,
/// all of them within [`STALLED`] × the target, found them at their floor: near a lightly
/// damped resonance the response's coefficients are large and their rounding bounds the
/// estimate (on the 77 229-DoF crank with dashpots at 1 529 Hz: 2.1e-12 at dimension 216,
/// 7.4e-13 at 396, against 1e-12). The certificate then judges the responses, and a failed
/// one asks for a tighter target (§3.10).
const STALLED: f64 = 100.0;

/// Whether the estimates `after` a batch of blocks stalled against those `before` it
/// ([`STALLED`]).
fn stalled(before: &[f64], after: &[f64], target: f64) -> bool {
    before
        .iter()
        .zip(after)
        .filter(|(_, &a)| a > target)
        .all(|(&b, &a)| a <= STALLED * target && a > 0.5 * b)
}

/// A response space's answer X = Q c, rigid-free, into `buffers`, and its certificate against
/// the exact pencil (b = `load`). One product Q [Re c, Im c] reads Q once.
pub(crate) fn lift(
    space: Lifted<'_>,
    omega: f64,
    c: MatRef<'_, c64>,
    par: Par,
    buffers: &mut SolutionBuffers,
) -> Certificate {
    let (n, p) = (space.q.nrows(), c.ncols());
    let parts = Mat::<f64>::from_fn(c.nrows(), 2 * p, |i, j| {
        if j < p {
            c[(i, j)].re
        } else {
            c[(i, j - p)].im
        }
    });
    shaped(&mut buffers.parts, n, 2 * p);
    matmul(
        buffers.parts.as_mut(),
        Accum::Replace,
        space.q,
        parts.as_ref(),
        1.0,
        par,
    );
    shaped(&mut buffers.x, n, p);
    let xp = &buffers.parts;
    for j in 0..p {
        let (re, im) = (xp.col(j), xp.col(p + j));
        for (x, (&r, &i)) in buffers
            .x
            .col_mut(j)
            .iter_mut()
            .zip(re.iter().zip(im.iter()))
        {
            *x = c64::new(r, i);
        }
    }
    if let Some(rb) = space.rigid {
        rb.project_response(buffers.x.as_mut());
    }
    certify(
        space.pencil,
        omega,
        space.load,
        buffers.x.as_ref(),
        par,
        &mut buffers.certify,
    )
}

/// What [`lift`] reads of a space: its pencil, basis, rigid body and load.
#[derive(Clone, Copy)]
pub(crate) struct Lifted<'s> {
    pub pencil: &'s Pencil,
    pub q: MatRef<'s, f64>,
    pub rigid: Option<&'s RigidBody>,
    pub load: MatRef<'s, f64>,
}

/// A C for real A and complex C, as A Re C + i A Im C.
pub(crate) fn complex_product(a: MatRef<'_, f64>, c: MatRef<'_, c64>) -> Mat<c64> {
    let (re, im) = (a * c.map(|x| x.re), a * c.map(|x| x.im));
    Mat::from_fn(a.nrows(), c.ncols(), |i, j| {
        c64::new(re[(i, j)], im[(i, j)])
    })
}

/// max_j (|λ_j| + |μ|) / |λ_j − μ| over the Ritz values λ_j = σ + a_j/b_j of `ritz`,
/// μ = σ + τ: how much K − μM amplifies a relative perturbation of K and M (a componentwise
/// backward error) along the space's mode nearest μ. Computed as
/// (|a_j + σb_j| + |μb_j|) / |a_j − τb_j| (times |b_j| above and below), with |a_j − τb_j|
/// less its rounding: 8ε(|a_j| + |σb_j| + |μb_j|), since the shift τ = μ − σ carries an
/// absolute error ε(|μ| + |σ|), which an interior σ next to an eigenvalue makes as large as
/// the distance itself; and 8ε(maxᵢ|aᵢ| + |τ| maxᵢ|bᵢ|), the dense eigensolver's error in
/// the poles. Infinite where the rounding covers the distance (an undamped eigenvalue to
/// working precision).
fn amplification(ritz: &Ritz, sigma: f64, tau: c64) -> f64 {
    let mu = tau + sigma;
    let largest = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let poles = 8.0 * f64::EPSILON * (largest(&ritz.a) + tau.norm() * largest(&ritz.b));
    ritz.a
        .iter()
        .zip(&ritz.b)
        .map(|(&a, &b)| {
            let (s, m) = ((a + sigma * b).abs(), (mu * b).norm());
            let rounding = 8.0 * f64::EPSILON * (a.abs() + (sigma * b).abs() + m) + poles;
            let distance = (c64::new(a, 0.0) - tau * b).norm() - rounding;
            if distance > 0.0 {
                (s + m) / distance
            } else {
                f64::INFINITY
            }
        })
        .fold(0.0, f64::max)
}

/// d_j = s / (a_j − τb_j): the projected resolvent at the shift τ, times s.
fn resolvent(ritz: &Ritz, tau: c64, s: c64, d: &mut [c64]) {
    for (d, (&a, &b)) in d.iter_mut().zip(ritz.a.iter().zip(&ritz.b)) {
        *d = s / (c64::new(a, 0.0) - tau * b);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::body::Body;
    use crate::fe::{bar_model, paper_scene, BoxSpec};
    use crate::model::{Damping, Model, Structural};
    use crate::sparse::Csc;
    use crate::sweep::{FreqStats, Response as Kind, SolveMethod, Solver, SweepOptions};
    use proptest::prelude::*;
    use std::sync::Mutex;

    /// The paper bar, coarsely meshed (free), with `damping`.
    fn bar(damping: Damping) -> (Body, Vec<usize>) {
        bar_with(|m| m.damping = damping)
    }

    /// The paper bar, coarsely meshed (free), changed by `change`.
    pub(crate) fn bar_with(change: impl FnOnce(&mut Model)) -> (Body, Vec<usize>) {
        let spec = BoxSpec {
            elements: [1, 2, 24],
            ..BoxSpec::paper_bar()
        };
        let mut model = bar_model(&spec).unwrap();
        change(&mut model);
        let inputs = paper_scene(&spec).inputs;
        (Body::new(&model).unwrap(), inputs)
    }

    /// The damping of the tests about an interior shift.
    const LIGHT: Damping = Damping::Rayleigh {
        alpha: 0.0,
        beta: 1e-5,
    };

    /// The body's 8th eigenvalue (rigid ones included).
    fn eighth_eigenvalue(body: &Body) -> f64 {
        let opts = crate::eigen::EigenOptions::default();
        let modes = crate::eigen::eigenpairs(body, crate::eigen::Request::Lowest(8), &opts);
        modes.unwrap().lambdas[7]
    }

    /// a M + b K + the entries `extra` (full storage, both triangles given).
    fn combined(model: &Model, a: f64, b: f64, extra: &[(usize, usize, f64)]) -> Csc {
        let mut t = crate::sparse::Triplets::default();
        extra.iter().for_each(|&(i, j, v)| t.push(i, j, v));
        let e = t.into_csc(model.n(), false);
        crate::sparse::linear_combination(a, &model.mass, b, &model.stiffness, Some(&e))
    }

    /// β K plus two axial dashpots c (e_a − e_b)(e_a − e_b)ᵀ along the bar's axis z: from
    /// node 0 to the far node on its line, and from that line's middle node to the next
    /// line's far node... both between z DoFs of nodes on one line parallel to z, so that
    /// rigid motion does not load them.
    fn with_dashpots(model: &Model, beta: f64, c: f64) -> Csc {
        let nodes = model.nodes.as_ref().expect("the bar has nodes");
        let line = |x: [f64; 3]| {
            let mut on: Vec<usize> = (0..nodes.len())
                .filter(|&i| nodes[i][0] == x[0] && nodes[i][1] == x[1])
                .collect();
            on.sort_by(|&a, &b| nodes[a][2].total_cmp(&nodes[b][2]));
            on
        };
        let first = line(nodes[0]);
        let other = line(nodes[nodes.len() - 1]);
        let mut extra = Vec::new();
        for (a, b) in [
            (first[0], first[first.len() - 1]),
            (other[other.len() / 2], other[0]),
        ] {
            let (a, b) = (3 * a + 2, 3 * b + 2);
            extra.extend([(a, a, c), (b, b, c), (a, b, -c), (b, a, -c)]);
        }
        combined(model, 0.0, beta, &extra)
    }

    /// Every damping the space answers (docs/design.md §3.12) gives certified responses equal
    /// to factored ones, none of them factored: an explicit D that is α M + β K, a loss factor
    /// η (alone and with Rayleigh damping), K₄ = ηK as a matrix, and dashpots on β K (a
    /// rank-2 remainder).
    #[test]
    fn every_proportional_or_low_rank_damping_is_answered_by_the_space() {
        let freqs = [3.0, 117.0, 410.5, 640.0, 999.0];
        let rayleigh_file = |m: &mut Model| {
            m.damping = Damping::Matrix(combined(m, 3.0, 2e-6, &[]));
        };
        let eta = |m: &mut Model| {
            m.structural = Structural {
                eta: 0.02,
                matrix: None,
            }
        };
        let rayleigh_eta = |m: &mut Model| {
            m.damping = Damping::Rayleigh {
                alpha: 3.0,
                beta: 2e-6,
            };
            eta(m);
        };
        let k4 = |m: &mut Model| {
            m.structural = Structural {
                eta: 0.0,
                matrix: Some(combined(m, 0.0, 0.02, &[])),
            }
        };
        let dashpots = |m: &mut Model| m.damping = Damping::Matrix(with_dashpots(m, 1e-6, 50.0));
        type Change<'a> = &'a dyn Fn(&mut Model);
        let cases: [(&str, Change); 5] = [
            ("D = 3 M + 2e-6 K as a matrix", &rayleigh_file),
            ("eta 0.02", &eta),
            ("Rayleigh and eta 0.02", &rayleigh_eta),
            ("K4 = 0.02 K as a matrix", &k4),
            ("dashpots on 1e-6 K", &dashpots),
        ];
        for (what, change) in cases {
            let (body, inputs) = bar_with(change);
            let d = krylov_vs_factored_body(&body, &inputs, &freqs);
            assert!(d <= 1e-8, "{what}: relative difference {d:.2e}");
            let low_rank = body.pencil().remainder().map_or(0, |r| r.rank());
            assert_eq!(
                low_rank,
                if what.starts_with("dashpots") { 2 } else { 0 },
                "{what}"
            );
        }
    }

    /// The elastic responses at `freqs` and their stats, by `method`.
    pub(crate) fn responses(
        body: &Body,
        inputs: &[usize],
        freqs: &[f64],
        method: SolveMethod,
    ) -> (Vec<Mat<c64>>, Vec<FreqStats>) {
        let solver = Solver::new(body, inputs, Kind::Elastic, &one_thread(method)).unwrap();
        let (x, _, stats) = solver_responses(&solver, freqs);
        (x, stats)
    }

    /// One thread and `method`, the sweep's defaults otherwise.
    fn one_thread(method: SolveMethod) -> SweepOptions {
        SweepOptions {
            threads: 1,
            method,
            ..SweepOptions::default()
        }
    }

    /// `solver`'s responses at `freqs`, whether each came with coefficients, and the stats.
    fn solver_responses(
        solver: &Solver<'_>,
        freqs: &[f64],
    ) -> (Vec<Mat<c64>>, Vec<bool>, Vec<FreqStats>) {
        let out = Mutex::new(vec![(Mat::<c64>::zeros(0, 0), false); freqs.len()]);
        let (_, stats) = solver
            .run(
                freqs,
                || (),
                |_, s| {
                    out.lock().unwrap()[s.index] = (s.x.to_owned(), s.coefficients.is_some());
                    Ok(())
                },
                &crate::sweep::no_progress,
            )
            .unwrap();
        let (x, spanned) = out.into_inner().unwrap().into_iter().unzip();
        (x, spanned, stats)
    }

    /// The largest relative difference (Frobenius) between the Krylov space's certified
    /// responses and factored ones; every response must come from the space.
    fn krylov_vs_factored(damping: Damping, freqs: &[f64]) -> f64 {
        let (body, inputs) = bar(damping);
        krylov_vs_factored_body(&body, &inputs, freqs)
    }

    /// [`krylov_vs_factored`] for a body.
    pub(crate) fn krylov_vs_factored_body(body: &Body, inputs: &[usize], freqs: &[f64]) -> f64 {
        krylov_vs_factored_within(body, inputs, freqs, body.n() / 2)
    }

    /// [`krylov_vs_factored_body`] for a space of fewer than `max_dim` basis vectors.
    pub(crate) fn krylov_vs_factored_within(
        body: &Body,
        inputs: &[usize],
        freqs: &[f64],
        max_dim: usize,
    ) -> f64 {
        let (x, stats) = responses(body, inputs, freqs, SolveMethod::Auto);
        let (x0, _) = responses(body, inputs, freqs, SolveMethod::Factored);
        let load = body.elastic_load(inputs);
        let mut buffers = crate::factor::CertifyBuffers::default();
        for (s, x) in stats.iter().zip(&x) {
            assert!(s.from_space(), "{} Hz was factored", s.freq_hz);
            assert!(s.space_dim < max_dim, "dimension {}", s.space_dim);
            // every column passes one of the three tests (not each test by every column)
            let omega = crate::units::hz_to_omega(s.freq_hz);
            let certificate = certify(
                body.pencil(),
                omega,
                load.as_ref(),
                x.as_ref(),
                Par::Seq,
                &mut buffers,
            );
            assert!(
                certificate.passes(
                    CERTIFIED_BACKWARD_ERROR,
                    CERTIFIED_RELATIVE_RESIDUAL,
                    CERTIFIED_NORMWISE_BACKWARD_ERROR
                ),
                "{} Hz",
                s.freq_hz
            );
        }
        x.iter()
            .zip(&x0)
            .map(|(a, b)| (a - b).norm_l2() / b.norm_l2())
            .fold(0.0, f64::max)
    }

    /// The certified responses equal factored ones over the band, at resonances and beside
    /// them, damped (stiffness- or mass-proportional) or not: measured 1.0e-11…1.7e-11.
    #[test]
    fn certified_responses_equal_factored_ones() {
        let freqs = [3.0, 117.0, 410.5, 640.0, 999.0];
        for damping in [
            Damping::Rayleigh {
                alpha: 0.0,
                beta: 1e-5,
            },
            Damping::Rayleigh {
                alpha: 3.0,
                beta: 2e-6,
            },
            Damping::None,
        ] {
            let d = krylov_vs_factored(damping, &freqs);
            assert!(d <= 1e-8, "relative difference {d:.2e}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]
        /// An iteratively solved snapshot equals the factored one to its certificate, at any
        /// frequency of the band and any Rayleigh damping.
        #[test]
        fn an_iterative_snapshot_equals_the_factored_one(
            f in 1.0f64..1000.0,
            alpha in 0.0f64..20.0,
            beta in 0.0f64..1e-4,
        ) {
            let d = krylov_vs_factored(Damping::Rayleigh { alpha, beta }, &[f]);
            prop_assert!(d <= 1e-8, "{f} Hz: relative difference {d:.2e}");
        }
    }

    /// The outputs' rows from the batched products equal the rows of the lifted response at
    /// each frequency (the same Galerkin solution, summed in another order), and still do
    /// after the space grew since they were last asked (a kept answer would be the smaller
    /// space's).
    #[test]
    fn rows_at_equal_the_lifted_responses() {
        let (body, inputs) = bar(Damping::Rayleigh {
            alpha: 0.0,
            beta: 1e-5,
        });
        rows_at_equal_lifted(&body, &inputs);
        // with a low-rank remainder, corrected in both
        let (body, inputs) =
            bar_with(|m| m.damping = Damping::Matrix(with_dashpots(m, 1e-5, 30.0)));
        assert!(body.pencil().remainder().is_some());
        rows_at_equal_lifted(&body, &inputs);
    }

    /// [`rows_at_equal_the_lifted_responses`] for one body.
    fn rows_at_equal_lifted(body: &Body, inputs: &[usize]) {
        let load = body.elastic_load(inputs);
        let sigma = -crate::units::hz_to_lambda(50.0);
        let freqs = [30.0, 333.0, 777.0, 990.0];
        let mut space = ShiftedSpace::new(body, load, sigma, body.n(), Par::Seq).unwrap();
        let rows = [0, 7, body.n() - 1];
        // one set of buffers for every frequency, as a sweep worker keeps them
        let mut buffers = SolutionBuffers::default();
        let mut dims = Vec::new();
        for target in [GROW_TO, 1e-6 * GROW_TO] {
            space.grow_for(&freqs, target).unwrap();
            dims.push(space.dim());
            assert!(
                space.answer(&freqs, &rows).is_none(),
                "asked of a grown space"
            );
            let answer = space.rows_at(&freqs, &rows);
            assert_eq!(answer.len(), freqs.len());
            for (k, f) in freqs.iter().enumerate() {
                space.solve(*f, Par::Seq, &mut buffers).unwrap();
                let x = buffers.x();
                let h = answer
                    .get(k)
                    .expect("the space answers every frequency it was grown for");
                let want = Mat::from_fn(rows.len(), x.ncols(), |i, c| x[(rows[i], c)]);
                let err = (h - &want).norm_l2() / want.norm_l2();
                assert!(err <= 1e-12, "{f} Hz, dimension {}: {err:.2e}", space.dim());
            }
            assert!(
                space.answer(&freqs, &rows).is_some(),
                "asked again, same space"
            );
            assert!(
                space.answer(&freqs[1..], &rows).is_none(),
                "asked other frequencies"
            );
        }
        assert!(
            dims[1] > dims[0],
            "the tighter target grew the space: {dims:?}"
        );
    }

    /// A space about an interior shift at the band's top, as line-fitting makes it to count
    /// the band's modes with the same factor: its count equals the inertia of a factor of its
    /// own, and its certified responses equal factored ones (measured 1e-11…3e-11 on the
    /// coarse bar, undamped, damped, with dashpots).
    #[test]
    fn a_space_about_the_band_top_counts_the_modes_and_answers_the_band() {
        let freqs = [3.0, 117.0, 410.5, 640.0, 999.0];
        for (what, change) in [
            (
                "beta 1e-5",
                &(|m: &mut Model| {
                    m.damping = Damping::Rayleigh {
                        alpha: 0.0,
                        beta: 1e-5,
                    }
                }) as &dyn Fn(&mut Model),
            ),
            ("undamped", &|m: &mut Model| m.damping = Damping::None),
            ("dashpots", &|m: &mut Model| {
                m.damping = Damping::Matrix(with_dashpots(m, 1e-6, 50.0))
            }),
        ] {
            let (body, inputs) = bar_with(change);
            let sigma = crate::units::hz_to_lambda(1000.0);
            let mut space =
                ShiftedSpace::new(&body, body.elastic_load(&inputs), sigma, body.n(), Par::Seq)
                    .unwrap();
            let sym = body.symbolic().unwrap();
            let own = crate::factor::count_eigenvalues_below_with(
                &sym,
                body.pencil(),
                sigma,
                crate::factor::Storage::IN_CORE,
            );
            assert_eq!(space.below(), own.unwrap(), "{what}: count");
            assert!(space.below() > 6 + 2, "{what}: {} below", space.below());
            let (x0, _) = responses(&body, &inputs, &freqs, SolveMethod::Factored);
            let mut buffers = SolutionBuffers::default();
            for (f, x0) in freqs.iter().zip(&x0) {
                // grown as the sweep grows it: a target 100× tighter after a failed certificate
                let certified = crate::sweep::growth_targets().any(|t| {
                    space.grow_for(&[*f], t).unwrap();
                    space.solve(*f, Par::Seq, &mut buffers).unwrap().certified()
                });
                assert!(certified, "{what}, {f} Hz: not certified");
                let d = (buffers.x() - x0).norm_l2() / x0.norm_l2();
                assert!(d <= 1e-8, "{what}, {f} Hz: relative difference {d:.2e}");
            }
        }
    }

    /// Undamped, exactly at an eigenfrequency f_k, from a space about σ a millionth above
    /// λ_k: the shift τ = λ_k − σ carries a rounding error ε|σ|, a part in 10⁹ of itself, so
    /// the response's mode-k term is noise, and the forward error estimate must say so
    /// (without the rounding in the amplification it passed, 53 % off a dense solve).
    #[test]
    fn an_eigenfrequency_next_to_an_interior_shift_is_not_answered() {
        let (body, inputs) = bar(Damping::None);
        let lambda = eighth_eigenvalue(&body);
        let fk = crate::units::lambda_to_hz(lambda);
        let sigma = lambda * (1.0 + 2e-6);
        let mut space =
            ShiftedSpace::new(&body, body.elastic_load(&inputs), sigma, body.n(), Par::Seq)
                .unwrap();
        space.grow_for(&[fk], GROW_TO).unwrap();
        let r = space
            .solve(fk, Par::Seq, &mut SolutionBuffers::default())
            .unwrap();
        let estimate = r.forward_error_estimate();
        assert!(
            estimate > crate::sweep::DEFAULT_PROBE_TOL,
            "{fk} Hz: estimate {estimate:.1e}, amplification {:.1e}",
            r.amplification
        );
        // a part in 10⁶ away, the mode is resolved: amplification about 10⁶
        let f = fk * (1.0 - 1e-6);
        let r = space
            .solve(f, Par::Seq, &mut SolutionBuffers::default())
            .unwrap();
        assert!(
            (1e5..1e7).contains(&r.amplification),
            "{f} Hz: amplification {:.1e}",
            r.amplification
        );
    }

    /// About σ a part in 10⁴ above λ_8, the responses away from it equal factored ones to
    /// 1e-10 (measured 9e-12…4e-11 at 3, 117 and 640 Hz). Read from the Lanczos relation
    /// instead, they carry the solves' rounding times about σ/|λ_8 − σ| (measured
    /// 1.6e-10…2.5e-9); the projection formed with K does not.
    #[test]
    fn an_interior_shift_next_to_an_eigenvalue_answers_the_band() {
        let (body, inputs) = bar(LIGHT);
        let sigma = eighth_eigenvalue(&body) * (1.0 + 1e-4);
        let mut space =
            ShiftedSpace::new(&body, body.elastic_load(&inputs), sigma, body.n(), Par::Seq)
                .unwrap();
        let freqs = [3.0, 117.0, 640.0];
        let (x0, _) = responses(&body, &inputs, &freqs, SolveMethod::Factored);
        let mut buffers = SolutionBuffers::default();
        for (f, x0) in freqs.iter().zip(&x0) {
            space.grow_for(&[*f], GROW_TO).unwrap();
            space.solve(*f, Par::Seq, &mut buffers).unwrap();
            let d = (buffers.x() - x0).norm_l2() / x0.norm_l2();
            assert!(d <= 1e-10, "{f} Hz: relative difference {d:.2e}");
        }
    }

    /// The sweep's space made about a band top a millionth above an eigenfrequency (as
    /// line-fitting's count makes it) fails its certificates at every target; the sweep then
    /// answers from a space below the spectrum: two factorizations in all, no frequency
    /// factored, the responses equal factored ones and handed out whole (kept snapshots'
    /// coefficients refer to the first space's basis, which stays).
    #[test]
    fn a_stalled_interior_space_gives_way_to_one_below_the_spectrum() {
        let (body, inputs) = bar(LIGHT);
        let top = crate::units::lambda_to_hz(eighth_eigenvalue(&body)) * (1.0 + 1e-6);
        let solver = Solver::new(
            &body,
            &inputs,
            Kind::Elastic,
            &one_thread(SolveMethod::Auto),
        )
        .unwrap();
        assert!(solver.count_below(top).unwrap().is_some());
        let freqs = [3.0, 117.0, 640.0];
        let (x, spanned, stats) = solver_responses(&solver, &freqs);
        assert!(stats.iter().all(FreqStats::from_space), "{stats:?}");
        assert_eq!(solver.accuracy().space_factorizations, 2);
        // the replaced space's basis is the one coefficients refer to, so the new space's
        // responses come whole
        assert!(spanned.iter().all(|&s| !s));
        let kept = solver.with_basis(|q| q.map(|q| q.ncols()));
        assert!(kept.is_some_and(|k| k != stats[0].space_dim), "{kept:?}");
        let (x0, _) = responses(&body, &inputs, &freqs, SolveMethod::Factored);
        for ((x, x0), f) in x.iter().zip(&x0).zip(freqs) {
            let d = (x - x0).norm_l2() / x0.norm_l2();
            assert!(d <= 1e-8, "{f} Hz: relative difference {d:.2e}");
        }
    }

    /// The amplification is (|λ| + |μ|)/|λ − μ| of the nearest Ritz value, below the
    /// spectrum and inside it alike, and infinite where the shift's rounding covers λ − μ.
    #[test]
    fn the_amplification_is_that_of_the_nearest_mode_with_the_shifts_rounding() {
        let lambdas = [1.0e6, 4.0e6, 9.0e6];
        let mu = 3.9e6;
        let want = (4.0e6 + 3.9e6) / 1.0e5;
        // the Lanczos form (a = 1, b = θ) and the pencil's (a = λ − σ, b = 1)
        let ritz = |lambdas: &[f64], sigma: f64, lanczos: bool| {
            let shifted = lambdas.iter().map(|l| l - sigma);
            let (a, b) = if lanczos {
                (vec![1.0; lambdas.len()], shifted.map(|d| 1.0 / d).collect())
            } else {
                (shifted.collect(), vec![1.0; lambdas.len()])
            };
            let none = Mat::zeros(0, 0);
            Ritz {
                a,
                b,
                z: none.clone(),
                c: none,
            }
        };
        for sigma in [-2.0e6, 2.5e6, 8.0e6] {
            for lanczos in [true, false] {
                let r = ritz(&lambdas, sigma, lanczos);
                let a = amplification(&r, sigma, c64::new(mu - sigma, 0.0));
                assert!(
                    (a / want - 1.0).abs() <= 1e-9,
                    "sigma {sigma}, lanczos {lanczos}: {a} vs {want}"
                );
            }
        }
        // μ = λ: the rounding covers the distance
        let sigma = 4.0e6 * (1.0 + 1e-9);
        for lanczos in [true, false] {
            let r = ritz(&[4.0e6], sigma, lanczos);
            let a = amplification(&r, sigma, c64::new(4.0e6 - sigma, 0.0));
            assert_eq!(a, f64::INFINITY, "lanczos {lanczos}");
        }
    }

    /// A space too small for a frequency fails its certificate: the certificate can fail.
    #[test]
    fn a_space_too_small_fails_its_certificate() {
        let (body, inputs) = bar(Damping::Rayleigh {
            alpha: 0.0,
            beta: 1e-5,
        });
        let load = body.elastic_load(&inputs);
        let sigma = -crate::units::hz_to_lambda(50.0);
        let mut space = ShiftedSpace::new(&body, load, sigma, 18, Par::Seq).unwrap();
        space.grow_for(&[900.0], GROW_TO).unwrap();
        assert_eq!(space.dim(), 18);
        assert!(!space.can_grow());
        assert!(space.estimates(&[900.0])[0] > GROW_TO);
        let r = space.solve(900.0, Par::Seq, &mut SolutionBuffers::default());
        assert!(!r.unwrap().certified());
    }

    /// Growth stops at a floor only when every estimate above the target is within
    /// [`STALLED`] × the target and no batch halved it.
    #[test]
    fn growth_stalls_only_near_the_target_and_without_progress() {
        let t = 1e-12;
        // the dashpot crank's 1 529 Hz: 2.07e-12 → 1.45e-12, the rest met
        assert!(stalled(&[2.07e-12, 1e-13], &[1.45e-12, 9e-14], t));
        // halved: still converging
        assert!(!stalled(&[4e-12], &[1.9e-12], t));
        // far above the target: no floor yet
        assert!(!stalled(&[2e-10], &[1.9e-10], t));
        // one converging frequency keeps the space growing
        assert!(!stalled(&[2e-12, 8e-12], &[1.9e-12, 3e-12], t));
        // only the estimates above the target count
        assert!(stalled(&[2e-12, 8e-12], &[1.9e-12, 5e-13], t));
    }

    /// With the image of `w` given, the orthonormalized columns and their images equal the
    /// ones computed column by column: G-orthonormal, G Q = G·Q to rounding, w = Q C, also
    /// for a column left with little of its norm (its image recomputed) and one deflated.
    #[test]
    fn orthonormalization_from_the_given_image_matches_the_products() {
        let (body, _) = bar(Damping::None);
        let pencil = body.pencil();
        let n = pencil.n();
        let mut rng = crate::random::Xorshift::new(77);
        let mut w = Mat::<f64>::from_fn(n, 5, |_, _| rng.next_centred());
        // column 3 nearly column 0 (kept with 1e-7 of its norm), column 4 a copy (deflated)
        for i in 0..n {
            w[(i, 3)] = w[(i, 0)] + 1e-7 * w[(i, 3)];
            w[(i, 4)] = w[(i, 1)];
        }
        let mass = |x: MatRef<'_, f64>| pencil.mul(Coefficient::Mass, x);
        let gw = mass(w.as_ref());
        let scale: Vec<f64> = (0..5)
            .map(|j| (w.col(j).transpose() * gw.col(j)).sqrt())
            .collect();
        let (q, gq, c) = m_orthonormalize(pencil, w.as_ref(), Some(gw.as_ref()), &scale);
        assert_eq!(q.ncols(), 4, "the copy is deflated");
        let exact = mass(q.as_ref());
        let gram = q.transpose() * &exact;
        for i in 0..4 {
            for j in 0..4 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (gram[(i, j)] - want).abs() < 1e-12,
                    "QᵀMQ ({i}, {j}) = {}",
                    gram[(i, j)]
                );
            }
            let err = (gq.col(i) - exact.col(i)).norm_l2() / exact.col(i).norm_l2();
            assert!(err < 1e-12, "image of column {i}: {err:.1e}");
        }
        let back = &q * &c;
        assert!((&back - &w).norm_l2() <= 1e-12 * w.norm_l2());
        let (q2, _, _) = m_orthonormalize(pencil, w.as_ref(), None, &scale);
        assert!((&q2 - &q).norm_l2() <= 1e-12 * q.norm_l2());
    }
}
