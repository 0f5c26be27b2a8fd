//! The least-squares fit of line-fitting (docs/design.md §3.3–3.4): the interface/rest split
//! checked against the scene (the frequency engine absorbs each frequency's blocks of eq. 22
//! into streamed QR states of it, [`Split`]), and the solve that turns a merged state into
//! V = Πᵀ[I; W] and a projected ROM.
//!
//! ```text
//! G_k = [Re X_k[I,:], Im X_k[I,:]]ᵀ  (2p×n),   F_k = [Re X_k[R,:], Im X_k[R,:]]ᵀ  (2p×(N−n))
//! min_W ‖T_oᵀ Wᵀ − T_nᵀ‖_F,  T_oᵀ = [G_1; …; G_z],  T_nᵀ = [F_1; …; F_z]     (eq. 22)
//! ```

use crate::body::Body;
use crate::lsq::{LsqOptions, Split, StreamedQr};
use crate::reduce::interface::Interface;
use crate::reduce::projection::project;
use crate::reduce::rom::{FitReport, Provenance, Rom};
use crate::scene::{check_dofs, Scene};
use crate::{Error, Result};
use faer::Mat;

/// The interface/rest split of the DoFs (eq. 22's rows, [`Split`]), checked against the
/// scene.
pub(crate) struct Partition {
    /// Interface DoFs I (ROM coordinates, in this order) and the others R.
    pub split: Split,
}

impl Partition {
    /// Resolves the interface setting and checks it (in range, unique, contains the outputs).
    pub fn new(body: &Body, scene: &Scene, interface: &Interface) -> Result<Self> {
        let n_full = body.n();
        let outputs = &scene.outputs;
        let interface = interface.resolve(body, outputs)?;
        check_dofs(&interface, n_full, "interface")?;
        if let Some(o) = outputs.iter().find(|o| !interface.contains(o)) {
            return Err(Error::InvalidSetting(format!(
                "output DoF {o} is not in the interface: line-fitting keeps the outputs as ROM coordinates (V = [I; W]); add it to the interface"
            )));
        }
        Ok(Partition {
            split: Split::from_interface(n_full, interface),
        })
    }

    /// The same split with the interface DoFs `d` appended.
    pub fn grown(&self, body: &Body, scene: &Scene, d: &[usize]) -> Result<Self> {
        let mut interface = self.split.interface.clone();
        interface.extend_from_slice(d);
        Partition::new(body, scene, &Interface::Explicit(interface))
    }

    /// The non-interface DoFs in descending order of their fit residual `residual` (one per
    /// rest DoF), at most one per node of `dofs_per_node` DoFs and none on a node that
    /// already has an interface DoF: several DoFs added at once then spread over the body
    /// instead of taking the three directions of one node.
    fn growth_candidates(&self, residual: &[f64], dofs_per_node: usize) -> Vec<usize> {
        let per = dofs_per_node.max(1);
        let mut order: Vec<usize> = (0..residual.len()).collect();
        order.sort_by(|&a, &b| residual[b].total_cmp(&residual[a]));
        let mut used: std::collections::HashSet<usize> =
            self.split.interface.iter().map(|&d| d / per).collect();
        order
            .into_iter()
            .map(|r| self.split.rest[r])
            .filter(|&d| used.insert(d / per))
            .take(crate::reduce::rom::GROWTH_CANDIDATES)
            .collect()
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.split.order()
    }

    /// Solves the least-squares problem of `qr`, builds V = Πᵀ[I; W] and projects (§3.4).
    /// Returns the ROM with V kept, no timings and no sampling history.
    pub fn finish(
        &self,
        body: &Body,
        scene: &Scene,
        qr: &StreamedQr,
        lsq: &LsqOptions,
        ref_freqs_hz: &[f64],
        solves: crate::sweep::SolveAccuracy,
    ) -> Result<Rom> {
        let n = self.split.interface.len();
        let sol = qr.finish(lsq)?;
        let mut v = Mat::<f64>::zeros(body.n(), n);
        for (c, &d) in self.split.interface.iter().enumerate() {
            v[(d, c)] = 1.0;
        }
        for (r, &d) in self.split.rest.iter().enumerate() {
            for c in 0..n {
                v[(d, c)] = sol.w[(r, c)];
            }
        }
        drop(sol.w);
        let pr = project(body, scene, v.as_ref());
        let mut warnings = Vec::new();
        if sol.truncated {
            warnings.push(format!(
                "T_o has numerical rank {} < n = {n} (cond {:.1e} after equilibration): the fit was truncated; \
                 add reference frequencies or remove interface DoFs",
                sol.rank, sol.cond_equilibrated
            ));
        }
        Ok(Rom::from_projection(
            Provenance::LineFit {
                ref_freqs_hz: ref_freqs_hz.to_vec(),
                fit: FitReport {
                    cond_raw: sol.cond_raw,
                    cond_equilibrated: sol.cond_equilibrated,
                    rank: sol.rank,
                    truncated: sol.truncated,
                    residual_max: sol.residual_max,
                    residual_mean: sol.residual_mean,
                    residual_argmax_dof: self
                        .split
                        .rest
                        .get(sol.residual_argmax)
                        .copied()
                        .unwrap_or(0),
                    growth_candidates: self.growth_candidates(&sol.residual, body.dofs_per_node()),
                    rows: sol.rows,
                    solves,
                },
                sampling: None,
            },
            body.n(),
            pr,
            self.split.interface.clone(),
            scene,
            warnings,
            Some(v),
        ))
    }
}

/// The fit of the sampling loop's current interface (docs/design.md §3.5, step 2): its
/// partition, the streamed QR state of every sampled frequency, and the ROM fitted from them.
pub(super) struct Fitted {
    pub(super) part: Partition,
    pub(super) qr: StreamedQr,
    pub(super) rom: Rom,
}

impl Fitted {
    /// Merges the state `other` of new frequencies into the QR state (TSQR).
    pub(super) fn merge(&mut self, other: StreamedQr) -> Result<()> {
        let qr = std::mem::replace(&mut self.qr, StreamedQr::new(0, 0));
        self.qr = qr.merge(other)?;
        Ok(())
    }

    /// A copy of the ROM, with its basis V only when `keep_basis` (V is needed only while
    /// the ROM is the current one: the indicator, the growth).
    pub(super) fn rom_copy(&mut self, keep_basis: bool) -> Rom {
        let basis = self.rom.basis.take();
        let mut copy = self.rom.clone();
        if keep_basis {
            copy.basis = basis.clone();
        }
        self.rom.basis = basis;
        copy
    }
}

/// Checks 2pz ≥ n (eq. 22 must not be underdetermined).
///
/// # Errors
/// [`Error::Underdetermined`] naming the counts and the smallest z that works.
pub(super) fn check_rows(p: usize, z: usize, n: usize) -> Result<()> {
    if 2 * p * z < n {
        return Err(Error::Underdetermined {
            rows: 2 * p * z,
            order: n,
            min_frequencies: n.div_ceil(2 * p),
        });
    }
    Ok(())
}
