//! The paper's evaluation (§4.3, DESIGN.md §3.7): the relative transfer-function error
//! ε(f) = ‖H(iω) − Hr(iω)‖_F / ‖H(iω)‖_F (eq. 23) on a grid, in two variants, and the ROM's
//! eigenfrequencies.
//!
//! - elastic: H1 (by inertia relief, [`crate::sweep::Part::Elastic`]) vs the ROM;
//! - total: H = H0 + H1 vs H0 + ROM, i.e. ‖H1 − Hr‖ / ‖H0 + H1‖. H is formed as H0 + H1
//!   (exact for Rayleigh damping, DESIGN.md §3.2) rather than by a second sweep: it is more
//!   accurate at low frequency and costs nothing extra. On a constrained body both coincide.
//!
//! The full H1 on the grid comes from the same parallel sweep as everything else.

use crate::model::Model;
use crate::reduce::Rom;
use crate::rigid::RigidBody;
use crate::sweep::{transfer_function, Part, ProgressFn, SweepOptions};
use crate::{Error, Result};
use faer::Mat;

/// ε(f) on a frequency grid.
#[derive(Clone, Debug)]
pub struct ErrorCurve {
    /// Frequencies (Hz).
    pub freqs_hz: Vec<f64>,
    /// ε of the elastic part.
    pub eps_elastic: Vec<f64>,
    /// ε of the total transfer function.
    pub eps_total: Vec<f64>,
    /// Wall time of the full-model sweep (s).
    pub sweep_seconds: f64,
}

impl ErrorCurve {
    /// (max, mean) of a curve.
    pub fn max_mean(v: &[f64]) -> (f64, f64) {
        let max = v.iter().copied().fold(0.0, f64::max);
        (max, v.iter().sum::<f64>() / v.len().max(1) as f64)
    }
}

/// ε(f) of `rom` against `model` at `freqs_hz` (both variants; see the module doc).
///
/// # Errors
/// The sweep's errors (e.g. f = 0 on a free body).
pub fn transfer_error(model: &Model, rom: &Rom, freqs_hz: &[f64], opts: &SweepOptions, progress: ProgressFn<'_>) -> Result<ErrorCurve> {
    if freqs_hz.is_empty() {
        return Err(Error::InvalidSetting("error curve: no frequencies".into()));
    }
    let h1 = transfer_function(model, &rom.inputs, &rom.outputs, freqs_hz, Part::Elastic, false, opts, progress)?;
    let rigid = RigidBody::detect(model)?;
    let mut eps_elastic = Vec::with_capacity(freqs_hz.len());
    let mut eps_total = Vec::with_capacity(freqs_hz.len());
    for (k, &f) in freqs_hz.iter().enumerate() {
        let hr = rom.transfer(f);
        let diff = (&h1.h[k] - &hr).norm_l2();
        eps_elastic.push(diff / h1.h[k].norm_l2());
        let total = match &rigid {
            Some(rb) => &h1.h[k] + rb.h0(2.0 * std::f64::consts::PI * f, &rom.inputs, &rom.outputs),
            None => h1.h[k].clone(),
        };
        eps_total.push(diff / total.norm_l2());
    }
    Ok(ErrorCurve {
        freqs_hz: freqs_hz.to_vec(),
        eps_elastic,
        eps_total,
        sweep_seconds: h1.seconds,
    })
}

/// Eigenfrequencies (Hz, ascending) of Kr φ = λ Mr φ, as sign(λ)·√|λ| / 2π.
///
/// # Errors
/// [`Error::InvalidSetting`] when Mr is not positive definite.
pub fn rom_eigenfrequencies(rom: &Rom) -> Result<Vec<f64>> {
    generalized_eigenfrequencies(&rom.kr, &rom.mr)
}

/// Eigenfrequencies of a small dense symmetric pencil (K, M), M positive definite.
///
/// # Errors
/// [`Error::InvalidSetting`] when M is not positive definite or the eigensolver fails.
pub fn generalized_eigenfrequencies(k: &Mat<f64>, m: &Mat<f64>) -> Result<Vec<f64>> {
    use faer::linalg::solvers::DenseSolveCore;
    let llt = m
        .llt(faer::Side::Lower)
        .map_err(|_| Error::InvalidSetting("the reduced mass matrix is not positive definite".into()))?;
    let linv = llt.L().to_owned().partial_piv_lu().inverse();
    let c = &linv * k * linv.transpose();
    let c = Mat::from_fn(c.nrows(), c.ncols(), |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    let ev = c
        .self_adjoint_eigenvalues(faer::Side::Lower)
        .map_err(|_| Error::InvalidSetting("dense eigensolver did not converge".into()))?;
    Ok(ev
        .iter()
        .map(|&l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI))
        .collect())
}
