//! Reduced models: the [`Rom`] type, the shared Galerkin projection (DESIGN.md §3.4) and
//! the methods that build V: [`linefit`] (§3.3) and, later, SEREP (§3.6).

pub mod linefit;
pub mod serep;

use crate::model::{Damping, Model};
use crate::rigid::RigidBody;
use crate::sparse::mul_dense;
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

/// A reduced second-order model Mr q̈ + Dr q̇ + Kr q = Br u, y = Cr q (DESIGN.md §3.4).
#[derive(Clone, Debug)]
pub struct Rom {
    /// How it was built.
    pub method: Method,
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
    /// Reference frequencies (Hz) of a line-fitting ROM.
    pub ref_freqs_hz: Vec<f64>,
    /// SEREP mode numbers (1-based among all modes, rigid included).
    pub modes: Vec<usize>,
    /// Least-squares numerics (line-fitting).
    pub fit: Option<FitReport>,
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
    /// cond(U_cr) of a SEREP ROM.
    pub serep_cond: Option<f64>,
}

impl Rom {
    /// Order n.
    pub fn order(&self) -> usize {
        self.mr.nrows()
    }

    /// Hr(iω) = Cr (Kr − ω²Mr + iωDr)⁻¹ Br (outputs × inputs).
    pub fn transfer(&self, freq_hz: f64) -> Mat<c64> {
        let w = 2.0 * std::f64::consts::PI * freq_hz;
        let n = self.order();
        let a = Mat::<c64>::from_fn(n, n, |i, j| {
            c64::new(
                self.kr[(i, j)] - w * w * self.mr[(i, j)],
                w * self.dr[(i, j)],
            )
        });
        let b = Mat::<c64>::from_fn(n, self.br.ncols(), |i, j| c64::new(self.br[(i, j)], 0.0));
        let x = a.partial_piv_lu().solve(&b);
        Mat::from_fn(self.cr.nrows(), b.ncols(), |o, j| {
            (0..n).map(|i| x[(i, j)] * self.cr[(o, i)]).sum()
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

/// Projects `model` onto V (N×n) for unit loads at `inputs` and outputs `outputs`.
pub fn project(
    model: &Model,
    v: MatRef<'_, f64>,
    inputs: &[usize],
    outputs: &[usize],
    rigid: Option<&RigidBody>,
) -> Projected {
    let sym =
        |a: Mat<f64>| Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let mr = sym(v.transpose() * mul_dense(model.mass.as_ref(), v));
    let kr = sym(v.transpose() * mul_dense(model.stiffness.as_ref(), v));
    let dr = match &model.damping {
        Damping::None => Mat::zeros(mr.nrows(), mr.ncols()),
        Damping::Rayleigh { alpha, beta } => Mat::from_fn(mr.nrows(), mr.ncols(), |i, j| {
            alpha * mr[(i, j)] + beta * kr[(i, j)]
        }),
        Damping::Matrix(d) => sym(v.transpose() * mul_dense(d.as_ref(), v)),
    };
    let mut pb = Mat::<c64>::zeros(v.nrows(), inputs.len());
    for (j, &d) in inputs.iter().enumerate() {
        pb[(d, j)] = c64::new(1.0, 0.0);
    }
    if let Some(rb) = rigid {
        rb.project_load(pb.as_mut());
    }
    let pb_re = Mat::from_fn(pb.nrows(), pb.ncols(), |i, j| pb[(i, j)].re);
    let br = v.transpose() * pb_re;
    let cr = Mat::from_fn(outputs.len(), v.ncols(), |o, j| v[(outputs[o], j)]);
    Projected { mr, dr, kr, br, cr }
}
