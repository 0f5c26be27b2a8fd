//! The reduced model Mr q̈ + Dr q̇ + Kr q = Br u, y = Cr q (docs/design.md §3.4) and where
//! it came from: method, reference frequencies and fit numerics, sampling history, SEREP
//! modes — everything a front end reports and writes to `rom.toml`.

use super::projection::{Definiteness, Projected};
use super::sampling_report::SamplingReport;
use crate::scene::Scene;
use crate::{Error, Result};
use faer::linalg::solvers::Solve;
use faer::{c64, Mat};

/// How a ROM was built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Line-fitting (docs/design.md §3.3).
    LineFit,
    /// SEREP (docs/design.md §3.6).
    Serep,
    /// Craig–Bampton (docs/design.md §3.8).
    CraigBampton,
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Method::LineFit => "linefit",
            Method::Serep => "serep",
            Method::CraigBampton => "craig-bampton",
        })
    }
}

/// Wall time of one phase of a reduction.
#[derive(Clone, Debug)]
pub struct Timing {
    /// Phase name.
    pub phase: String,
    /// Seconds.
    pub seconds: f64,
}

/// How many DoFs of largest fit residual a [`FitReport`] keeps for interface growth.
pub const GROWTH_CANDIDATES: usize = 64;

/// Numerics of the least-squares fit (line-fitting), reported to the user.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct FitReport {
    /// cond(T_oᵀ) before column equilibration.
    pub cond_raw: f64,
    /// cond(T_oᵀ) after column equilibration (what the rank decision uses).
    pub cond_equilibrated: f64,
    /// Numerical rank of T_oᵀ.
    pub rank: usize,
    /// True when singular values were truncated (rank < n).
    pub truncated: bool,
    /// Max over non-interface DoFs of the relative fit residual (eq. 22).
    pub residual_max: f64,
    /// Mean of the relative fit residual.
    pub residual_mean: f64,
    /// DoF with the largest fit residual: the best hint where to add an interface DoF.
    pub residual_argmax_dof: usize,
    /// The non-interface DoFs of largest fit residual, at most one per node, largest first
    /// (up to [`GROWTH_CANDIDATES`]): where the sampling loop grows the interface (§3.5).
    #[serde(skip)]
    pub growth_candidates: Vec<usize>,
    /// Rows of T_oᵀ (2pz).
    pub rows: usize,
    /// How accurate the full-model solves behind the snapshots were (docs/design.md §3.1).
    #[serde(default)]
    pub solves: crate::sweep::SolveAccuracy,
}

/// Numerics of a Craig–Bampton reduction (docs/design.md §3.8), reported to the user and
/// stored in `rom.toml` (`[craig_bampton]`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CraigBamptonReport {
    /// Frequencies (Hz) of the c fixed-interface modes, ascending.
    pub fixed_interface_hz: Vec<f64>,
    /// Their normwise backward errors η (as [`crate::eigen::Modes::residuals`]).
    pub mode_residuals: Vec<f64>,
    /// The factorization of K_ii: `cholesky` (positive definite) or `lblt`.
    pub factorization: String,
    /// min/max |pivot| of the LBLᵀ factorization (none for Cholesky).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pivot_ratio: Option<f64>,
    /// Largest relative residual ‖K_ii ψ_j + K_ib e_j‖ / ‖K_ib e_j‖ of the constraint modes.
    pub static_residual: f64,
    /// Residual vectors of the dampers: the fixed-interface static responses to the damping
    /// remainder's force patterns (docs/design.md §3.8, §3.12), coordinates after the modes.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub residual_vectors: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// Where a ROM came from: the method and what it was built from.
#[derive(Clone, Debug)]
// one per ROM: boxing the line-fitting report would buy nothing
#[allow(clippy::large_enum_variant)]
pub enum Provenance {
    /// Line-fitting (docs/design.md §3.3).
    LineFit {
        /// Reference frequencies (Hz) whose snapshots were fitted.
        ref_freqs_hz: Vec<f64>,
        /// Least-squares numerics.
        fit: FitReport,
        /// The sampling loop's history when the frequencies were chosen for a tolerance
        /// (docs/design.md §3.5); `None` for explicit frequencies or a ROM read from disk.
        sampling: Option<SamplingReport>,
    },
    /// SEREP (docs/design.md §3.6).
    Serep {
        /// Mode numbers (1-based among all modes, rigid included).
        modes: Vec<usize>,
        /// cond(U_cr).
        cond: f64,
    },
    /// Craig–Bampton (docs/design.md §3.8); the boundary DoFs are [`Rom::dofs`].
    CraigBampton(CraigBamptonReport),
}

