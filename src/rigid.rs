//! The rigid-body part of a free body (docs/design.md §3.2, eq. 15–17), and the rigid-body
//! inertia of a model that the multibody exports write (§3.9).
//!
//! V0 (N×6) holds the rigid modes built from node coordinates r_k, centered at their
//! centroid c for conditioning: translations `I₃` and rotations `−skew(r_k − c)` per node
//! (3 DoFs/node); 6-DoF nodes add [0; I₃] on their rotational DoFs. With M0 = V0ᵀMV0,
//!
//! ```text
//! P  = I − M V0 M0⁻¹ V0ᵀ        (P B has no rigid load: inertia relief)
//! Pᵀ = I − V0 M0⁻¹ V0ᵀ M        (removes the rigid part of a response)
//! X(s) = Pᵀ A(s)⁻¹ P B          (the elastic response, no cancellation as s → 0)
//! H0(s) = C V0 (s²M0 + sD0 + K0)⁻¹ V0ᵀ B          (eq. 16)
//! ```
//!
//! K0 = V0ᵀKV0 is 0 for a free body; its computed value is rounding noise of size eps·‖K‖
//! that would swamp ω²M0 at low frequency, so it is taken as exactly 0 (and D0 = αM0 for
//! Rayleigh damping).
//!
//! For K V0 = 0 and D V0 ∈ span(M V0) (e.g. Rayleigh damping) A(s) is block diagonal in the
//! M-orthogonal split rigid ⊕ elastic, so H = H0 + C X exactly; X is computed without forming
//! H − H0, which loses all digits at low frequency (H and H0 grow like 1/s²).
//!
//! The inertia ([`inertia`]: total mass, centre of mass, inertia tensor about it) is read off
//! the 6 × 6 rigid-body mass matrix RᵀMR with R the rigid modes about the origin (not V0:
//! those are centred at the centroid), which needs neither K nor a free body.
//!
//! Entry points: [`RigidBody::from_nodes`], [`RigidBody::detect`]; [`inertia`].

use crate::dense::sym;
use crate::model::Model;
use crate::pencil::{Coefficient, Pencil};
use crate::{Error, Result};
use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{c64, Mat, MatMut, MatRef};

/// ‖K V0‖_F ≤ this · ‖K‖_F ‖V0‖_F means the body is free (the node rigid modes are in ker K).
pub const FREE_BODY_RTOL: f64 = 1e-8;

/// Rigid modes and the projections built from them.
#[derive(Clone, Debug)]
pub struct RigidBody {
    v0: Mat<f64>,
    mv0: Mat<f64>,
    m0: Mat<f64>,
    m0_inv: Mat<f64>,
    d0: Mat<f64>,
    /// ‖K V0‖_F / (‖K‖_F ‖V0‖_F): how rigid the modes are for this K.
    pub stiffness_residual: f64,
}

/// Rigid modes (N×6: tx, ty, tz, rx, ry, rz) from node coordinates, centered at the centroid.
pub fn rigid_modes(nodes: &[[f64; 3]], dofs_per_node: usize) -> Mat<f64> {
    rigid_modes_about(nodes, dofs_per_node, centroid(nodes))
}

/// The centroid of `nodes` (the origin for none).
pub fn centroid(nodes: &[[f64; 3]]) -> [f64; 3] {
    let nn = nodes.len().max(1) as f64;
    let mut c = [0.0; 3];
    for p in nodes {
        for a in 0..3 {
            c[a] += p[a] / nn;
        }
    }
    c
}

/// Rigid modes (N×6) of points with `dofs_per_node` DoFs each, rotations about `centre`:
/// translations `I₃`, rotations `−skew(r − centre)`, and [0; I₃] on rotational DoFs.
pub fn rigid_modes_about(nodes: &[[f64; 3]], dofs_per_node: usize, centre: [f64; 3]) -> Mat<f64> {
    let c = centre;
    let mut v0 = Mat::<f64>::zeros(nodes.len() * dofs_per_node, 6);
    for (k, p) in nodes.iter().enumerate() {
        let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        let b = k * dofs_per_node;
        for a in 0..3 {
            v0[(b + a, a)] = 1.0;
        }
        // rotation about axis a: e_a × r
        v0[(b + 1, 3)] = -r[2];
        v0[(b + 2, 3)] = r[1];
        v0[(b, 4)] = r[2];
        v0[(b + 2, 4)] = -r[0];
        v0[(b, 5)] = -r[1];
        v0[(b + 1, 5)] = r[0];
        if dofs_per_node == 6 {
            for a in 0..3 {
                v0[(b + 3 + a, 3 + a)] = 1.0;
            }
        }
    }
    v0
}

