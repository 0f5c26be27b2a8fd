//! Line-fitting (paper §3.2, docs/design.md §3.3–3.5): V = Πᵀ[I; W] with W fitted by least
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
//! (docs/design.md §3.5): its driver `adaptive.rs`, and its rooms — the settings resolved
//! before the first solve (`plan.rs`), the steps so far (`history.rs`), where a step solves
//! (`picks.rs`), when it stops or grows (`stop.rs`), by how much and which DoFs
//! (`growth.rs`), the true error ε where H1 is known (`true_error.rs`), the verification
//! pass (`verification.rs`), the ROM returned (`best.rs`); its error indicator in
//! [`indicator`], the snapshots kept for interface growth in `snapshots.rs`, its report in
//! `reduce/sampling_report.rs`.

mod adaptive;
mod best;
pub(crate) mod fit;
mod growth;
mod history;
pub mod indicator;
mod options;
mod picks;
mod placement;
mod plan;
mod stop;
mod true_error;
mod verification;

pub use crate::reduce::interface::{spread_dofs, Interface};
pub use crate::reduce::sampling_report::{Outcome, SamplingReport, Step, Verified};
pub use indicator::Indicator;
pub use options::{Growth, LineFitOptions, References, SamplingOptions};
pub use placement::{place_reference_frequencies, RESONANCE_OFFSET};

use crate::body::Body;
use crate::eigen::{eigenpairs, EigenOptions, Modes, Request};
use crate::engine::{Engine, Keep};
use crate::reduce::rom::{Rom, Timing};
use crate::scene::{check_dofs, Scene};
use crate::sweep::{ProgressFn, Response};
use crate::{Error, Result};
use fit::{check_rows, Partition};
use std::time::Instant;

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
    body: &Body,
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
    body: &Body,
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
    let mut engine = Engine::new(body, &opts.sweep, opts.cluster.clone());
    let absorbed = engine.absorb(
        &part.split,
        &scene.inputs,
        &scene.outputs,
        freqs,
        Keep::No,
        progress,
    )?;
    let sweep_s = t_sweep.elapsed().as_secs_f64();
    let gather_s = engine.gather_seconds();
    let absorb_s = absorbed.absorb_s;
    let symbolic_s = engine
        .local_stats(Response::Elastic, &scene.inputs, freqs.len())
        .and_then(|(s, _)| s)
        .map_or(0.0, |s| s.seconds);

    let t_fit = Instant::now();
    let qr = absorbed.qr;
    let mut rom = part.finish(body, scene, &qr, &opts.lsq, freqs, engine.accuracy())?;
    drop(qr);
    let fit_s = t_fit.elapsed().as_secs_f64();
    if !opts.keep_basis {
        rom.basis = None;
    }
    rom.timings = vec![
        Timing {
            phase: "symbolic".into(),
            seconds: symbolic_s,
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
    if engine.ranks() > 1 {
        rom.timings.insert(
            2,
            Timing {
                phase: "gather (rank 0: wait for the ranks, receive, TSQR merge)".into(),
                seconds: gather_s,
            },
        );
    }
    Ok(rom)
}
