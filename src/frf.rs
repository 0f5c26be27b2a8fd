//! Transfer functions on a frequency list (docs/design.md §3.1–3.2): H(iω) = C A(iω)⁻¹ B,
//! its elastic part H1 = C Pᵀ A⁻¹ P B (eq. 17) or its rigid part H0 (eq. 16), solved by the
//! frequency engine ([`crate::engine`]: this process or the ranks of a cluster).

use crate::body::Body;
use crate::engine::{Cluster, Engine};
use crate::factor::SymbolicStats;
use crate::scene::Scene;
use crate::sweep::{zero_hz_total, FreqStats, ProgressFn, Response, Schedule, SweepOptions};
use crate::{Error, Result};
use faer::{c64, Mat};
use std::sync::Arc;
use std::time::Instant;

/// Which part of the transfer function [`transfer_function`] returns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// H = C A⁻¹ B (eq. 14), by direct solves.
    Total,
    /// H1 = C Pᵀ A⁻¹ P B (eq. 17 without cancellation); equals H on a constrained body.
    Elastic,
    /// H0 (eq. 16); needs a free body with nodes.
    Rigid,
}

impl std::str::FromStr for Part {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "total" => Ok(Part::Total),
            "elastic" => Ok(Part::Elastic),
            "rigid" => Ok(Part::Rigid),
            _ => Err(Error::InvalidSetting(format!(
                "part '{s}': choose total, elastic or rigid"
            ))),
        }
    }
}

/// A transfer function on a frequency list, with what it cost.
#[derive(Clone, Debug)]
pub struct Frf {
    /// Frequencies (Hz).
    pub freqs_hz: Vec<f64>,
    /// H(iω_k): outputs × inputs, one per frequency.
    pub h: Vec<Mat<c64>>,
    /// Symbolic analysis (None for the rigid part, which needs no factorization).
    pub symbolic: Option<SymbolicStats>,
    /// Schedule used.
    pub schedule: Option<Schedule>,
    /// Per-frequency stats.
    pub freq_stats: Vec<FreqStats>,
    /// Wall time of the whole computation (s).
    pub seconds: f64,
}

/// H(iω) (or H1, H0) = C X at `freqs_hz` for the scene's inputs and outputs (its band is not
/// used: the frequencies are given), solved in this process or, with a `cluster` of more
/// than one rank, spread over its ranks.
///
/// # Errors
/// As [`crate::sweep::Solver::new`] and [`crate::sweep::Solver::run`]; `Part::Rigid` on a model without rigid part.
pub fn transfer_function(
    body: &Body,
    scene: &Scene,
    freqs_hz: &[f64],
    part: Part,
    opts: &SweepOptions,
    cluster: Option<Arc<dyn Cluster>>,
    progress: ProgressFn<'_>,
) -> Result<Frf> {
    let start = Instant::now();
    let (inputs, outputs) = (&scene.inputs[..], &scene.outputs[..]);
    crate::scene::check_dofs(outputs, body.n(), "outputs")?;
    if part == Part::Rigid {
        crate::scene::check_dofs(inputs, body.n(), "inputs")?;
        let rb = body.rigid().ok_or_else(|| {
            Error::InvalidSetting(
                "part rigid: the model has no rigid part (no nodes, or K V0 != 0: a constrained body)".into(),
            )
        })?;
        let h = freqs_hz
            .iter()
            .map(|&f| rb.h0(2.0 * std::f64::consts::PI * f, inputs, outputs))
            .collect();
        return Ok(Frf {
            freqs_hz: freqs_hz.to_vec(),
            h,
            symbolic: None,
            schedule: None,
            freq_stats: Vec::new(),
            seconds: start.elapsed().as_secs_f64(),
        });
    }
    // A free body without damping or with Rayleigh damping splits exactly into its rigid and
    // elastic parts (docs/design.md §3.2), so its total H is computed as H0 + H1: a direct
    // solve of A(iω) returns the rigid part, which the probe does not check, inaccurately at
    // low frequency (relative error 1.9 at 1e-6·f1 on a coarse bar, tests/it/extremes.rs).
    let split =
        part == Part::Total && !body.pencil().has_damping_matrix() && body.rigid().is_some();
    if split && freqs_hz.contains(&0.0) {
        return Err(zero_hz_total());
    }
    let response = if part == Part::Elastic || split {
        Response::Elastic
    } else {
        Response::Total
    };
    let mut engine = Engine::new(body, opts, cluster);
    let (mut h, freq_stats) = engine.respond(response, inputs, outputs, freqs_hz, progress)?;
    let h0 = |f: f64| match (split, body.rigid()) {
        (true, Some(rb)) => Some(rb.h0(2.0 * std::f64::consts::PI * f, inputs, outputs)),
        _ => None,
    };
    for (h, &f) in h.iter_mut().zip(freqs_hz) {
        if let Some(h0) = h0(f) {
            *h += h0;
        }
    }
    let (symbolic, schedule) = match engine.local_stats(response, inputs, freqs_hz.len()) {
        Some((symbolic, schedule)) => (symbolic, Some(schedule)),
        None => (None, None),
    };
    Ok(Frf {
        freqs_hz: freqs_hz.to_vec(),
        h,
        symbolic,
        schedule,
        freq_stats,
        seconds: start.elapsed().as_secs_f64(),
    })
}
