//! Reduced models: the [`Rom`] type with its [`Provenance`], the shared Galerkin projection
//! (DESIGN.md §3.4) and the methods that build V: [`linefit`] (§3.3, §3.5) and [`serep`]
//! (§3.6). Every reductor takes a prepared [`Body`] and a [`Scene`] and ends in [`project`].

pub mod linefit;
pub mod serep;

use crate::body::Body;
use crate::model::Model;
use crate::scene::Scene;
use crate::sparse::mul_dense;
use crate::{Error, Result};
use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef};

/// How a ROM was built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Line-fitting (DESIGN.md §3.3).
    LineFit,
    /// SEREP (DESIGN.md §3.6).
    Serep,
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Method::LineFit => "linefit",
            Method::Serep => "serep",
        })
    }
}

/// Definiteness check of a small symmetric matrix (Cholesky + extreme eigenvalues).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Definiteness {
    /// Cholesky succeeded.
    pub positive_definite: bool,
    /// Smallest eigenvalue.
    pub min_eig: f64,
    /// Largest eigenvalue.
    pub max_eig: f64,
}

impl Definiteness {
    /// Checks Mr and Kr of a projection; a warning per matrix that is not positive definite
    /// is appended to `warnings`.
    pub fn of_projection(pr: &Projected, warnings: &mut Vec<String>) -> (Self, Self) {
        let (m, k) = (Self::of(pr.mr.as_ref()), Self::of(pr.kr.as_ref()));
        for (name, d) in [("Mr", &m), ("Kr", &k)] {
            if !d.positive_definite {
                warnings.push(format!(
                    "{name} is not positive definite (eigenvalues in [{:.3e}, {:.3e}])",
                    d.min_eig, d.max_eig
                ));
            }
        }
        (m, k)
    }

    /// Checks a symmetric matrix.
    pub fn of(a: MatRef<'_, f64>) -> Self {
        let positive_definite = a.llt(faer::Side::Lower).is_ok();
        let (min_eig, max_eig) = match a.self_adjoint_eigenvalues(faer::Side::Lower) {
            Ok(ev) if !ev.is_empty() => (ev[0], ev[ev.len() - 1]),
            _ => (f64::NAN, f64::NAN),
        };
        Definiteness {
            positive_definite,
            min_eig,
            max_eig,
        }
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
    /// Rows of T_oᵀ (2pz).
    pub rows: usize,
}

/// Where a ROM came from: the method and what it was built from.
#[derive(Clone, Debug)]
pub enum Provenance {
    /// Line-fitting (DESIGN.md §3.3).
    LineFit {
        /// Reference frequencies (Hz) whose snapshots were fitted.
        ref_freqs_hz: Vec<f64>,
        /// Least-squares numerics.
        fit: FitReport,
        /// The sampling loop's history when the frequencies were chosen for a tolerance
        /// (DESIGN.md §3.5); `None` for explicit frequencies or a ROM read from disk.
        sampling: Option<linefit::SamplingReport>,
    },
    /// SEREP (DESIGN.md §3.6).
    Serep {
        /// Mode numbers (1-based among all modes, rigid included).
        modes: Vec<usize>,
        /// cond(U_cr).
        cond: f64,
    },
}

/// A reduced second-order model Mr q̈ + Dr q̇ + Kr q = Br u, y = Cr q (DESIGN.md §3.4).
#[derive(Clone, Debug)]
pub struct Rom {
    /// How it was built.
    pub provenance: Provenance,
    /// N of the full model it was built from (0 when unknown: a ROM directory written before
    /// this was recorded).
    pub full_n: usize,
    /// Reduced mass (n×n, symmetric).
    pub mr: Mat<f64>,
    /// Reduced damping (n×n, symmetric).
    pub dr: Mat<f64>,
    /// Reduced stiffness (n×n, symmetric).
    pub kr: Mat<f64>,
    /// Reduced input matrix Vᵀ P B (n×p).
    pub br: Mat<f64>,
    /// Reduced output matrix C V (q×n).
    pub cr: Mat<f64>,
    /// The full-model DoF of each reduced coordinate (interface / retained DoFs).
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
    /// Order n.
    pub fn order(&self) -> usize {
        self.mr.nrows()
    }

    /// The method.
    pub fn method(&self) -> Method {
        match self.provenance {
            Provenance::LineFit { .. } => Method::LineFit,
            Provenance::Serep { .. } => Method::Serep,
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
    pub fn sampling(&self) -> Option<&linefit::SamplingReport> {
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

    /// Checks that this ROM can belong to `model`: the same N (when recorded) and every DoF
    /// (coordinates, inputs, outputs) and the basis' row count within it.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] saying which size or DoF does not fit.
    pub fn check_model(&self, model: &Model) -> Result<()> {
        let n = model.n();
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

    /// X̃(iω) = (Kr − ω²Mr + iωDr)⁻¹ Br (n × inputs): the reduced state response, `w` = ω.
    pub fn reduced_response(&self, w: f64) -> Mat<c64> {
        let n = self.order();
        let a = Mat::<c64>::from_fn(n, n, |i, j| {
            c64::new(self.kr[(i, j)] - w * w * self.mr[(i, j)], w * self.dr[(i, j)])
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

/// The Galerkin projection of DESIGN.md §3.4: Mr = VᵀMV, Kr = VᵀKV, Dr = VᵀDV (all
/// symmetrized), Br = Vᵀ P B (P: inertia relief on a free body, identity otherwise),
/// Cr = C V. Cost O(nnz·n + N·n²); MV is formed once as a sparse × dense product.
pub struct Projected {
    /// Vᵀ M V.
    pub mr: Mat<f64>,
    /// Vᵀ D V.
    pub dr: Mat<f64>,
    /// Vᵀ K V.
    pub kr: Mat<f64>,
    /// Vᵀ P B.
    pub br: Mat<f64>,
    /// C V.
    pub cr: Mat<f64>,
}

/// Projects the body onto V (N×n) for the scene's unit loads and outputs.
pub fn project(body: &Body<'_>, scene: &Scene, v: MatRef<'_, f64>) -> Projected {
    let model = body.model();
    let sym =
        |a: Mat<f64>| Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let mr = sym(v.transpose() * mul_dense(model.mass.as_ref(), v));
    let kr = sym(v.transpose() * mul_dense(model.stiffness.as_ref(), v));
    let dr = model.damping.combine(&mr, &kr, |d| {
        sym(v.transpose() * mul_dense(d.as_ref(), v))
    });
    let pb = body.elastic_load(&scene.inputs);
    let pb_re = Mat::from_fn(pb.nrows(), pb.ncols(), |i, j| pb[(i, j)].re);
    let br = v.transpose() * pb_re;
    let outputs = &scene.outputs;
    let cr = Mat::from_fn(outputs.len(), v.ncols(), |o, j| v[(outputs[o], j)]);
    Projected { mr, dr, kr, br, cr }
}
