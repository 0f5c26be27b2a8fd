//! The paper's evaluation (§4.3, docs/design.md §3.7): the relative transfer-function error
//! ε(f) = ‖H(iω) − Hr(iω)‖_F / ‖H(iω)‖_F (eq. 23) on a grid, in two variants, the ROM's
//! eigenfrequencies (its rigid modes at 0 Hz) and MAC, and the definiteness of Mr and Kr in
//! words (§3.4).
//!
//! - elastic: H1 (by inertia relief, [`crate::frf::Part::Elastic`]) vs the ROM;
//! - total: H = H0 + H1 vs H0 + ROM, i.e. ‖H1 − Hr‖ / ‖H0 + H1‖. H is formed as H0 + H1
//!   (exact for Rayleigh damping, docs/design.md §3.2) rather than by a second sweep: it is more
//!   accurate at low frequency and costs nothing extra. On a constrained body both coincide.
//!
//! The full H1 on the grid comes from the same parallel sweep as everything else.

use crate::body::Body;
use crate::eigen::{Modes, RIGID_RTOL};
use crate::engine::Cluster;
use crate::frf::{transfer_function, Part};
use crate::reduce::spectrum::rigid_tol;
pub use crate::reduce::spectrum::{rom_eigenfrequencies, rom_modes, rom_spectrum, RomSpectrum};
use crate::reduce::{Definiteness, Rom};
use crate::scene::Scene;
use crate::sweep::{ProgressFn, SweepOptions};
use crate::units::lambda_to_hz;
use crate::{Error, Result};
use faer::{c64, Mat, MatRef};
use std::sync::Arc;

/// ε(f) on a frequency grid.
#[derive(Clone, Debug)]
pub struct ErrorCurve {
    /// Frequencies (Hz).
    pub freqs_hz: Vec<f64>,
    /// ε of the elastic part.
    pub eps_elastic: Vec<f64>,
    /// ε of the total transfer function.
    pub eps_total: Vec<f64>,
}

impl ErrorCurve {
    /// (max, mean) of a curve.
    pub fn max_mean(v: &[f64]) -> (f64, f64) {
        let max = v.iter().copied().fold(0.0, f64::max);
        (max, v.iter().sum::<f64>() / v.len().max(1) as f64)
    }
}

/// The full model's transfer functions on a grid, computed once and compared with any
/// number of ROMs.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Frequencies (Hz).
    pub freqs_hz: Vec<f64>,
    /// Input DoFs.
    pub inputs: Vec<usize>,
    /// Output DoFs.
    pub outputs: Vec<usize>,
    /// H1 (elastic part) per frequency.
    pub h1: Vec<Mat<c64>>,
    /// H = H0 + H1 per frequency (= H1 on a constrained body).
    pub h: Vec<Mat<c64>>,
    /// Wall time of the full-model sweep (s).
    pub sweep_seconds: f64,
}

impl Reference {
    /// Sweeps the full model at `freqs_hz` (see the module doc for H = H0 + H1), in this
    /// process or over the ranks of `cluster`.
    ///
    /// # Errors
    /// The sweep's errors (e.g. f = 0 on a free body).
    pub fn compute(
        body: &Body,
        scene: &Scene,
        freqs_hz: &[f64],
        opts: &SweepOptions,
        cluster: Option<Arc<dyn Cluster>>,
        progress: ProgressFn<'_>,
    ) -> Result<Self> {
        if freqs_hz.is_empty() {
            return Err(Error::InvalidSetting("error curve: no frequencies".into()));
        }
        let (inputs, outputs) = (&scene.inputs[..], &scene.outputs[..]);
        let frf = transfer_function(
            body,
            scene,
            freqs_hz,
            Part::Elastic,
            opts,
            cluster,
            progress,
        )?;
        let h = frf
            .h
            .iter()
            .zip(freqs_hz)
            .map(|(h1, &f)| match body.rigid() {
                Some(rb) => h1 + rb.h0(2.0 * std::f64::consts::PI * f, inputs, outputs),
                None => h1.clone(),
            })
            .collect();
        Ok(Reference {
            freqs_hz: freqs_hz.to_vec(),
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
            h1: frf.h,
            h,
            sweep_seconds: frf.seconds,
        })
    }

    /// ε(f) of `rom` (both variants).
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] when the ROM has other inputs/outputs than the reference.
    pub fn error(&self, rom: &Rom) -> Result<ErrorCurve> {
        if rom.inputs != self.inputs || rom.outputs != self.outputs {
            return Err(Error::InvalidSetting(
                "the ROM's inputs/outputs differ from the reference's".into(),
            ));
        }
        let mut eps_elastic = Vec::with_capacity(self.freqs_hz.len());
        let mut eps_total = Vec::with_capacity(self.freqs_hz.len());
        let h1: Vec<MatRef<'_, c64>> = self.h1.iter().map(|h| h.as_ref()).collect();
        for (k, diff) in rom
            .transfer_differences(&self.freqs_hz, &h1)
            .into_iter()
            .enumerate()
        {
            eps_elastic.push(diff / self.h1[k].norm_l2());
            eps_total.push(diff / self.h[k].norm_l2());
        }
        Ok(ErrorCurve {
            freqs_hz: self.freqs_hz.clone(),
            eps_elastic,
            eps_total,
        })
    }
}

