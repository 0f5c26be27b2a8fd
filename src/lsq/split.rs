//! The row split of eq. 22 (docs/design.md §3.3): a response X (N × p, complex) at one
//! frequency becomes the block pair
//!
//! ```text
//! G = [Re X[I,:], Im X[I,:]]ᵀ  (2p × n),   F = [Re X[R,:], Im X[R,:]]ᵀ  (2p × (N − n))
//! ```
//!
//! with I the kept rows (n of them, in their order) and R the others, ascending. Blocks are
//! absorbed into a [`StreamedQr`] per worker ([`Split::absorb`]) and the workers' states
//! merged (TSQR, [`Split::merge`]). The frequency engine runs this for any caller; what the
//! rows mean (line-fitting's interface) is the caller's.

use super::qr::StreamedQr;
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::{c64, Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;
use std::time::Instant;

/// Rows of R per task when a state is built from coefficients ([`Split::state_in_span`]).
const SPAN_BLOCK_ROWS: usize = 2048;

/// C = [Re c_1, Im c_1, Re c_2, …] (k × Σ 2p_i, real) for coefficient blocks c_i with at
/// most k rows (zero rows below each): the responses X_i = Q c_i have
/// [Re X_1, Im X_1, …] = Q C.
pub fn stacked_coefficients(coefs: &[Mat<c64>], k: usize) -> Mat<f64> {
    let cols = coefs.iter().map(|c| 2 * c.ncols()).sum();
    let mut s = Mat::<f64>::zeros(k, cols);
    let mut at = 0;
    for c in coefs {
        let p = c.ncols();
        for j in 0..p {
            for i in 0..c.nrows().min(k) {
                s[(i, at + j)] = c[(i, j)].re;
                s[(i, at + p + j)] = c[(i, j)].im;
            }
        }
        at += 2 * p;
    }
    s
}

/// The kept rows I and the other rows R of an N-row response.
pub struct Split {
    /// Kept rows I (the columns of G, in this order).
    pub interface: Vec<usize>,
    /// The other rows R, ascending.
    pub rest: Vec<usize>,
}

/// One worker's streamed QR and its reusable block buffers.
pub struct SplitState {
    /// The QR of every block this worker absorbed.
    pub qr: StreamedQr,
    g: Mat<f64>,
    f: Mat<f64>,
    /// Seconds spent absorbing.
    pub absorb_s: f64,
}

impl Split {
    /// The split of N rows keeping `interface` (in range and unique: the caller checks).
    pub fn from_interface(n_full: usize, interface: Vec<usize>) -> Self {
        let mut is_interface = vec![false; n_full];
        for &d in &interface {
            is_interface[d] = true;
        }
        let rest = (0..n_full).filter(|&d| !is_interface[d]).collect();
        Split { interface, rest }
    }

    /// The number n of kept rows.
    pub fn order(&self) -> usize {
        self.interface.len()
    }

    /// A streamed QR of this split that has absorbed nothing.
    pub fn empty_qr(&self) -> StreamedQr {
        StreamedQr::new(self.interface.len(), self.rest.len())
    }

    /// An empty worker state for responses of p columns.
    pub fn state(&self, p: usize) -> SplitState {
        SplitState {
            qr: self.empty_qr(),
            g: Mat::zeros(2 * p, self.interface.len()),
            f: Mat::zeros(2 * p, self.rest.len()),
            absorb_s: 0.0,
        }
    }

    /// Absorbs one response X (N × p): G = [Re X[I,:], Im X[I,:]]ᵀ,
    /// F = [Re X[R,:], Im X[R,:]]ᵀ.
    ///
    /// # Errors
    /// As [`StreamedQr::absorb`].
    pub fn absorb(&self, w: &mut SplitState, x: MatRef<'_, c64>) -> Result<()> {
        let t = Instant::now();
        let p = x.ncols();
        for j in 0..p {
            for (c, &d) in self.interface.iter().enumerate() {
                w.g[(j, c)] = x[(d, j)].re;
                w.g[(p + j, c)] = x[(d, j)].im;
            }
            for (r, &d) in self.rest.iter().enumerate() {
                w.f[(j, r)] = x[(d, j)].re;
                w.f[(p + j, r)] = x[(d, j)].im;
            }
        }
        w.qr.absorb(w.g.as_ref(), w.f.as_ref())?;
        w.absorb_s += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// The state of absorbing the responses X_i = Q c_i (`coefs`, each k_i × p with
    /// k_i ≤ k; Q real N × k), without forming them. With C = [Re c_1, Im c_1, …]
    /// ([`stacked_coefficients`]) the stacked blocks are T_oᵀ = Cᵀ Q_Iᵀ and T_nᵀ = Cᵀ Q_Rᵀ
    /// (Q_I, Q_R the rows of Q at I and R). A Householder QR T_oᵀ = Q₁R₁ gives the state
    /// (docs/design.md §3.3):
    ///
    /// ```text
    /// R = R₁,   Y = Q₁ᵀT_nᵀ = H Q_Rᵀ,   e_j = ‖(I − Q₁Q₁ᵀ)Cᵀ q_j‖² = ‖R_E q_j‖²
    /// ```
    ///
    /// with H = Q₁ᵀCᵀ, q_j row j of Q and R_E the triangle of E = Cᵀ − Q₁H. Cost
    /// O(N·k·(n + k)) and the small QRs, against O(N·n·Σ2p_i) for absorbing the formed
    /// responses; equal to that state up to rounding and the signs of R's rows.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] for a coefficient block with more rows than Q has columns,
    /// or NaN/Inf in them.
    pub fn state_in_span(&self, q: MatRef<'_, f64>, coefs: &[Mat<c64>]) -> Result<StreamedQr> {
        let (k, n, m) = (q.ncols(), self.interface.len(), self.rest.len());
        if let Some(c) = coefs.iter().find(|c| c.nrows() > k) {
            return Err(Error::InvalidSetting(format!(
                "response coefficients of {} rows for a basis of {k} vectors",
                c.nrows()
            )));
        }
        let c = stacked_coefficients(coefs, k);
        if !c.as_ref().is_all_finite() {
            return Err(Error::InvalidSetting(
                "NaN or Inf in the response coefficients".into(),
            ));
        }
        let rows = c.ncols();
        let q_i = Mat::<f64>::from_fn(n, k, |i, j| q[(self.interface[i], j)]);
        let t_o = (q_i * &c).transpose().to_owned();
        let qr = t_o.qr();
        let q1 = qr.compute_thin_Q();
        let r1 = qr.thin_R();
        let r = Mat::<f64>::from_fn(n, n, |i, j| if i < r1.nrows() { r1[(i, j)] } else { 0.0 });
        let h = q1.transpose() * c.transpose();
        let e_mat = c.transpose() - &q1 * &h;
        let r_e = e_mat.qr().thin_R().to_owned();
        let (mut y, mut e) = (vec![0.0; n * m], vec![0.0; m]);
        y.par_chunks_mut(n * SPAN_BLOCK_ROWS)
            .zip(e.par_chunks_mut(SPAN_BLOCK_ROWS))
            .enumerate()
            .for_each(|(b, (yb, eb))| {
                let rest = &self.rest[b * SPAN_BLOCK_ROWS..][..eb.len()];
                let qb = Mat::<f64>::from_fn(rest.len(), k, |i, j| q[(rest[i], j)]);
                let yb = MatMut::from_column_major_slice_mut(yb, n, rest.len());
                matmul(
                    yb.subrows_mut(0, h.nrows()),
                    Accum::Replace,
                    h.as_ref(),
                    qb.transpose(),
                    1.0,
                    Par::Seq,
                );
                let z = &qb * r_e.transpose();
                for (i, x) in eb.iter_mut().enumerate() {
                    *x = z.row(i).squared_norm_l2();
                }
            });
        StreamedQr::from_parts(r, y, e, rows)
    }

    /// Merges worker states into one (TSQR).
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] when there is nothing to merge; as [`StreamedQr::merge`].
    pub fn merge(workers: Vec<SplitState>) -> Result<StreamedQr> {
        let mut it = workers.into_iter().map(|w| w.qr);
        let first = it
            .next()
            .ok_or_else(|| Error::InvalidSetting("no reference frequency was solved".into()))?;
        it.try_fold(first, |a, b| a.merge(b))
    }
}