/// ‖K V0‖_F / (‖K‖_F ‖V0‖_F): 0 for a free body (docs/design.md §3.2).
fn stiffness_residual(pencil: &Pencil, v0: &Mat<f64>) -> f64 {
    let kv0 = pencil.mul(Coefficient::Stiffness, v0.as_ref());
    kv0.norm_l2() / (pencil.norm_fro(Coefficient::Stiffness) * v0.norm_l2()).max(f64::MIN_POSITIVE)
}

impl RigidBody {
    /// Builds V0 from the model's `nodes` and the projections for the matrices of `pencil`;
    /// `None` when K V0 ≠ 0 (a constrained body: nothing to separate).
    ///
    /// # Errors
    /// [`Error::InvalidModel`] when M0 = V0ᵀMV0 is not positive definite.
    ///
    /// K V0 is tested first: a constrained body needs no M0, which is singular when the nodes
    /// are one point or lie on a line (a constrained single node, a chain of node pairs:
    /// `tests/it/extremes.rs`).
    pub fn detect(
        pencil: &Pencil,
        nodes: &[[f64; 3]],
        dofs_per_node: usize,
    ) -> Result<Option<Self>> {
        Self::detect_modes(pencil, rigid_modes(nodes, dofs_per_node))
    }

    /// [`Self::detect`] for given rigid modes `v0` (N×6), for a model whose DoFs are not all
    /// node DoFs (a coupled model, docs/design.md §3.11).
    ///
    /// # Errors
    /// As [`Self::detect`].
    pub fn detect_modes(pencil: &Pencil, v0: Mat<f64>) -> Result<Option<Self>> {
        let residual = stiffness_residual(pencil, &v0);
        if residual > FREE_BODY_RTOL {
            return Ok(None);
        }
        Self::with_modes(pencil, v0, residual).map(Some)
    }

    /// Builds V0 from `nodes` for the matrices of `pencil` (does not check K V0 = 0; see
    /// [`Self::detect`]).
    ///
    /// # Errors
    /// [`Error::InvalidModel`] when M0 = V0ᵀMV0 is not positive definite.
    pub fn from_nodes(pencil: &Pencil, nodes: &[[f64; 3]], dofs_per_node: usize) -> Result<Self> {
        Self::from_modes(pencil, rigid_modes(nodes, dofs_per_node))
    }

    /// [`Self::from_nodes`] for given rigid modes `v0` (N×6).
    ///
    /// # Errors
    /// As [`Self::from_nodes`].
    pub fn from_modes(pencil: &Pencil, v0: Mat<f64>) -> Result<Self> {
        let residual = stiffness_residual(pencil, &v0);
        Self::with_modes(pencil, v0, residual)
    }

    /// The projections for rigid modes `v0` whose relative K V0 is `stiffness_residual`.
    fn with_modes(pencil: &Pencil, v0: Mat<f64>, stiffness_residual: f64) -> Result<Self> {
        let mv0 = pencil.mul(Coefficient::Mass, v0.as_ref());
        let m0 = sym((v0.transpose() * &mv0).as_ref());
        // K V0 = 0 on a free body, so the stiffness part of Rayleigh damping drops out
        let d0 = pencil.damping_term(&m0, &Mat::zeros(6, 6), |d| {
            sym((v0.transpose() * d(v0.as_ref())).as_ref())
        });
        let llt = m0.llt(faer::Side::Lower).map_err(|_| {
            Error::InvalidModel(
                "rigid modes: V0ᵀ M V0 is not positive definite (are the node coordinates right?)"
                    .into(),
            )
        })?;
        let m0_inv = llt.inverse();
        Ok(RigidBody {
            v0,
            mv0,
            m0,
            m0_inv,
            d0,
            stiffness_residual,
        })
    }

    /// Six DoFs on which the rigid modes are independent — a statically determinate support
    /// of the free body — chosen as the first six pivots of a column-pivoted QR of V0ᵀ (6×N),
    /// so V0 restricted to those rows is as well conditioned as the nodes allow; sorted.
    pub fn supports(&self) -> Vec<usize> {
        let qr = self.v0.transpose().to_owned().col_piv_qr();
        let (fwd, _) = qr.P().arrays();
        let mut s: Vec<usize> = fwd.iter().copied().take(6).collect();
        s.sort_unstable();
        s
    }

