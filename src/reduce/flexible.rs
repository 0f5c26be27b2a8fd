//! A ROM as a flexible body for a floating-frame multibody code (docs/design.md §3.9).
//!
//! A floating-frame-of-reference body moves with a reference frame and deforms in an elastic
//! basis that must carry no rigid motion. From the basis V of any ROM (line-fitting, SEREP,
//! Craig–Bampton: only V is used):
//!
//! ```text
//! X  = Pᵀ V                        Pᵀ = I − V0 M0⁻¹ V0ᵀ M removes the rigid part (§3.2)
//! G  = Xᵀ M X = U S Uᵀ             keep s_i > DEPENDENT_RTOL · s_max, drop the rest
//! Y  = X U_k S_k^(−1/2)            M-orthonormal: Yᵀ M Y = I
//! Yᵀ K Y = Q Λ Qᵀ,   Φ = Y Q       elastic modes of span(PᵀV), ascending
//! ```
//!
//! so V0ᵀ M Φ = 0, Φᵀ M Φ = I and Φᵀ K Φ = Λ. A column of V dropped in step 2 lay (to the
//! tolerance) in the rigid span: a Craig–Bampton basis loses six, a line-fitting basis
//! usually none. Because K Pᵀ = K, span(PᵀV) holds the same elastic shapes V reproduced,
//! but the reduced mass changes (the rigid content V carried is gone), so the elastic
//! transfer functions are scored again on the projected ROM ([`ElasticBasis::rom`]) and
//! compared with the ROM's own ε (docs/design.md §3.7).
//!
//! **Coupled models** (§3.11). A ROM of a coupled model lives in its coordinates z, q = T z,
//! with M' = TᵀMT, K' = TᵀKT, D' = TᵀDT and T V0' = V0. Its elastic basis Φ (in z) carried
//! to the original DoFs, TΦ, is an elastic basis of the original body with the same ROM:
//!
//! ```text
//! (TΦ)ᵀ M (TΦ) = Φᵀ M' Φ = I,   (TΦ)ᵀ K (TΦ) = Λ,   V0ᵀ M (TΦ) = V0'ᵀ M' Φ = 0
//! ```
//!
//! so the flexible-body exports write the mesh nodes' shapes from TΦ and the body's inertia
//! from the original M and node coordinates, unchanged by the couplings (the remote points
//! are massless). Each remote point becomes one more interface node: its six DoFs (x, y, z,
//! rx, ry, rz) in mode k are R_p Φ_k, R_p the point's six rows over z
//! ([`crate::coupled::Coupled::point_rows`]: a rigid point's DoFs are coordinates of z₁, a
//! distributing point's the weighted least-squares rigid motion of its nodes).
//! [`ElasticBasis::on_original`] does both.
//!
//! Entry points: [`elastic_basis`], [`ElasticBasis::on_original`].

use super::projection::project;
use super::rom::Rom;
use crate::body::Body;
use crate::coupled::Joints;
use crate::coupling::Kind;
use crate::dense::{sym_eigen, sym_eigenvalues};
use crate::pencil::Coefficient;
use crate::scene::Scene;
use crate::units::lambda_to_hz;
use crate::{Error, Result};
use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef};

/// A column of PᵀV whose M-orthogonal component has squared M-norm below this times the
/// largest (an eigenvalue of G = XᵀMX) is dependent and dropped.
pub const DEPENDENT_RTOL: f64 = 1e-10;

