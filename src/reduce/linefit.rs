//! Line-fitting (paper §3.2, DESIGN.md §3.3–3.4): V = Πᵀ[I; W] with W fitted by least
//! squares so that the elastic responses of the non-interface DoFs are W times those of the
//! interface DoFs at the reference frequencies:
//!
//! ```text
//! X_k = Pᵀ A(iω_k)⁻¹ P B                       elastic snapshot (N×p), k = 1..z
//! G_k = [Re X_k[I,:], Im X_k[I,:]]ᵀ  (2p×n),   F_k = [Re X_k[R,:], Im X_k[R,:]]ᵀ  (2p×(N−n))
//! min_W ‖T_oᵀ Wᵀ − T_nᵀ‖_F,  T_oᵀ = [G_1; …; G_z],  T_nᵀ = [F_1; …; F_z]     (eq. 22)
//! ```
//!
//! Each frequency's block is absorbed into the worker's streamed QR as soon as it is solved
//! and then dropped ([`crate::lsq`]); the workers' states merge at the end (TSQR), so the
//! peak memory is O(threads · n · N) on top of the factorizations — T_nᵀ is never formed.
//!
//! Entry point: [`reduce`].

use super::{project, Definiteness, FitReport, Method, Rom, Timing};
use crate::lsq::{LsqOptions, StreamedQr};
use crate::model::Model;
use crate::rigid::RigidBody;
use crate::scene::check_dofs;
use crate::sweep::{ProgressFn, Response, Solver, SweepOptions};
use crate::{Error, Result};
use faer::{c64, Mat, MatRef};
use std::time::Instant;

/// How the interface (the ROM's DoFs, order n) is chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum Interface {
    /// These DoFs (must contain every output).
    Explicit(Vec<usize>),
    /// The outputs plus k DoFs spread along the body by [`spread_dofs`].
    OutputsPlus(usize),
}

/// Settings of a line-fitting reduction.
#[derive(Clone, Debug)]
pub struct LineFitOptions {
    /// The interface.
    pub interface: Interface,
    /// Reference frequencies (Hz), each > 0 on a free body.
    pub ref_freqs_hz: Vec<f64>,
    /// Keep V (N×n) in the result.
    pub keep_basis: bool,
    /// Sweep settings (threads, backend, memory).
    pub sweep: SweepOptions,
    /// Least-squares settings (rank truncation).
    pub lsq: LsqOptions,
}

/// `k` DoFs spread uniformly along the body, none of them in `exclude`.
///
/// Rule (with nodes): the long axis a is the longest side of the nodes' bounding box; the
/// targets are the points at fractions (j + ½)/k of its length on the line through the
/// centroid; the node nearest to each target is taken (the lower index on a tie; the next
/// nearest if its DoF is excluded or taken), and its DoF in a direction cycling through the
/// two axes perpendicular to a (bending carries most of a slender body's low-frequency
/// dynamics). Without nodes: DoFs at fractions (j + ½)/k of 0..N.
///
/// # Errors
/// [`Error::InvalidSetting`] when fewer than k DoFs are available.
pub fn spread_dofs(model: &Model, k: usize, exclude: &[usize]) -> Result<Vec<usize>> {
    let n = model.n();
    if k + exclude.len() > n {
        return Err(Error::InvalidSetting(format!(
            "cannot spread {k} extra interface DoFs over a model with N = {n}"
        )));
    }
    let mut taken: Vec<bool> = vec![false; n];
    for &d in exclude {
        taken[d] = true;
    }
    let mut out = Vec::with_capacity(k);
    let Some(nodes) = &model.nodes else {
        for j in 0..k {
            let mut d = ((j as f64 + 0.5) / k as f64 * n as f64) as usize % n;
            while taken[d] {
                d = (d + 1) % n;
            }
            taken[d] = true;
            out.push(d);
        }
        return Ok(out);
    };
    let (mut lo, mut hi, mut c) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], [0.0; 3]);
    for p in nodes {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
            c[a] += p[a] / nodes.len() as f64;
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(2);
    let perp = [(axis + 1) % 3, (axis + 2) % 3];
    let dpn = model.dofs_per_node;
    for j in 0..k {
        let mut target = c;
        target[axis] = lo[axis] + (j as f64 + 0.5) / k as f64 * (hi[axis] - lo[axis]);
        let dir = perp[j % 2];
        let dist = |p: &[f64; 3]| (0..3).map(|a| (p[a] - target[a]).powi(2)).sum::<f64>();
        let best = (0..nodes.len())
            .filter(|&i| !taken[i * dpn + dir])
            .min_by(|&x, &y| dist(&nodes[x]).total_cmp(&dist(&nodes[y])).then(x.cmp(&y)))
            .ok_or_else(|| {
                Error::InvalidSetting("no free DoF left to spread the interface over".into())
            })?;
        taken[best * dpn + dir] = true;
        out.push(best * dpn + dir);
    }
    Ok(out)
}

