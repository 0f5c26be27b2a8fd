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
//! Entry point: [`elastic_basis`].

use super::projection::project;
use super::rom::Rom;
use crate::body::Body;
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