/// A reduced second-order model Mr q̈ + Dr q̇ + Kr q = Br u, y = Cr q (docs/design.md §3.4).
#[derive(Clone, Debug)]
pub struct Rom {
    /// How it was built.
    pub provenance: Provenance,
    /// N of the full model it was built from (0 when unknown: a ROM directory that does not
    /// record it).
    pub full_n: usize,
    /// Reduced mass (n×n, symmetric).
    pub mr: Mat<f64>,
    /// Reduced damping (n×n, symmetric).
    pub dr: Mat<f64>,
    /// Reduced stiffness (n×n, symmetric).
    pub kr: Mat<f64>,
    /// Reduced structural damping K₄r = VᵀHV, H = ηK + K₄ (n×n, symmetric), when the body has
    /// structural damping: Hr(iω) = Cr(Kr + iK₄r − ω²Mr + iωDr)⁻¹Br (docs/design.md §3.12).
    pub k4r: Option<Mat<f64>>,
    /// Reduced input matrix Vᵀ P B (n×p).
    pub br: Mat<f64>,
    /// Reduced output matrix C V (q×n).
    pub cr: Mat<f64>,
    /// The full-model DoF of each physical reduced coordinate (interface / retained /
    /// boundary DoFs): the first `dofs.len()` coordinates. Only Craig–Bampton has more
    /// coordinates than DoFs: after the boundary come its modal amplitudes.
    pub dofs: Vec<usize>,
    /// Input DoFs (columns of B).
    pub inputs: Vec<usize>,
    /// Output DoFs (rows of C).
    pub outputs: Vec<usize>,
    /// Definiteness of Mr.
    pub mass_definiteness: Definiteness,
    /// Definiteness of Kr.
    pub stiffness_definiteness: Definiteness,
    /// Wall time per phase.
    pub timings: Vec<Timing>,
    /// Warnings (ill-conditioning, rank truncation, ...).
    pub warnings: Vec<String>,
    /// V (N×n) when requested.
    pub basis: Option<Mat<f64>>,
}

impl Rom {
    /// The ROM of a projection (docs/design.md §3.4) with the scene's inputs and outputs:
    /// the definiteness of Mr and Kr is checked here (a warning for each that is not positive
    /// definite, appended to `warnings`); no timings yet.
    pub fn from_projection(
        provenance: Provenance,
        full_n: usize,
        pr: Projected,
        dofs: Vec<usize>,
        scene: &Scene,
        mut warnings: Vec<String>,
        basis: Option<Mat<f64>>,
    ) -> Rom {
        let (mass_definiteness, stiffness_definiteness) =
            Definiteness::of_projection(&pr, &mut warnings);
        Rom {
            provenance,
            full_n,
            mr: pr.mr,
            dr: pr.dr,
            kr: pr.kr,
            k4r: pr.k4r,
            br: pr.br,
            cr: pr.cr,
            dofs,
            inputs: scene.inputs.clone(),
            outputs: scene.outputs.clone(),
            mass_definiteness,
            stiffness_definiteness,
            timings: Vec::new(),
            warnings,
            basis,
        }
    }

    /// The matrices by their file names: Mr, Dr, Kr, Br, Cr, then K4r when the ROM has
    /// structural damping.
    pub fn matrices(&self) -> Vec<(&'static str, &Mat<f64>)> {
        let mut all = vec![
            ("Mr", &self.mr),
            ("Dr", &self.dr),
            ("Kr", &self.kr),
            ("Br", &self.br),
            ("Cr", &self.cr),
        ];
        if let Some(k4r) = &self.k4r {
            all.push(("K4r", k4r));
        }
        all
    }

    /// Order n.
    pub fn order(&self) -> usize {
        self.mr.nrows()
    }