/// The interface/rest split of the DoFs and the per-frequency blocks of eq. 22.
pub(crate) struct Partition {
    /// Interface DoFs I (ROM coordinates, in this order).
    pub interface: Vec<usize>,
    /// The other DoFs R, ascending.
    pub rest: Vec<usize>,
    /// Input DoFs (columns of B).
    pub inputs: Vec<usize>,
    /// Output DoFs (rows of C), all in the interface.
    pub outputs: Vec<usize>,
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
    pub fn new(
        model: &Model,
        inputs: &[usize],
        outputs: &[usize],
        interface: &Interface,
    ) -> Result<Self> {
        let n_full = model.n();
        let interface = match interface {
            Interface::Explicit(i) => i.clone(),
            Interface::OutputsPlus(k) => {
                let mut i = outputs.to_vec();
                i.extend(spread_dofs(model, *k, outputs)?);
                i
            }
        };
        check_dofs(&interface, n_full, "interface")?;
        if let Some(o) = outputs.iter().find(|o| !interface.contains(o)) {
            return Err(Error::InvalidSetting(format!(
                "output DoF {o} is not in the interface: line-fitting keeps the outputs as ROM coordinates (V = [I; W]); add it to the interface"
            )));
        }
        let mut is_interface = vec![false; n_full];
        for &d in &interface {
            is_interface[d] = true;
        }
        let rest = (0..n_full).filter(|&d| !is_interface[d]).collect();
        Ok(Partition {
            interface,
            rest,
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
        })
    }