    /// The rigid modes V0 (N×6).
    pub fn modes(&self) -> MatRef<'_, f64> {
        self.v0.as_ref()
    }

    /// M0 = V0ᵀ M V0 (6×6).
    pub fn mass(&self) -> MatRef<'_, f64> {
        self.m0.as_ref()
    }

    /// x ← P x = x − M V0 M0⁻¹ V0ᵀ x (removes the rigid load component; loads are real).
    pub fn project_load(&self, x: MatMut<'_, f64>) {
        apply_projector(self.mv0.as_ref(), &self.m0_inv, self.v0.as_ref(), x);
    }

    /// x ← Pᵀ x = x − V0 M0⁻¹ (M V0)ᵀ x (removes the rigid part of a response).
    pub fn project_response(&self, x: MatMut<'_, c64>) {
        apply_projector(self.v0.as_ref(), &self.m0_inv, self.mv0.as_ref(), x);
    }

    /// x ← Pᵀ x for real columns (as [`Self::project_response`]), by three small products:
    /// x − V0 (M0⁻¹ ((M V0)ᵀ x)).
    pub fn project_response_real(&self, mut x: MatMut<'_, f64>) {
        let t = &self.m0_inv * (self.mv0.transpose() * x.as_ref());
        x -= &self.v0 * t;
    }

    /// H0(iω) = C V0 (−ω²M0 + iωD0)⁻¹ V0ᵀ B for B, C selecting `inputs`, `outputs`
    /// (eq. 16 with K0 = 0). Infinite at ω = 0.
    pub fn h0(&self, omega: f64, inputs: &[usize], outputs: &[usize]) -> Mat<c64> {
        let a = Mat::<c64>::from_fn(6, 6, |i, j| {
            c64::new(-omega * omega * self.m0[(i, j)], omega * self.d0[(i, j)])
        });
        let b0 = Mat::<c64>::from_fn(6, inputs.len(), |i, j| {
            c64::new(self.v0[(inputs[j], i)], 0.0)
        });
        let x = a.partial_piv_lu().solve(&b0);
        Mat::<c64>::from_fn(outputs.len(), inputs.len(), |o, j| {
            (0..6).map(|i| x[(i, j)] * self.v0[(outputs[o], i)]).sum()
        })
    }
}

/// x ← x − U G Wᵀ x for N×6 U, W and 6×6 G; x real or complex (the same operations on the
/// real part either way).
fn apply_projector<T>(u: MatRef<'_, f64>, g: &Mat<f64>, w: MatRef<'_, f64>, mut x: MatMut<'_, T>)
where
    T: Copy + Default + std::ops::AddAssign + std::ops::SubAssign + std::ops::Mul<f64, Output = T>,
{
    let (n, k) = (x.nrows(), x.ncols());
    for c in 0..k {
        let mut t = [T::default(); 6];
        for (a, ta) in t.iter_mut().enumerate() {
            for i in 0..n {
                *ta += x[(i, c)] * w[(i, a)];
            }
        }
        let mut s = [T::default(); 6];
        for (a, sa) in s.iter_mut().enumerate() {
            for (b, tb) in t.iter().enumerate() {
                *sa += *tb * g[(a, b)];
            }
        }
        for i in 0..n {
            let mut acc = T::default();
            for (a, sa) in s.iter().enumerate() {
                acc += *sa * u[(i, a)];
            }
            x[(i, c)] -= acc;
        }
    }
}

/// The rigid-body inertia of a model ([`inertia`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inertia {
    /// Total mass.
    pub mass: f64,
    /// Centre of mass.
    pub center: [f64; 3],
    /// Inertia tensor about the centre of mass (positive off-diagonal products as
    /// ∫ρ(|r|²δ − r rᵀ), the matrix MBDyn uses).
    pub inertia: [[f64; 3]; 3],
    /// The 6 × 6 rigid-body mass matrix Rᵀ M R about the origin (translations x, y, z, then
    /// rotations about x, y, z).
    pub mrb: [[f64; 6]; 6],
}

