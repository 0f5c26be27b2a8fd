//! The ROM's own spectrum (docs/design.md §3.6–3.7): Kr φ̃ = λ Mr φ̃ by a dense
//! Cholesky-reduced symmetric eigenproblem, its eigenfrequencies with the rigid modes at 0 Hz.
//! Used by the sampling loop's growth (§3.5) and, through `metrics`, by every report.

use super::Rom;
use crate::eigen::RIGID_RTOL;
use crate::units::lambda_to_hz;
use crate::{Error, Result};
use faer::Mat;

/// Eigenpairs of the ROM, Kr φ̃ = λ Mr φ̃ (ascending λ, Mr-orthonormal φ̃).
///
/// # Errors
/// [`Error::InvalidSetting`] when Mr is not positive definite or the eigensolver fails.
pub fn rom_modes(rom: &Rom) -> Result<(Vec<f64>, Mat<f64>)> {
    use faer::linalg::solvers::DenseSolveCore;
    let llt = rom.mr.llt(faer::Side::Lower).map_err(|_| {
        Error::InvalidSetting("the reduced mass matrix Mr is not positive definite".into())
    })?;
    let linv = llt.L().to_owned().partial_piv_lu().inverse();
    let c = &linv * &rom.kr * linv.transpose();
    let (lambdas, u) = crate::dense::sym_eigen(c.as_ref())
        .ok_or_else(|| Error::InvalidSetting("dense eigensolver did not converge".into()))?;
    Ok((lambdas, linv.transpose() * u))
}

/// Eigenfrequencies (Hz, ascending) of the ROM, f = √λ / 2π as computed (signed for λ < 0).
///
/// # Errors
/// As [`rom_modes`].
pub fn rom_eigenfrequencies(rom: &Rom) -> Result<Vec<f64>> {
    Ok(rom_modes(rom)?.0.into_iter().map(lambda_to_hz).collect())
}

/// The rigid tolerance τ of a ROM spectrum (docs/design.md §3.6–3.7): a ROM mode is rigid
/// when |λ| ≤ τ = [`RIGID_RTOL`] · λ_max — the full model's rule without V0, applied to the
/// ROM's own spectrum, whose largest eigenvalue is known exactly — elastic when λ > τ and
/// negative (an unstable ROM) when λ < −τ.
pub(crate) fn rigid_tol(lambdas: &[f64]) -> f64 {
    RIGID_RTOL * lambdas.iter().copied().fold(0.0, f64::max)
}

/// The ROM's eigenfrequencies reported as [`crate::eigen::Modes::freqs_hz`] reports the full
/// model's.
#[derive(Clone, Debug)]
pub struct RomSpectrum {
    /// f = √λ / 2π (Hz, ascending; signed for λ < 0), the rigid modes at exactly 0 Hz (their
    /// computed λ is a rounding-level number of either sign).
    pub freqs_hz: Vec<f64>,
    /// Rigid modes, |λ| ≤ τ = [`RIGID_RTOL`] · λ_max; the modal comparison (MAC) compares the
    /// modes above τ.
    pub rigid: usize,
    /// Modes with λ < −τ.
    pub negative: usize,
}

/// The ROM's eigenfrequencies with its rigid modes at 0 Hz ([`RomSpectrum`]).
///
/// # Errors
/// As [`rom_modes`].
pub fn rom_spectrum(rom: &Rom) -> Result<RomSpectrum> {
    let lambdas = rom_modes(rom)?.0;
    let tol = rigid_tol(&lambdas);
    Ok(RomSpectrum {
        freqs_hz: lambdas
            .iter()
            .map(|&l| if l.abs() <= tol { 0.0 } else { lambda_to_hz(l) })
            .collect(),
        rigid: lambdas.iter().filter(|&&l| l.abs() <= tol).count(),
        negative: lambdas.iter().filter(|&&l| l < -tol).count(),
    })
}
