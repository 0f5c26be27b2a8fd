//! The full-order model M q'' + D q' + K q = B u, y = C q (docs/design.md §1, eq. 3), with its
//! validation.
//!
//! M and K are stored in full (both triangles) CSC; B and C are selections of DoFs given by
//! a [`crate::scene::Scene`], which is not part of the model: every computation takes it as an
//! argument. Entry point: [`Model::new`], which validates everything once so that later
//! stages can rely on shapes, symmetry and finiteness.

use crate::sparse::{asymmetry, Csc};
use crate::{Error, Result};

/// Relative tolerance of the symmetry check: max|a_ij − a_ji| ≤ tol · max|a_ij|.
pub const SYMMETRY_RTOL: f64 = 1e-10;

/// Damping model.
#[derive(Clone, Debug)]
pub enum Damping {
    /// D = 0: the pencil is real (docs/design.md §3.1, real path).
    None,
    /// D = α M + β K.
    Rayleigh {
        /// Mass-proportional coefficient α (1/s).
        alpha: f64,
        /// Stiffness-proportional coefficient β (s).
        beta: f64,
    },
    /// An explicit symmetric damping matrix (full storage).
    Matrix(Csc),
}

/// Structural (hysteretic) damping H = ηK + K₄: A(iω) = K + iH − ω²M + iωD
/// (docs/design.md §3.1). Defined in the frequency domain only: a loss factor η on K (Nastran's
/// G, ANSYS's DMPSTR, Abaqus's structural damping) and an element-wise structural damping matrix
/// K₄ (Nastran's K4), or both. [`Structural::default`] is none.
#[derive(Clone, Debug, Default)]
pub struct Structural {
    /// Uniform loss factor η ≥ 0 on K.
    pub eta: f64,
    /// Structural damping matrix K₄ (symmetric, full storage), if any.
    pub matrix: Option<Csc>,
}

impl Structural {
    /// True when H = 0.
    pub fn is_zero(&self) -> bool {
        self.eta == 0.0 && self.matrix.is_none()
    }
}

impl Damping {
    /// True when D = 0 (no damping matrix, or Rayleigh with α = β = 0).
    pub fn is_zero(&self) -> bool {
        matches!(
            self,
            Damping::None
                | Damping::Rayleigh {
                    alpha: 0.0,
                    beta: 0.0
                }
        )
    }
}

/// A validated second-order FE model.
#[derive(Clone, Debug)]
pub struct Model {
    /// Name (from `model.toml` or the generator).
    pub name: String,
    /// Mass matrix M (symmetric positive definite, full storage).
    pub mass: Csc,
    /// Stiffness matrix K (symmetric positive semi-definite, full storage).
    pub stiffness: Csc,
    /// Damping D.
    pub damping: Damping,
    /// Node coordinates; node i owns DoFs dofs_per_node·i .. dofs_per_node·(i+1).
    pub nodes: Option<Vec<[f64; 3]>>,
    /// 3 (translations) or 6 (translations + rotations).
    pub dofs_per_node: usize,
    /// Rigid-body modes V0 (N×6) given explicitly, for a model whose DoFs are not all node
    /// DoFs (a coupled model, docs/design.md §3.11); they win over `nodes` when the body's
    /// rigid part is detected (§3.2). `None` from [`Model::new`].
    pub rigid_modes: Option<faer::Mat<f64>>,
    /// Structural damping H = ηK + K₄ (none from [`Model::new`]; [`Model::with_structural`]).
    pub structural: Structural,
    /// A coupled model's coupling, through which its products and real factorizations are
    /// cheaper than with its formed matrices (docs/design.md §3.11; set by
    /// [`crate::coupled::couple`] when it pays, none from [`Model::new`]). The pencil checks
    /// it against the formed matrices and ignores it when they differ.
    pub coupling: Option<std::sync::Arc<Coupling>>,
}