/// Row `i` of the rigid modes R about the origin for DoF direction `a` (0–2 translations,
/// 3–5 rotations) of a node at `p`.
fn rigid_row(a: usize, p: [f64; 3]) -> [f64; 6] {
    let mut r = [0.0; 6];
    if a < 3 {
        r[a] = 1.0;
        // rotation about e_q moves p by e_q × p; its component a
        for q in 0..3 {
            let (b, c) = ((q + 1) % 3, (q + 2) % 3);
            r[3 + q] = if a == b {
                -p[c]
            } else if a == c {
                p[b]
            } else {
                0.0
            };
        }
    } else {
        r[a] = 1.0;
    }
    r
}

/// The model's rigid-body inertia from M and the node coordinates, in one pass over M's
/// entries (Mrb = Rᵀ(MR) with R the N × 6 rigid modes about the origin: O(nnz), never a dense
/// N × N product): mass = the mean of Mrb's three translational diagonal entries; the first
/// moments m·c from the antisymmetric translation–rotation block; the inertia about the
/// origin from the rotational block, moved to the centre of mass.
///
/// # Errors
/// [`Error::InvalidSetting`] when the model has no node coordinates, a DoF count that is not
/// nodes × dofs_per_node, or a total mass that is not positive.
pub fn inertia(model: &Model) -> Result<Inertia> {
    let nodes = model.nodes.as_ref().ok_or_else(|| {
        Error::InvalidSetting(format!(
            "model '{}' has no node coordinates (nodes.csv): rigid-body inertia needs them",
            model.name
        ))
    })?;
    let dpn = model.dofs_per_node;
    let n = model.n();
    if !(dpn == 3 || dpn == 6) || nodes.len() * dpn != n {
        return Err(Error::InvalidSetting(format!(
            "model '{}': {} nodes × {dpn} DoFs per node is not N = {n}",
            model.name,
            nodes.len()
        )));
    }
    let row = |i: usize| rigid_row(i % dpn, nodes[i / dpn]);
    let m = &model.mass;
    let mut mrb = [[0.0; 6]; 6];
    // Σ_ij R_ia M_ij R_jb, column by column of M (full storage)
    for j in 0..m.ncols() {
        let rj = row(j);
        let mut mr = [0.0; 6];
        for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
            let ri = row(i);
            for a in 0..6 {
                mr[a] += ri[a] * v;
            }
        }
        for a in 0..6 {
            for b in 0..6 {
                mrb[a][b] += mr[a] * rj[b];
            }
        }
    }
    let mass = (mrb[0][0] + mrb[1][1] + mrb[2][2]) / 3.0;
    if !(mass > 0.0 && mass.is_finite()) {
        return Err(Error::InvalidSetting(format!(
            "model '{}': the mass matrix gives a total mass of {mass:e}",
            model.name
        )));
    }
    // Mrb[0..3][3..6] = −skew(m c)
    let c = |a: usize, b: usize| mrb[a][3 + b];
    let s = [
        (c(1, 2) - c(2, 1)) / 2.0,
        (c(2, 0) - c(0, 2)) / 2.0,
        (c(0, 1) - c(1, 0)) / 2.0,
    ];
    let center = s.map(|x| x / mass);
    let r2: f64 = center.iter().map(|x| x * x).sum();
    let mut tensor = [[0.0; 3]; 3];
    for a in 0..3 {
        for b in 0..3 {
            let parallel = mass * (if a == b { r2 } else { 0.0 } - center[a] * center[b]);
            tensor[a][b] = (mrb[3 + a][3 + b] + mrb[3 + b][3 + a]) / 2.0 - parallel;
        }
    }
    Ok(Inertia {
        mass,
        center,
        inertia: tensor,
        mrb,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rigid_modes_columns() {
        let nodes = [[1.0, 2.0, 3.0], [3.0, 2.0, 3.0]];
        let v = rigid_modes(&nodes, 3);
        assert_eq!((v.nrows(), v.ncols()), (6, 6));
        // Centroid (2,2,3): node 0 at p = (-1,0,0). Rotation about z moves it by
        // e_z × p = (0,-1,0).
        assert_eq!([v[(0, 5)], v[(1, 5)], v[(2, 5)]], [0.0, -1.0, 0.0]);
        // Rotation about y: e_y × p = (0,0,1).
        assert_eq!([v[(0, 4)], v[(1, 4)], v[(2, 4)]], [0.0, 0.0, 1.0]);
        assert_eq!(rigid_modes(&[], 3).nrows(), 0);
    }
}
