//! Line-fitting (paper §3.2, DESIGN.md §3.3–3.5): V = Πᵀ[I; W] with W fitted by least
//! squares so that the elastic responses of the non-interface DoFs are W times those of the
//! interface DoFs at the reference frequencies:
//!
//! ```text
//! X_k = Pᵀ A(iω_k)⁻¹ P B                       elastic snapshot (N×p), k = 1..z
//! min_W ‖T_oᵀ Wᵀ − T_nᵀ‖_F                     (eq. 22, see [`fit`])
//! ```
//!
//! Each frequency's block is absorbed into the worker's streamed QR as soon as it is solved
//! and then dropped ([`crate::lsq`]); the workers' states merge at the end (TSQR), so the
//! peak memory is O(threads · n · N) on top of the factorizations — T_nᵀ is never formed.
//!
//! One entry point, [`reduce`], for every way of choosing the reference frequencies
//! ([`References`]): given explicitly, a count placed beside the resonances in the band
//! ([`place_reference_frequencies`]), or a tolerance reached by the adaptive sampling loop
//! ([`adaptive`], DESIGN.md §3.5; its error indicator in [`indicator`], the snapshots kept
//! for interface growth in [`snapshots`]).

mod adaptive;
mod fit;
pub mod indicator;
mod snapshots;

pub use adaptive::{Growth, Outcome, SamplingOptions, SamplingReport, Step};
pub use indicator::Indicator;

use crate::body::Body;
use crate::eigen::{eigenpairs, EigenOptions, Modes, Request};
use crate::lsq::LsqOptions;
use crate::model::Model;
use crate::reduce::{Rom, Timing};
use crate::scene::{check_dofs, Scene};
use crate::sweep::{ProgressFn, Response, Solver, SweepOptions};
use crate::{Error, Result};
use fit::{check_rows, Partition, Worker};
use std::time::Instant;

/// How the interface (the ROM's DoFs, order n) is chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum Interface {
    /// These DoFs (must contain every output).
    Explicit(Vec<usize>),
    /// The outputs plus k DoFs spread along the body by [`spread_dofs`].
    OutputsPlus(usize),
}

/// How the reference frequencies are chosen.
#[derive(Clone, Debug)]
pub enum References {
    /// These frequencies (Hz), each > 0 on a free body.
    Explicit(Vec<f64>),
    /// This many, placed beside the resonances of the scene's band by
    /// [`place_reference_frequencies`] (the modes are computed, or taken from the caller).
    Count(usize),
    /// As many as the adaptive sampling loop needs to reach a tolerance (DESIGN.md §3.5).
    Tolerance(SamplingOptions),
}

/// Settings of a line-fitting reduction.
#[derive(Clone, Debug)]
pub struct LineFitOptions {
    /// The interface (the initial one when the sampling loop may grow it).
    pub interface: Interface,
    /// The reference frequencies.
    pub references: References,
    /// Keep V (N×n) in the result.
    pub keep_basis: bool,
    /// Sweep settings (threads, backend, memory).
    pub sweep: SweepOptions,
    /// Least-squares settings (rank truncation).
    pub lsq: LsqOptions,
}

impl LineFitOptions {
    /// Defaults (all threads, automatic backend, default rank rule, no basis kept) for an
    /// interface and a choice of reference frequencies.
    pub fn new(interface: Interface, references: References) -> Self {
        LineFitOptions {
            interface,
            references,
            keep_basis: false,
            sweep: SweepOptions::default(),
            lsq: LsqOptions::default(),
        }
    }
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

/// Reduces the body by line-fitting for the scene's unit loads and outputs.
///
/// `known` are eigenpairs the caller already has (used by [`References::Count`] for the
/// resonances in the band: every mode up to the band end, as [`Request::UpTo`] returns them);
/// without them the modes are computed.
///
/// A tolerance that is not reached is not an error: the ROM's [`Rom::sampling`] report says
/// what was reached and why the loop stopped.
///
/// # Errors
/// Bad settings ([`Error::InvalidSetting`]: outputs not in the interface, duplicate DoFs, no
/// frequency, frequency ≤ 0 on a free body, tol ≤ 0), [`Error::DofOutOfRange`],
/// [`Error::Underdetermined`] (2pz < n), the eigensolver's and the sweep's errors.
pub fn reduce(
    body: &Body<'_>,
    scene: &Scene,
    opts: &LineFitOptions,
    known: Option<&Modes>,
    progress: ProgressFn<'_>,
) -> Result<Rom> {
    let n = body.n();
    check_dofs(&scene.inputs, n, "inputs")?;
    check_dofs(&scene.outputs, n, "outputs")?;
    let freqs = match &opts.references {
        References::Explicit(f) => f.clone(),
        References::Count(z) => {
            let computed;
            let modes = match known {
                Some(m) => m,
                None => {
                    computed = eigenpairs(
                        body,
                        Request::UpTo(scene.band_hz[1]),
                        &EigenOptions::default(),
                    )?;
                    &computed
                }
            };
            let resonances = &modes.freqs_hz()[modes.rigid..];
            place_reference_frequencies(resonances, scene.band_hz, *z)?
        }
        References::Tolerance(s) => return adaptive::reduce(body, scene, opts, s, progress),
    };
    fixed(body, scene, opts, &freqs, progress)
}

/// Line-fitting on a fixed set of reference frequencies.
fn fixed(
    body: &Body<'_>,
    scene: &Scene,
    opts: &LineFitOptions,
    freqs: &[f64],
    progress: ProgressFn<'_>,
) -> Result<Rom> {
    let part = Partition::new(body, scene, &opts.interface)?;
    if freqs.is_empty() {
        return Err(Error::InvalidSetting(
            "line-fitting needs at least one reference frequency".into(),
        ));
    }
    let p = scene.inputs.len();
    check_rows(p, freqs.len(), part.order())?;

    let t_sweep = Instant::now();
    let solver = Solver::new(body, &scene.inputs, Response::Elastic, &opts.sweep)?;
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
    let mut rom = part.finish(body, scene, &qr, &opts.lsq, freqs)?;
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