    /// An empty worker state for p inputs.
    pub fn worker(&self, p: usize) -> Worker {
        Worker {
            qr: StreamedQr::new(self.interface.len(), self.rest.len()),
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
    /// Returns the ROM (without timings, with V kept) .
    pub fn finish(
        &self,
        model: &Model,
        qr: &StreamedQr,
        rigid: Option<&RigidBody>,
        lsq: &LsqOptions,
        ref_freqs_hz: &[f64],
    ) -> Result<Rom> {
        let n = self.interface.len();
        let sol = qr.finish(lsq)?;
        let mut v = Mat::<f64>::zeros(model.n(), n);
        for (c, &d) in self.interface.iter().enumerate() {
            v[(d, c)] = 1.0;
        }
        for (r, &d) in self.rest.iter().enumerate() {
            for c in 0..n {
                v[(d, c)] = sol.w[(r, c)];
            }
        }
        drop(sol.w);
        let (inputs, outputs) = (&self.inputs, &self.outputs);
        let pr = project(model, v.as_ref(), inputs, outputs, rigid);
        let mut warnings = Vec::new();
        if sol.truncated {
            warnings.push(format!(
                "T_o has numerical rank {} < n = {n} (cond {:.1e} after equilibration): the fit was truncated; \
                 add reference frequencies or remove interface DoFs",
                sol.rank, sol.cond_equilibrated
            ));
        }
        let (mass_definiteness, stiffness_definiteness) =
            Definiteness::of_projection(&pr, &mut warnings);
        Ok(Rom {
            method: Method::LineFit,
            mr: pr.mr,
            dr: pr.dr,
            kr: pr.kr,
            br: pr.br,
            cr: pr.cr,
            dofs: self.interface.clone(),
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
            ref_freqs_hz: ref_freqs_hz.to_vec(),
            modes: Vec::new(),
            fit: Some(FitReport {
                cond_raw: sol.cond_raw,
                cond_equilibrated: sol.cond_equilibrated,
                rank: sol.rank,
                truncated: sol.truncated,
                residual_max: sol.residual_max,
                residual_mean: sol.residual_mean,
                residual_argmax_dof: self.rest.get(sol.residual_argmax).copied().unwrap_or(0),
                rows: sol.rows,
            }),
            mass_definiteness,
            stiffness_definiteness,
            timings: Vec::new(),
            warnings,
            basis: Some(v),
            serep_cond: None,
        })
    }
}

/// Checks 2pz ≥ n (eq. 22 must not be underdetermined).
pub(crate) fn check_rows(p: usize, z: usize, n: usize) -> Result<()> {
    if 2 * p * z < n {
        return Err(Error::InvalidSetting(format!(
            "2pz = 2·{p}·{z} = {} < n = {n}: the least-squares fit of eq. 22 is underdetermined; \
             use at least {} reference frequencies or a smaller interface",
            2 * p * z,
            n.div_ceil(2 * p)
        )));
    }
    Ok(())
}

/// Reduces `model` for unit loads at `inputs` and outputs `outputs` by line-fitting.
///
/// # Errors
/// Bad settings ([`Error::InvalidSetting`]: outputs not in the interface, duplicate DoFs,
/// 2pz < n, no frequency, frequency ≤ 0 on a free body), and the sweep's errors.
pub fn reduce(
    model: &Model,
    inputs: &[usize],
    outputs: &[usize],
    opts: &LineFitOptions,
    progress: ProgressFn<'_>,
) -> Result<Rom> {
    check_dofs(inputs, model.n(), "inputs")?;
    check_dofs(outputs, model.n(), "outputs")?;
    let part = Partition::new(model, inputs, outputs, &opts.interface)?;
    let freqs = &opts.ref_freqs_hz;
    if freqs.is_empty() {
        return Err(Error::InvalidSetting(
            "line-fitting needs at least one reference frequency".into(),
        ));
    }
    let p = inputs.len();
    check_rows(p, freqs.len(), part.interface.len())?;

    let t_sweep = Instant::now();
    let solver = Solver::new(model, inputs, Response::Elastic, &opts.sweep)?;
    let (workers, _) = solver.run(
        freqs,
        || part.worker(p),
        |w: &mut Worker, snap| part.absorb(w, snap.x),
        progress,
    )?;
    let sweep_s = t_sweep.elapsed().as_secs_f64();
    let absorb_s: f64 = workers.iter().map(|w| w.absorb_s).sum();

    let t_fit = Instant::now();
    let qr = part.merge(workers, None)?;
    let mut rom = part.finish(model, &qr, solver.rigid(), &opts.lsq, freqs)?;
    drop(qr);
    let fit_s = t_fit.elapsed().as_secs_f64();
    if !opts.keep_basis {
        rom.basis = None;
    }
    rom.timings = vec![
        Timing {
            phase: "symbolic".into(),
            seconds: solver.symbolic_stats().seconds,
        },
        Timing {
            phase: "sweep (factor + solve + absorb)".into(),
            seconds: sweep_s,
        },
        Timing {
            phase: "absorb (streamed QR, summed over workers)".into(),
            seconds: absorb_s,
        },
        Timing {
            phase: "fit + projection".into(),
            seconds: fit_s,
        },
    ];
    Ok(rom)
}

/// Relative offset δ of the reference points placed beside each resonance: f(1 ± δ).
pub const RESONANCE_OFFSET: f64 = 0.03;

/// `z` reference frequencies for the band from its resonances (the paper's Figure 4 rule,
/// made explicit): a point on each side of every in-band resonance f_j·(1 ± δ) (δ =
/// [`RESONANCE_OFFSET`]), the midpoint between consecutive resonances (where the
/// anti-resonances of driving-point FRFs lie), the midpoints between the band start and the
/// first resonance and between the last resonance and f_hi, and f_hi itself. Then, while
/// there are fewer than z points, the midpoint of the widest gap (band start included) is
/// added; while there are more, the later point of the closest pair is dropped. All points
/// are in (max(f_lo, 0), f_hi], so f = 0 is never used (a free body's A(0) is singular).
///
/// # Errors
/// [`Error::InvalidSetting`] for z = 0 or an empty band.
pub fn place_reference_frequencies(
    resonances_hz: &[f64],
    band_hz: [f64; 2],
    z: usize,
) -> Result<Vec<f64>> {
    let [lo, hi] = band_hz;
    if z == 0 || !(hi > lo && lo >= 0.0) {
        return Err(Error::InvalidSetting(format!(
            "reference points: need z >= 1 and a band 0 <= f_lo < f_hi (got z = {z}, {band_hz:?})"
        )));
    }
    let res: Vec<f64> = resonances_hz
        .iter()
        .copied()
        .filter(|&f| f > lo && f < hi)
        .collect();
    let mut pts = vec![hi];
    let mut prev = lo;
    for &f in &res {
        pts.extend([
            f * (1.0 - RESONANCE_OFFSET),
            f * (1.0 + RESONANCE_OFFSET),
            0.5 * (prev + f),
        ]);
        prev = f;
    }
    if !res.is_empty() {
        pts.push(0.5 * (prev + hi));
    }
    pts.retain(|&f| f > lo && f <= hi);
    pts.sort_by(f64::total_cmp);
    pts.dedup();
    while pts.len() < z {
        let mut best = (pts[0] - lo, 0);
        for k in 1..pts.len() {
            if pts[k] - pts[k - 1] > best.0 {
                best = (pts[k] - pts[k - 1], k);
            }
        }
        let left = if best.1 == 0 { lo } else { pts[best.1 - 1] };
        pts.insert(best.1, 0.5 * (left + pts[best.1]));
    }
    while pts.len() > z {
        let k = (1..pts.len())
            .min_by(|&a, &b| (pts[a] - pts[a - 1]).total_cmp(&(pts[b] - pts[b - 1])))
            .unwrap_or(0);
        pts.remove(k);
    }
    Ok(pts)
}
