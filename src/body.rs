//! The prepared body (docs/design.md §2): everything that depends on the model alone, built
//! once and shared by the sweep, the eigensolver, the metrics and every reductor.
//!
//! - the pencil A(s) = s²M + sD + K on its union pattern (§3.1, [`Pencil`]);
//! - the rigid part of a free body: V0, M0 and the inertia-relief projector P (§3.2,
//!   [`RigidBody`]), detected once;
//! - the ordered (AMD, level-set bisection or nested dissection) symbolic Cholesky of the
//!   pencil's N×N pattern, computed on first use.
//!   The complex LDLᵀ sweep, the real LBLᵀ sweep (D = 0), the interleaved 2N LBLᵀ sweep (its
//!   order is this one, expanded pairwise), the shift-invert Cholesky of K − σM and the
//!   inertia count all factor matrices with this pattern, so one analysis serves them all.
//!
//! A [`Body`] holds the model's matrices once, as the pencil's lower triangles (every later
//! product with M, K or D is [`Pencil::mul`]), with the model's name, node coordinates and DoFs
//! per node: the [`Model`] it was built from can be dropped (on the 10⁶-DoF bar its
//! full-storage M and K are 1.36 GB beside the pencil's 0.77 GB; docs/design.md §2). The scene
//! (inputs, outputs, band) is not part of it and is passed to each computation explicitly.

use crate::factor::Storage;
use crate::model::Model;
use crate::pencil::Pencil;
use crate::rigid::RigidBody;
use crate::Result;
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::Mat;
use std::sync::{Arc, OnceLock};

/// A model prepared for computation; see the module doc.
pub struct Body {
    name: String,
    nodes: Option<Vec<[f64; 3]>>,
    dofs_per_node: usize,
    pencil: Pencil,
    rigid: Option<RigidBody>,
    symbolic: OnceLock<Arc<SymbolicCholesky<usize>>>,
    formed_symbolic: OnceLock<Arc<SymbolicCholesky<usize>>>,
    /// The memory budget of the run (bytes), if one was set: what the real factors may take.
    memory_budget: Option<usize>,
}

impl Body {
    /// Builds the pencil and detects the rigid part ([`RigidBody::detect`], or
    /// [`RigidBody::detect_modes`] for the model's explicit rigid modes); copies the
    /// model's name and nodes. Cost O(nnz + N); the body keeps no reference to `model`.
    ///
    /// # Errors
    /// [`crate::Error::InvalidModel`] when the rigid modes' mass V0ᵀMV0 is not positive
    /// definite (wrong node coordinates).
    pub fn new(model: &Model) -> Result<Self> {
        let pencil = Pencil::new(model);
        let rigid = match (&model.rigid_modes, &model.nodes) {
            (Some(v0), _) => RigidBody::detect_modes(&pencil, v0.clone())?,
            (None, Some(nodes)) => RigidBody::detect(&pencil, nodes, model.dofs_per_node)?,
            (None, None) => None,
        };
        Ok(Body {
            name: model.name.clone(),
            nodes: model.nodes.clone(),
            dofs_per_node: model.dofs_per_node,
            pencil,
            rigid,
            symbolic: OnceLock::new(),
            formed_symbolic: OnceLock::new(),
            memory_budget: None,
        })
    }

    /// The undamped body of the kept DoFs `keep` (ascending; `pos[i]` the new index of DoF i,
    /// `usize::MAX` for a dropped one) with the dropped DoFs held fixed: its pencil is
    /// M_kk, K_kk ([`Pencil::restricted`]), it has no nodes and so no rigid part, and its own
    /// symbolic analysis. Craig–Bampton's interior (docs/design.md §3.8).
    pub fn restricted(&self, name: String, pos: &[usize], keep: &[usize]) -> Body {
        Body {
            name,
            nodes: None,
            dofs_per_node: self.dofs_per_node,
            pencil: self.pencil.restricted(pos, keep),
            rigid: None,
            symbolic: OnceLock::new(),
            formed_symbolic: OnceLock::new(),
            memory_budget: self.memory_budget,
        }
    }

