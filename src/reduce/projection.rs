//! The Galerkin projection shared by every reductor (docs/design.md §3.4) and the
//! definiteness check of its result.

use crate::body::Body;
use crate::dense::{sym, sym_eigenvalues};
use crate::pencil::Coefficient;
use crate::scene::Scene;
use faer::{Mat, MatRef};

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
        let (min_eig, max_eig) = match sym_eigenvalues(a) {
            Some(ev) if !ev.is_empty() => (ev[0], ev[ev.len() - 1]),
            _ => (f64::NAN, f64::NAN),
        };
        Definiteness {
            positive_definite,
            min_eig,
            max_eig,
        }
    }
}

/// The Galerkin projection of docs/design.md §3.4: Mr = VᵀMV, Kr = VᵀKV, Dr = VᵀDV,
/// K₄r = VᵀHV (all symmetrized), Br = Vᵀ P B (P: inertia relief on a free body, identity otherwise),
/// Cr = C V. Cost O(nnz·n + N·n²); MV is formed once as a sparse × dense product.
pub struct Projected {
    /// Vᵀ M V.
    pub mr: Mat<f64>,
    /// Vᵀ D V.
    pub dr: Mat<f64>,
    /// Vᵀ K V.
    pub kr: Mat<f64>,
    /// Vᵀ H V (H = ηK + K₄) when the body has structural damping.
    pub k4r: Option<Mat<f64>>,
    /// Vᵀ P B.
    pub br: Mat<f64>,
    /// C V.
    pub cr: Mat<f64>,
}

/// Projects the body onto V (N×n) for the scene's unit loads and outputs.
pub fn project(body: &Body, scene: &Scene, v: MatRef<'_, f64>) -> Projected {
    let pencil = body.pencil();
    let sym = |a: Mat<f64>| sym(a.as_ref());
    let mr = sym(v.transpose() * pencil.mul(Coefficient::Mass, v));
    let kr = sym(v.transpose() * pencil.mul(Coefficient::Stiffness, v));
    let dr = pencil.damping_term(&mr, &kr, |d| sym(v.transpose() * d(v)));
    let k4r = pencil.structural_term(&kr, || {
        sym(v.transpose() * pencil.mul(Coefficient::Structural, v))
    });
    let br = v.transpose() * body.elastic_load(&scene.inputs);
    let outputs = &scene.outputs;
    let cr = Mat::from_fn(outputs.len(), v.ncols(), |o, j| v[(outputs[o], j)]);
    Projected {
        mr,
        dr,
        kr,
        k4r,
        br,
        cr,
    }
}
