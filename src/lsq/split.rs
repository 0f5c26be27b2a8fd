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

use super::StreamedQr;
use crate::{Error, Result};
use faer::{c64, Mat, MatRef};
use std::time::Instant;

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