    /// The method.
    pub fn method(&self) -> Method {
        match self.provenance {
            Provenance::LineFit { .. } => Method::LineFit,
            Provenance::Serep { .. } => Method::Serep,
            Provenance::CraigBampton(_) => Method::CraigBampton,
        }
    }

    /// Reference frequencies (Hz) of a line-fitting ROM (empty otherwise).
    pub fn ref_freqs_hz(&self) -> &[f64] {
        match &self.provenance {
            Provenance::LineFit { ref_freqs_hz, .. } => ref_freqs_hz,
            _ => &[],
        }
    }

    /// Least-squares numerics of a line-fitting ROM.
    pub fn fit(&self) -> Option<&FitReport> {
        match &self.provenance {
            Provenance::LineFit { fit, .. } => Some(fit),
            _ => None,
        }
    }

    /// The sampling loop's history of a tolerance-driven line-fitting ROM.
    pub fn sampling(&self) -> Option<&SamplingReport> {
        match &self.provenance {
            Provenance::LineFit { sampling, .. } => sampling.as_ref(),
            _ => None,
        }
    }

    /// SEREP mode numbers (1-based among all modes; empty for other methods).
    pub fn modes(&self) -> &[usize] {
        match &self.provenance {
            Provenance::Serep { modes, .. } => modes,
            _ => &[],
        }
    }

    /// cond(U_cr) of a SEREP ROM.
    pub fn serep_cond(&self) -> Option<f64> {
        match self.provenance {
            Provenance::Serep { cond, .. } => Some(cond),
            _ => None,
        }
    }

    /// The numerics of a Craig–Bampton ROM.
    pub fn craig_bampton(&self) -> Option<&CraigBamptonReport> {
        match &self.provenance {
            Provenance::CraigBampton(r) => Some(r),
            _ => None,
        }
    }

    /// Checks that this ROM can belong to a model with `n` DoFs: the same N (when recorded)
    /// and every DoF (coordinates, inputs, outputs) and the basis' row count within it.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] saying which size or DoF does not fit.
    pub fn check_model(&self, n: usize) -> Result<()> {
        if self.full_n != 0 && self.full_n != n {
            return Err(Error::InvalidSetting(format!(
                "the ROM was built from a model with N = {} but this model has N = {n}",
                self.full_n
            )));
        }
        if let Some(v) = &self.basis {
            if v.nrows() != n {
                return Err(Error::InvalidSetting(format!(
                    "the ROM's basis V has {} rows but the model has N = {n}",
                    v.nrows()
                )));
            }
        }
        for (what, dofs) in [
            ("coordinate", &self.dofs),
            ("input", &self.inputs),
            ("output", &self.outputs),
        ] {
            if let Some(d) = dofs.iter().find(|&&d| d >= n) {
                return Err(Error::InvalidSetting(format!(
                    "the ROM's {what} DoF {d} is out of range for this model (N = {n}): the ROM does not belong to it"
                )));
            }
        }
        Ok(())
    }

    /// X̃(iω) = (Kr + iK₄r − ω²Mr + iωDr)⁻¹ Br (n × inputs): the reduced state response,
    /// `w` = ω.
    pub fn reduced_response(&self, w: f64) -> Mat<c64> {
        let n = self.order();
        let h = |i, j| self.k4r.as_ref().map_or(0.0, |h: &Mat<f64>| h[(i, j)]);
        let a = Mat::<c64>::from_fn(n, n, |i, j| {
            c64::new(
                self.kr[(i, j)] - w * w * self.mr[(i, j)],
                w * self.dr[(i, j)] + h(i, j),
            )
        });
        let b = Mat::<c64>::from_fn(n, self.br.ncols(), |i, j| c64::new(self.br[(i, j)], 0.0));
        a.partial_piv_lu().solve(&b)
    }

    /// Hr(iω) = Cr X̃(iω) (outputs × inputs).
    pub fn transfer(&self, freq_hz: f64) -> Mat<c64> {
        let x = self.reduced_response(2.0 * std::f64::consts::PI * freq_hz);
        Mat::from_fn(self.cr.nrows(), x.ncols(), |o, j| {
            (0..self.order()).map(|i| x[(i, j)] * self.cr[(o, i)]).sum()
        })
    }
}