/// A coupled model M' = TᵀM₁T (and K', D', H' alike) as the model before its functionals
/// became coordinates and the change of variables (docs/design.md §3.11).
#[derive(Clone, Debug)]
pub struct Coupling {
    /// The model A₁ (M₁, K₁ and the damping whose congruence is the coupled model's; the
    /// rigid points already eliminated).
    pub first: Model,
    /// T (N × N): a state of the coupled model as one of `first`.
    pub t: Csc,
    /// S = T⁻¹: the identity with each functional's pivot row replaced by the functional.
    pub s: Csc,
}

/// What [`Model::new`] measured while validating: returned to the user (`sparsemor info`).
#[derive(Clone, Debug)]
pub struct ValidationReport {
    /// max|M − Mᵀ| / max|M|.
    pub mass_asymmetry: f64,
    /// max|K − Kᵀ| / max|K|.
    pub stiffness_asymmetry: f64,
    /// min and max of diag(M).
    pub mass_diagonal: [f64; 2],
}

impl Model {
    /// Validates and builds a model.
    ///
    /// Checks: M, K (and D) square of the same size N ≥ 1, all values finite, symmetric within
    /// [`SYMMETRY_RTOL`], diag(M) > 0, Rayleigh coefficients finite and ≥ 0, nodes consistent
    /// with N and `dofs_per_node` ∈ {3, 6}.
    ///
    /// # Errors
    /// [`Error::InvalidModel`] or [`Error::InvalidSetting`] naming the field and the fix.
    pub fn new(
        name: String,
        mass: Csc,
        stiffness: Csc,
        damping: Damping,
        nodes: Option<Vec<[f64; 3]>>,
        dofs_per_node: usize,
    ) -> Result<(Self, ValidationReport)> {
        let n = mass.nrows();
        let mass_asymmetry = check_matrix(&mass, n, "mass matrix M")?;
        let stiffness_asymmetry = check_matrix(&stiffness, n, "stiffness matrix K")?;
        match &damping {
            Damping::None => {}
            Damping::Rayleigh { alpha, beta } => {
                if !(alpha.is_finite() && beta.is_finite() && *alpha >= 0.0 && *beta >= 0.0) {
                    return Err(Error::InvalidModel(format!(
                        "rayleigh alpha = {alpha}, beta = {beta}: need finite values >= 0"
                    )));
                }
            }
            Damping::Matrix(d) => {
                check_matrix(d, n, "damping matrix D")?;
            }
        }
        let mut diag = [f64::INFINITY, f64::NEG_INFINITY];
        for j in 0..n {
            let rows = mass.symbolic().row_idx_of_col_raw(j);
            let d = rows
                .iter()
                .position(|&i| i == j)
                .map(|p| mass.val_of_col(j)[p])
                .unwrap_or(0.0);
            if d <= 0.0 {
                return Err(Error::InvalidModel(format!(
                    "mass matrix M: diagonal entry of DoF {j} is {d}; a mass matrix needs a positive diagonal \
                     (is a DoF without mass, or were M and K swapped?)"
                )));
            }
            diag = [diag[0].min(d), diag[1].max(d)];
        }
        if dofs_per_node != 3 && dofs_per_node != 6 {
            return Err(Error::InvalidModel(format!(
                "dofs_per_node = {dofs_per_node}: supported are 3 (translations) and 6 (translations + rotations)"
            )));
        }
        if let Some(nodes) = &nodes {
            if nodes.len() * dofs_per_node != n {
                return Err(Error::InvalidModel(format!(
                    "nodes: {} nodes × {dofs_per_node} DoFs per node = {} but the matrices have N = {n}",
                    nodes.len(),
                    nodes.len() * dofs_per_node
                )));
            }
            if let Some(i) = nodes.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
                return Err(Error::InvalidModel(format!(
                    "nodes: node {i} has a non-finite coordinate"
                )));
            }
        }
        let model = Model {
            name,
            mass,
            stiffness,
            damping,
            nodes,
            dofs_per_node,
            rigid_modes: None,
            structural: Structural::default(),
            coupling: None,
        };
        Ok((
            model,
            ValidationReport {
                mass_asymmetry,
                stiffness_asymmetry,
                mass_diagonal: diag,
            },
        ))
    }

    /// The model with explicit rigid-body modes `v0` (N×6, finite; see
    /// [`Model::rigid_modes`]).
    ///
    /// # Errors
    /// [`Error::InvalidModel`] for a wrong shape or a non-finite entry.
    pub fn with_rigid_modes(mut self, v0: faer::Mat<f64>) -> Result<Self> {
        if v0.nrows() != self.n() || v0.ncols() != 6 {
            return Err(Error::InvalidModel(format!(
                "rigid modes: {}×{} given for a model of N = {}; need N×6",
                v0.nrows(),
                v0.ncols(),
                self.n()
            )));
        }
        if (0..6).any(|j| v0.col(j).iter().any(|v| !v.is_finite())) {
            return Err(Error::InvalidModel(
                "rigid modes: a non-finite entry".into(),
            ));
        }
        self.rigid_modes = Some(v0);
        Ok(self)
    }

    /// The model with structural damping `structural` (docs/design.md §3.1).
    ///
    /// # Errors
    /// [`Error::InvalidModel`] for η negative or not finite, or a K₄ of another size than M,
    /// unsymmetric or not finite.
    pub fn with_structural(mut self, structural: Structural) -> Result<Self> {
        let eta = structural.eta;
        if !(eta.is_finite() && eta >= 0.0) {
            return Err(Error::InvalidModel(format!(
                "structural damping eta = {eta}: need a finite loss factor >= 0 (e.g. 0.02)"
            )));
        }
        if let Some(k4) = &structural.matrix {
            check_matrix(k4, self.n(), "structural damping matrix K4")?;
        }
        self.structural = structural;
        Ok(self)
    }

    /// Number of DoFs N.
    pub fn n(&self) -> usize {
        self.mass.nrows()
    }

    /// Stored entries of M, K (and D).
    pub fn nnz(&self) -> usize {
        let d = match &self.damping {
            Damping::Matrix(d) => d.compute_nnz(),
            _ => 0,
        };
        let k4 = self
            .structural
            .matrix
            .as_ref()
            .map_or(0, |m| m.compute_nnz());
        self.mass.compute_nnz() + self.stiffness.compute_nnz() + d + k4
    }
}