/// The definiteness class of a reduced matrix (docs/design.md §3.4), as every command prints it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Definite {
    /// Positive definite (Cholesky succeeded; for Kr also no rigid mode): `SPD`.
    Positive,
    /// Positive semidefinite: `semidefinite (k rigid)`, for Kr with its k rigid modes, or
    /// `semidefinite` when they are not counted.
    Semi(Option<usize>),
    /// Indefinite: `indefinite (k negative)`, for Kr with its k modes at λ < −τ, or
    /// `indefinite` when they are not counted.
    Indefinite(Option<usize>),
}

impl Definite {
    /// From the Cholesky test and the extreme eigenvalues μ of the matrix alone: SPD when
    /// Cholesky succeeded, else semidefinite when μ_min ≥ −[`RIGID_RTOL`] · μ_max, else
    /// indefinite.
    pub fn of(d: &Definiteness) -> Self {
        if d.positive_definite {
            Definite::Positive
        } else if d.min_eig >= -RIGID_RTOL * d.max_eig {
            Definite::Semi(None)
        } else {
            Definite::Indefinite(None)
        }
    }
}

impl std::fmt::Display for Definite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Definite::Positive => f.write_str("SPD"),
            Definite::Semi(None) => f.write_str("semidefinite"),
            Definite::Semi(Some(k)) => write!(f, "semidefinite ({k} rigid)"),
            Definite::Indefinite(None) => f.write_str("indefinite"),
            Definite::Indefinite(Some(k)) => write!(f, "indefinite ({k} negative)"),
        }
    }
}

/// The definiteness of Mr and Kr (docs/design.md §3.4) in the words every command prints,
/// `Mr SPD, Kr semidefinite (6 rigid)`. Kr is classed by the ROM's spectrum Kr φ = λ Mr φ when
/// Mr is positive definite — by Sylvester's law of inertia its signs are those of Kr's
/// eigenvalues, and its zeros are the rigid modes printed at 0 Hz ([`RomSpectrum`]) — so a free
/// body's Craig–Bampton ROM, which keeps the six rigid modes, reads `semidefinite (6 rigid)`
/// whether or not rounding let Kr's Cholesky pass; otherwise, and when the spectrum shows
/// neither rigid nor negative modes, by [`Definite::of`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stability {
    /// Mr.
    pub mass: Definite,
    /// Kr.
    pub stiffness: Definite,
}

impl Stability {
    /// The classes of a ROM's Mr and Kr.
    pub fn of(rom: &Rom) -> Self {
        let stiffness = match rom_spectrum(rom) {
            Ok(s) if s.negative > 0 => Definite::Indefinite(Some(s.negative)),
            Ok(s) if s.rigid > 0 => Definite::Semi(Some(s.rigid)),
            _ => Definite::of(&rom.stiffness_definiteness),
        };
        Stability {
            mass: Definite::of(&rom.mass_definiteness),
            stiffness,
        }
    }
}

impl std::fmt::Display for Stability {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Mr {}, Kr {}", self.mass, self.stiffness)
    }
}

/// MAC(a, b) = (aᵀb)² / (aᵀa · bᵀb).
pub fn mac(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
    let ab = (a.transpose() * b)[(0, 0)];
    ab * ab / ((a.transpose() * a)[(0, 0)] * (b.transpose() * b)[(0, 0)])
}

/// One full-model deformation mode in the band and the ROM mode paired with it.
#[derive(Clone, Debug)]
pub struct ModePair {
    /// 1-based number of the full mode among all modes (rigid included).
    pub full_mode: usize,
    /// Its frequency (Hz).
    pub full_hz: f64,
    /// 1-based number of the paired ROM mode.
    pub rom_mode: usize,
    /// Its frequency (Hz).
    pub rom_hz: f64,
    /// |f_rom − f_full| / f_full.
    pub rel_freq_error: f64,
    /// MAC of the pair.
    pub mac: f64,
}

/// Eigenfrequency errors and MAC of a ROM (paper §4.3).
#[derive(Clone, Debug)]
pub struct ModalComparison {
    /// One pair per full deformation mode that has a ROM partner, by full mode number.
    pub pairs: Vec<ModePair>,
    /// Full deformation modes without a ROM partner (1-based number, frequency in Hz): the
    /// ROM has fewer elastic modes than the full model has in the comparison.
    pub unpaired: Vec<(usize, f64)>,
    /// True when the MAC used expanded ROM modes V φ̃ over all N DoFs; false when it was taken
    /// on the ROM's DoFs only (no V available: ROM coordinates are physical DoF values).
    pub expanded: bool,
}