    /// The model again, in full storage, from the pencil's lower triangles (entries of the
    /// union pattern that a matrix lacks are stored as zeros), with the name, nodes and DoFs
    /// per node, and the rigid modes when the body has a rigid part (§3.2). For a caller that
    /// holds only the body and needs the model, e.g. to couple it (§3.11). Memory: the full
    /// storage of M, K (and D).
    ///
    /// # Errors
    /// [`crate::Error::InvalidModel`] if the values fail [`Model::new`]'s checks (they passed
    /// them when the body was built).
    pub fn to_model(&self) -> Result<Model> {
        use crate::model::{Damping, Structural};
        use crate::pencil::Coefficient;
        let all: Vec<usize> = (0..self.n()).collect();
        let full = |c| self.pencil.submatrix(c, &all, &all);
        let damping = match self.pencil.rayleigh() {
            Some((0.0, 0.0)) => Damping::None,
            Some((alpha, beta)) => Damping::Rayleigh { alpha, beta },
            None => Damping::Matrix(full(Coefficient::Damping)),
        };
        // H = ηK + K₄ again, as η alone or as one matrix
        let structural = match self.pencil.structural() {
            (eta, false) => Structural { eta, matrix: None },
            (_, true) => Structural {
                eta: 0.0,
                matrix: Some(full(Coefficient::Structural)),
            },
        };
        let (model, _) = Model::new(
            self.name.clone(),
            full(Coefficient::Mass),
            full(Coefficient::Stiffness),
            damping,
            self.nodes.clone(),
            self.dofs_per_node,
        )?;
        let model = model.with_structural(structural)?;
        match (&self.rigid, &self.nodes) {
            (Some(rb), None) => model.with_rigid_modes(rb.modes().to_owned()),
            _ => Ok(model),
        }
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of DoFs N.
    pub fn n(&self) -> usize {
        self.pencil.n()
    }

    /// The model's node coordinates, if it has them.
    pub fn nodes(&self) -> Option<&[[f64; 3]]> {
        self.nodes.as_deref()
    }

    /// DoFs per node (3 or 6).
    pub fn dofs_per_node(&self) -> usize {
        self.dofs_per_node
    }

    /// The pencil A(s) = s²M + sD + K.
    pub fn pencil(&self) -> &Pencil {
        &self.pencil
    }

    /// The rigid part, if the body is free.
    pub fn rigid(&self) -> Option<&RigidBody> {
        self.rigid.as_ref()
    }

    /// The ordered symbolic Cholesky of the N×N lower pattern the real factorizations take
    /// ([`Pencil::factored`]: the pencil's own, or through a coupling the pencil before its
    /// functionals became coordinates), computed on the first call and kept.
    ///
    /// # Errors
    /// [`crate::Error::Factor`] when the analysis fails (allocation, index overflow).
    pub fn symbolic(&self) -> Result<Arc<SymbolicCholesky<usize>>> {
        if let Some(s) = self.symbolic.get() {
            return Ok(s.clone());
        }
        let s = Arc::new(crate::factor::symbolic_cholesky(&self.pencil)?);
        Ok(self.symbolic.get_or_init(|| s).clone())
    }

    /// The ordered symbolic Cholesky of the pencil's own pattern, which the per-frequency
    /// factorizations of A(iω) fill: [`Self::symbolic`] unless the real factorizations go
    /// through a coupling, then its own analysis, computed on the first call and kept.
    ///
    /// # Errors
    /// As [`Self::symbolic`].
    pub fn formed_symbolic(&self) -> Result<Arc<SymbolicCholesky<usize>>> {
        if self.pencil.through_coupling().is_none() {
            return self.symbolic();
        }
        if let Some(s) = self.formed_symbolic.get() {
            return Ok(s.clone());
        }
        let (s, _) = crate::factor::symbolic_cholesky_ordered(&self.pencil)?;
        Ok(self.formed_symbolic.get_or_init(|| Arc::new(s)).clone())
    }

    /// The body with a memory budget for the whole run (`None`: half the memory available when a
    /// factor is made): a real factor that does not fit what is left of it goes to disk
    /// (docs/design.md §3.1).
    pub fn with_memory_budget(mut self, bytes: Option<usize>) -> Self {
        self.memory_budget = bytes;
        self
    }

    /// What the run's memory budget ([`Self::with_memory_budget`]) leaves beside what the
    /// process holds now, in bytes, if a budget was given.
    pub(crate) fn memory_left(&self) -> Option<usize> {
        self.memory_budget
            .map(|b| b.saturating_sub(crate::memory::rss_bytes().unwrap_or(0)))
    }

    /// Where a real factor made now keeps L: in memory while it fits the budget less what the
    /// process holds already ([`Self::with_memory_budget`]), or half the memory available
    /// ([`Storage::available`]).
    pub(crate) fn factor_storage(&self) -> Storage<'static> {
        match self.memory_left() {
            Some(budget) => Storage { dir: None, budget },
            None => Storage::available(),
        }
    }

    /// B (N×p): unit forces at `inputs`.
    pub fn unit_load(&self, inputs: &[usize]) -> Mat<f64> {
        let mut b = Mat::<f64>::zeros(self.n(), inputs.len());
        for (j, &d) in inputs.iter().enumerate() {
            b[(d, j)] = 1.0;
        }
        b
    }

    /// P B: the unit load without its rigid component on a free body (inertia relief,
    /// §3.2); B itself on a constrained body.
    pub fn elastic_load(&self, inputs: &[usize]) -> Mat<f64> {
        let mut b = self.unit_load(inputs);
        if let Some(rb) = &self.rigid {
            rb.project_load(b.as_mut());
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, BoxSpec};
    use crate::model::Damping;

    /// The model rebuilt from the body has the same M, K and damping, entry for entry.
    #[test]
    fn to_model_gives_back_the_matrices() {
        let mut model = bar_model(&BoxSpec::small()).unwrap();
        for damping in [
            Damping::Rayleigh {
                alpha: 0.5,
                beta: 1e-5,
            },
            Damping::Matrix(model.stiffness.clone()),
        ] {
            model.damping = damping;
            let back = Body::new(&model).unwrap().to_model().unwrap();
            let dense = |a: &crate::sparse::Csc| a.as_ref().to_dense();
            assert_eq!(dense(&back.mass), dense(&model.mass));
            assert_eq!(dense(&back.stiffness), dense(&model.stiffness));
            match (&back.damping, &model.damping) {
                (Damping::Rayleigh { alpha, beta }, Damping::Rayleigh { alpha: a, beta: b }) => {
                    assert_eq!((alpha, beta), (a, b));
                }
                (Damping::Matrix(d), Damping::Matrix(e)) => assert_eq!(dense(d), dense(e)),
                other => panic!("damping changed kind: {other:?}"),
            }
            assert_eq!(back.nodes, model.nodes);
        }
    }
}