/// The elastic basis of a ROM and the ROM projected onto it.
#[derive(Clone, Debug)]
pub struct ElasticBasis {
    /// Φ (N × r): M-orthonormal elastic modes of span(PᵀV), ascending frequency.
    pub phi: Mat<f64>,
    /// Eigenfrequencies (Hz) of Φ's modes: √Λ / 2π, ascending.
    pub eigenfrequencies_hz: Vec<f64>,
    /// Columns of V dropped as dependent after removing the rigid part.
    pub dropped: usize,
    /// The eigenvalues s_i / s_max of G = XᵀMX that were dropped (each below
    /// [`DEPENDENT_RTOL`]): how close to rigid the dropped directions were.
    pub dropped_rel_norms: Vec<f64>,
    /// Largest M-cosine between the rigid modes and Φ, ‖L0⁻¹ V0ᵀ M Φ‖₂ with M0 = L0 L0ᵀ
    /// (0 = M-orthogonal, 1 = a rigid motion lies in span Φ); `None` on a constrained body.
    pub rigid_coupling: Option<f64>,
    /// The ROM projected onto Φ (§3.4): Mr = ΦᵀMΦ, Kr = ΦᵀKΦ, Dr, Br = ΦᵀPB, Cr = CΦ; its
    /// coordinates are modal, so `dofs` is empty.
    pub rom: Rom,
}

/// Largest eigenvalue of a small symmetric matrix (0 for an empty one).
fn max_eig(a: MatRef<'_, f64>) -> f64 {
    match sym_eigenvalues(a) {
        Some(ev) => ev.last().copied().unwrap_or(0.0),
        None => f64::NAN,
    }
}

/// Eigenpairs of a small symmetric matrix, ascending.
fn eigenpairs(a: Mat<f64>) -> Result<(Vec<f64>, Mat<f64>)> {
    sym_eigen(a.as_ref())
        .ok_or_else(|| Error::InvalidSetting("dense eigensolver did not converge".into()))
}

/// The elastic basis Φ = orth_M(PᵀV) of `rom` (see the module doc) and the ROM projected onto
/// it for `scene`'s inputs and outputs.
///
/// # Errors
/// [`Error::InvalidSetting`] when the ROM has no basis (reduce with `--keep-basis`), does not
/// belong to the body's model, or nothing is left after removing the rigid part.
pub fn elastic_basis(body: &Body, scene: &Scene, rom: &Rom) -> Result<ElasticBasis> {
    let pencil = body.pencil();
    rom.check_model(body.n())?;
    let v = rom.basis.as_ref().ok_or_else(|| {
        Error::InvalidSetting(
            "the ROM has no basis V (V.mtx): reduce again with --keep-basis to export it".into(),
        )
    })?;
    let mut x = v.clone();
    if let Some(rb) = body.rigid() {
        rb.project_response_real(x.as_mut());
    }
    let (s, u) = eigenpairs(x.transpose() * pencil.mul(Coefficient::Mass, x.as_ref()))?;
    let s_max = s.last().copied().unwrap_or(0.0);
    let keep: Vec<usize> = (0..s.len())
        .filter(|&i| s[i] > DEPENDENT_RTOL * s_max)
        .collect();
    if keep.is_empty() {
        return Err(Error::InvalidSetting(
            "the ROM's basis V has no elastic content: every column is a rigid motion".into(),
        ));
    }
    let dropped_rel_norms = (0..s.len())
        .filter(|i| !keep.contains(i))
        .map(|i| s[i] / s_max)
        .collect::<Vec<_>>();
    let scale = Mat::from_fn(u.nrows(), keep.len(), |i, j| {
        u[(i, keep[j])] / s[keep[j]].sqrt()
    });
    let y = x * scale;
    let (lambdas, q) = eigenpairs(y.transpose() * pencil.mul(Coefficient::Stiffness, y.as_ref()))?;
    let phi = y * q;
    let rigid_coupling = body.rigid().map(|rb| {
        let w = rb.modes().transpose() * pencil.mul(Coefficient::Mass, phi.as_ref());
        match rb.mass().llt(faer::Side::Lower) {
            Ok(llt) => max_eig((w.transpose() * llt.solve(&w)).as_ref())
                .max(0.0)
                .sqrt(),
            Err(_) => f64::NAN,
        }
    });
    let pr = project(body, scene, phi.as_ref());
    Ok(ElasticBasis {
        eigenfrequencies_hz: lambdas.iter().map(|&l| lambda_to_hz(l)).collect(),
        dropped: s.len() - keep.len(),
        dropped_rel_norms,
        rigid_coupling,
        rom: Rom::from_projection(
            rom.provenance.clone(),
            rom.full_n,
            pr,
            Vec::new(),
            scene,
            Vec::new(),
            None,
        ),
        phi,
    })
}