/// MAC of every full-model deformation mode against every ROM elastic mode.
#[derive(Clone, Debug)]
pub struct MacMatrix {
    /// Rows: the full deformation modes (1-based number among all modes, frequency in Hz).
    pub full: Vec<(usize, f64)>,
    /// Columns: the ROM's elastic modes (1-based number among its modes, frequency in Hz).
    pub rom: Vec<(usize, f64)>,
    /// `values[(r, c)]` = MAC(full mode r, ROM mode c).
    pub values: Mat<f64>,
    /// True when the ROM modes were expanded to V φ̃ over all N DoFs; false when the MAC
    /// was taken on the ROM's DoFs only (no V available).
    pub expanded: bool,
}

/// The MAC matrix of the deformation modes of `full` (rigid ones skipped) against the
/// ROM's elastic modes (λ > [`RIGID_RTOL`] · λ_max). The MAC uses V φ̃ when `basis` (V) is
/// given, else the mode shapes on the ROM's DoFs.
///
/// # Errors
/// As [`rom_modes`].
pub fn mac_matrix(rom: &Rom, full: &Modes, basis: Option<MatRef<'_, f64>>) -> Result<MacMatrix> {
    let (lam_r, phi_r) = rom_modes(rom)?;
    let tol = rigid_tol(&lam_r);
    let rom_elastic: Vec<usize> = (0..lam_r.len()).filter(|&j| lam_r[j] > tol).collect();
    let expanded_modes = basis.map(|v| v * &phi_r);
    let full_modes: Vec<usize> = (full.rigid..full.lambdas.len()).collect();
    let mut values = Mat::zeros(full_modes.len(), rom_elastic.len());
    for (a_idx, &i) in full_modes.iter().enumerate() {
        let phi_full = full.vectors.as_ref().col(i).as_mat();
        let a = match &expanded_modes {
            Some(_) => phi_full.to_owned(),
            None => Mat::from_fn(rom.dofs.len(), 1, |r, _| phi_full[(rom.dofs[r], 0)]),
        };
        for (b_idx, &j) in rom_elastic.iter().enumerate() {
            let b = match &expanded_modes {
                Some(e) => e.as_ref().col(j).as_mat().to_owned(),
                // the ROM's physical coordinates (for Craig–Bampton the boundary rows only)
                None => phi_r
                    .as_ref()
                    .col(j)
                    .subrows(0, rom.dofs.len())
                    .as_mat()
                    .to_owned(),
            };
            values[(a_idx, b_idx)] = mac(a.as_ref(), b.as_ref());
        }
    }
    Ok(MacMatrix {
        full: full_modes
            .iter()
            .map(|&i| (i + 1, lambda_to_hz(full.lambdas[i])))
            .collect(),
        rom: rom_elastic
            .iter()
            .map(|&j| (j + 1, lambda_to_hz(lam_r[j])))
            .collect(),
        values,
        expanded: expanded_modes.is_some(),
    })
}

/// Pairs the deformation modes of `full` (rigid ones skipped) one-to-one with the ROM's
/// elastic modes and reports the relative frequency error and MAC of each pair: the
/// [`ModalComparison::from_mac`] of the [`mac_matrix`].
///
/// # Errors
/// As [`rom_modes`].
pub fn modal_comparison(
    rom: &Rom,
    full: &Modes,
    basis: Option<MatRef<'_, f64>>,
) -> Result<ModalComparison> {
    Ok(ModalComparison::from_mac(&mac_matrix(rom, full, basis)?))
}

impl ModalComparison {
    /// Pairs the rows (full modes) of `m` one-to-one with its columns (ROM modes).
    ///
    /// Pairing rule (one-to-one, by MAC): of all (full, ROM) combinations not yet used, the
    /// one of largest MAC is paired next, until one side runs out — a stable matching, so no
    /// full and ROM mode would both rather be paired with each other than with their
    /// partners. Full modes left over are listed in [`ModalComparison::unpaired`].
    pub fn from_mac(m: &MacMatrix) -> Self {
        let (nf, nr) = (m.full.len(), m.rom.len());
        let mut candidates: Vec<(f64, usize, usize)> = (0..nf)
            .flat_map(|a| (0..nr).map(move |b| (a, b)))
            .map(|(a, b)| (m.values[(a, b)], a, b))
            .collect();
        // largest MAC first; ties by full mode, then ROM mode (deterministic)
        candidates.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let (mut full_used, mut rom_used) = (vec![false; nf], vec![false; nr]);
        let mut pairs = Vec::new();
        for (mac, a_idx, b_idx) in candidates {
            if full_used[a_idx] || rom_used[b_idx] {
                continue;
            }
            full_used[a_idx] = true;
            rom_used[b_idx] = true;
            let ((full_mode, f), (rom_mode, fr)) = (m.full[a_idx], m.rom[b_idx]);
            pairs.push(ModePair {
                full_mode,
                full_hz: f,
                rom_mode,
                rom_hz: fr,
                rel_freq_error: (fr - f).abs() / f,
                mac,
            });
        }
        pairs.sort_by_key(|p| p.full_mode);
        let unpaired = m
            .full
            .iter()
            .zip(&full_used)
            .filter(|(_, &used)| !used)
            .map(|(&mode, _)| mode)
            .collect();
        ModalComparison {
            pairs,
            unpaired,
            expanded: m.expanded,
        }
    }
}
