//! The eigenpairs returned ([`Modes`]) and the post-processing shared by both iterations
//! (docs/design.md §3.6, "Post-processing"): ascending order, the normwise backward errors
//! η = ‖Kφ − λMφ‖ / ((‖K‖₁ + |λ|‖M‖₁)‖φ‖), rejected above [`MAX_BACKWARD_ERROR`], and the
//! rigid count — with V0 (§3.2) a mode is rigid when the M-projection onto span V0 carries at
//! least half its M-norm², without V0 when |λ| ≤ [`RIGID_RTOL`] · max_i K_ii/M_ii.

use super::stats::EigenStats;
use crate::body::Body;
use crate::pencil::Coefficient;
use crate::{Error, Result};
use faer::{Mat, Side};

/// |λ| ≤ RIGID_RTOL · max_i K_ii/M_ii marks a rigid-body mode when the model gives no rigid
/// modes V0 (see the module doc).
pub const RIGID_RTOL: f64 = 1e-10;

/// Largest accepted normwise backward error of a returned eigenpair ([`Modes::residuals`]);
/// a backward-stable iteration gives a small multiple of ε.
pub const MAX_BACKWARD_ERROR: f64 = 1e-10;

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

/// The shared post-processing: ascending order, residuals and the rigid count.
pub(super) fn finish(
    body: &Body,
    lambdas: Vec<f64>,
    vectors: Mat<f64>,
    stats: EigenStats,
) -> Result<Modes> {
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