/// Square N×N, finite, symmetric within [`SYMMETRY_RTOL`]; returns the relative asymmetry.
fn check_matrix(a: &Csc, n: usize, what: &str) -> Result<f64> {
    if n == 0 {
        return Err(Error::InvalidModel(format!("{what} is empty (N = 0)")));
    }
    if a.nrows() != a.ncols() {
        return Err(Error::InvalidModel(format!(
            "{what} is {}×{}, not square: M, K and D must be N×N",
            a.nrows(),
            a.ncols()
        )));
    }
    if a.nrows() != n {
        return Err(Error::InvalidModel(format!(
            "{what} is {}×{} but the model has N = {n} (the mass matrix sets N): all matrices must be N×N",
            a.nrows(),
            a.ncols()
        )));
    }
    if let Some(p) = a.val().iter().position(|v| !v.is_finite()) {
        let col = a.symbolic().col_ptr().partition_point(|&c| c <= p) - 1;
        return Err(Error::InvalidModel(format!(
            "{what} has a non-finite value ({}) in column {col}",
            a.val()[p]
        )));
    }
    let (diff, max) = asymmetry(a.as_ref());
    let rel = if max > 0.0 { diff / max } else { 0.0 };
    if rel > SYMMETRY_RTOL {
        return Err(Error::InvalidModel(format!(
            "{what} is not symmetric: max|a_ij - a_ji| / max|a_ij| = {rel:.3e} > {SYMMETRY_RTOL:.0e}; \
             sparsemor needs symmetric M, K, D (store both triangles or use a `symmetric` Matrix Market file)"
        )));
    }
    Ok(rel)
}
