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
        self.absorb_all(w, &[x])
    }

    /// Absorbs the responses `xs` as one block of rows (the rows of each as in
    /// [`Self::absorb`], stacked): the same least-squares state as absorbing them one by one,
    /// with one pass over the state's Y instead of one per response.
    ///
    /// # Errors
    /// As [`StreamedQr::absorb`].
    pub fn absorb_all(&self, w: &mut SplitState, xs: &[MatRef<'_, c64>]) -> Result<()> {
        let t = Instant::now();
        let rows = 2 * xs.iter().map(|x| x.ncols()).sum::<usize>();
        if w.g.nrows() != rows {
            w.g = Mat::zeros(rows, self.interface.len());
            w.f = Mat::zeros(rows, self.rest.len());
        }
        let mut at = 0;
        for x in xs {
            let p = x.ncols();
            for j in 0..p {
                for (c, &d) in self.interface.iter().enumerate() {
                    w.g[(at + j, c)] = x[(d, j)].re;
                    w.g[(at + p + j, c)] = x[(d, j)].im;
                }
                for (r, &d) in self.rest.iter().enumerate() {
                    w.f[(at + j, r)] = x[(d, j)].re;
                    w.f[(at + p + j, r)] = x[(d, j)].im;
                }
            }
            at += 2 * p;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Xorshift;

    /// Absorbing three responses as one block gives the state absorbing them one by one
    /// gives, up to the orthogonal factor: the same RᵀR = T_o T_oᵀ and RᵀY = T_o T_nᵀ.
    #[test]
    fn a_batch_absorbs_as_its_responses_one_by_one() {
        let (n_full, p) = (40, 2);
        let split = Split::from_interface(n_full, vec![3, 17, 29, 8, 11]);
        let mut rng = Xorshift::new(5);
        let xs: Vec<Mat<c64>> = (0..3)
            .map(|_| {
                Mat::from_fn(n_full, p, |_, _| {
                    c64::new(rng.next_centred(), rng.next_centred())
                })
            })
            .collect();
        let mut one = split.state(p);
        for x in &xs {
            split.absorb(&mut one, x.as_ref()).unwrap();
        }
        let mut all = split.state(p);
        let refs: Vec<_> = xs.iter().map(|x| x.as_ref()).collect();
        split.absorb_all(&mut all, &refs).unwrap();
        let gram = |s: &SplitState| {
            let r = s.qr.r();
            (r.transpose() * r, r.transpose() * s.qr.y())
        };
        let ((a1, b1), (a2, b2)) = (gram(&one), gram(&all));
        assert!((&a1 - &a2).norm_l2() <= 1e-13 * a1.norm_l2());
        assert!((&b1 - &b2).norm_l2() <= 1e-13 * b1.norm_l2());
        assert_eq!(all.qr.rows(), one.qr.rows());
    }
}