/// A remote point as an interface node of a flexible-body export (module doc, docs/design.md
/// §3.9, §3.11): massless, at the point's position, moving in mode k as the point does.
#[derive(Clone, Debug)]
pub struct PointNode {
    /// The point's name.
    pub name: String,
    /// Its position (the node's coordinates).
    pub position: [f64; 3],
    /// Rigid (RBE2) or distributing (RBE3).
    pub kind: Kind,
    /// The mesh nodes it is tied to (indices into the original model's nodes, increasing).
    pub nodes: Vec<usize>,
    /// One weight per node of `nodes` (1 for a rigid point and for equal weights).
    pub weights: Vec<f64>,
    /// Its six DoFs (x, y, z, rx, ry, rz) in each mode: 6 × r, R_p Φ.
    pub shapes: Mat<f64>,
}

impl ElasticBasis {
    /// The basis of a ROM of a coupled model carried to the model it came from (module doc):
    /// Φ ← TΦ (N × r, the original DoFs; frequencies and the projected ROM unchanged) and
    /// one [`PointNode`] per remote point with shapes R_p Φ.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] when Φ does not have the coupled model's N' rows or a
    /// point's rows run past them.
    pub fn on_original(&self, joints: &Joints) -> Result<(ElasticBasis, Vec<PointNode>)> {
        let t = &joints.t;
        let (n, np, r) = (t.nrows(), t.ncols(), self.phi.ncols());
        if self.phi.nrows() != np {
            return Err(Error::InvalidSetting(format!(
                "the elastic basis has {} rows, the coupled model has N' = {np}",
                self.phi.nrows()
            )));
        }
        // TΦ, one column of T at a time
        let mut phi = Mat::<f64>::zeros(n, r);
        for j in 0..np {
            for (&i, &v) in t.row_idx_of_col_raw(j).iter().zip(t.val_of_col(j)) {
                for k in 0..r {
                    phi[(i, k)] += v * self.phi[(j, k)];
                }
            }
        }
        let mut points = Vec::with_capacity(joints.points.len());
        for (p, rows) in joints.points.iter().zip(&joints.point_rows) {
            if let Some(&i) = rows.iter().flat_map(|row| &row.idx).find(|&&i| i >= np) {
                return Err(Error::InvalidSetting(format!(
                    "remote point {}: its rows reach DoF {i}, the coupled model has N' = {np}",
                    p.name
                )));
            }
            let shapes = Mat::from_fn(6, r, |d, k| {
                let row = &rows[d];
                row.idx
                    .iter()
                    .zip(&row.val)
                    .map(|(&i, &v)| v * self.phi[(i, k)])
                    .sum()
            });
            let mut order: Vec<usize> = (0..p.nodes.len()).collect();
            order.sort_by_key(|&k| p.nodes[k]);
            points.push(PointNode {
                name: p.name.clone(),
                position: p.position,
                kind: p.kind,
                nodes: order.iter().map(|&k| p.nodes[k]).collect(),
                weights: order
                    .iter()
                    .map(|&k| p.weights.get(k).copied().unwrap_or(1.0))
                    .collect(),
                shapes,
            });
        }
        Ok((
            ElasticBasis {
                phi,
                eigenfrequencies_hz: self.eigenfrequencies_hz.clone(),
                dropped: self.dropped,
                dropped_rel_norms: self.dropped_rel_norms.clone(),
                rigid_coupling: self.rigid_coupling,
                rom: self.rom.clone(),
            },
            points,
        ))
    }
}
