//! The least-squares fit of line-fitting (docs/design.md §3.3–3.4): the interface/rest split,
//! the per-frequency blocks of eq. 22 absorbed into streamed QR states, and the solve that
//! turns a merged state into V = Πᵀ[I; W] and a projected ROM.
//!
//! ```text
//! G_k = [Re X_k[I,:], Im X_k[I,:]]ᵀ  (2p×n),   F_k = [Re X_k[R,:], Im X_k[R,:]]ᵀ  (2p×(N−n))
//! min_W ‖T_oᵀ Wᵀ − T_nᵀ‖_F,  T_oᵀ = [G_1; …; G_z],  T_nᵀ = [F_1; …; F_z]     (eq. 22)
//! ```

use super::options::Interface;
use crate::body::Body;
use crate::lsq::{LsqOptions, StreamedQr};
use crate::reduce::projection::project;
use crate::reduce::rom::{FitReport, Provenance, Rom};
use crate::scene::{check_dofs, Scene};
use crate::{Error, Result};
use faer::{c64, Mat, MatRef};
use std::time::Instant;

/// The interface/rest split of the DoFs and the per-frequency blocks of eq. 22.
pub(crate) struct Partition {
    /// Interface DoFs I (ROM coordinates, in this order).
    pub interface: Vec<usize>,
    /// The other DoFs R, ascending.
    pub rest: Vec<usize>,
}

/// One worker's streamed QR and its reusable block buffers.
pub(crate) struct Worker {
    pub qr: StreamedQr,
    g: Mat<f64>,
    f: Mat<f64>,
    pub absorb_s: f64,
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
        Ok(Partition::from_interface(n_full, interface))
    }

    /// The split for a checked interface of an N-DoF body.
    pub fn from_interface(n_full: usize, interface: Vec<usize>) -> Self {
        let mut is_interface = vec![false; n_full];
        for &d in &interface {
            is_interface[d] = true;
        }
        let rest = (0..n_full).filter(|&d| !is_interface[d]).collect();
        Partition { interface, rest }
    }

    /// The same split with one more interface DoF `d` appended.
    pub fn grown(&self, body: &Body, scene: &Scene, d: usize) -> Result<Self> {
        let mut interface = self.interface.clone();
        interface.push(d);
        Partition::new(body, scene, &Interface::Explicit(interface))
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.interface.len()
    }

    /// A streamed QR of this split that has absorbed nothing.
    pub fn empty_qr(&self) -> StreamedQr {
        StreamedQr::new(self.interface.len(), self.rest.len())
    }

    /// An empty worker state for p inputs.
    pub fn worker(&self, p: usize) -> Worker {
        Worker {
            qr: self.empty_qr(),
            g: Mat::zeros(2 * p, self.interface.len()),
            f: Mat::zeros(2 * p, self.rest.len()),
            absorb_s: 0.0,
        }
    }

    /// Absorbs one elastic snapshot X (N×p): G = [Re X[I,:], Im X[I,:]]ᵀ,
    /// F = [Re X[R,:], Im X[R,:]]ᵀ.
    pub fn absorb(&self, w: &mut Worker, x: MatRef<'_, c64>) -> Result<()> {
        let t = Instant::now();
        let p = x.ncols();
        for j in 0..p {
            for (c, &d) in self.interface.iter().enumerate() {
                w.g[(j, c)] = x[(d, j)].re;
                w.g[(p + j, c)] = x[(d, j)].im;
            }
            for (r, &d) in self.rest.iter().enumerate() {
                w.f[(j, r)] = x[(d, j)].re;
                w.f[(p + j, r)] = x[(d, j)].im;
            }
        }
        w.qr.absorb(w.g.as_ref(), w.f.as_ref())?;
        w.absorb_s += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// Merges worker states into one (TSQR).
    pub fn merge(&self, workers: Vec<Worker>, into: Option<StreamedQr>) -> Result<StreamedQr> {
        let mut it = workers.into_iter().map(|w| w.qr);
        let first = match into {
            Some(q) => q,
            None => it
                .next()
                .ok_or_else(|| Error::InvalidSetting("no reference frequency was solved".into()))?,
        };
        it.try_fold(first, |a, b| a.merge(b))
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
        let n = self.interface.len();
        let sol = qr.finish(lsq)?;
        let mut v = Mat::<f64>::zeros(body.n(), n);
        for (c, &d) in self.interface.iter().enumerate() {
            v[(d, c)] = 1.0;
        }
        for (r, &d) in self.rest.iter().enumerate() {
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
                    residual_argmax_dof: self.rest.get(sol.residual_argmax).copied().unwrap_or(0),
                    rows: sol.rows,
                    solves,
                },
                sampling: None,
            },
            body.n(),
            pr,
            self.interface.clone(),
            scene,
            warnings,
            Some(v),
        ))
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
