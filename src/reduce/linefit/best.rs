//! The ROM a sampling run returns (docs/design.md §3.5, "What is reported is what is
//! returned"): on convergence the one the last step measured, otherwise the measured ROM of
//! smallest error ([`Best`]) — never an unmeasured refit.

use super::verification::Suspects;
use crate::reduce::rom::{Provenance, Rom, Timing};
use crate::reduce::sampling_report::{SamplingReport, Step};
use crate::sweep::SolveAccuracy;

/// A ROM the loop measured, kept as the one to return if the tolerance is not reached.
pub(super) struct Best {
    /// Its max true ε at its step's new and sampled points.
    pub(super) error: f64,
    pub(super) rom: Rom,
    /// Where its verification measures beside the evenly spread points.
    pub(super) suspects: Suspects,
}

/// Whether a ROM measured at `error` replaces the best so far (of error `best`): the first
/// measured one does, later only a smaller error.
pub(super) fn improves(best: Option<f64>, error: f64) -> bool {
    best.is_none_or(|b| error < b)
}

/// The ROM to return, its error and, for a loop that stopped without converging, its
/// [`Suspects`]: when `converged` the `current` ROM with the `last` step's error (max ε at
/// its new or grid and sampled points); otherwise the `best`, or the `current` ROM with an
/// unknown error (NaN) when the loop stopped before any ROM was measured.
pub(super) fn returned(
    converged: bool,
    best: Option<Best>,
    current: Rom,
    last: Option<&Step>,
) -> (f64, Rom, Option<Suspects>) {
    match (converged, best) {
        (true, _) => {
            let last = last.map(|s| s.true_error_max.max(s.sampled_error_max));
            (last.unwrap_or(f64::NAN), current, None)
        }
        (false, Some(best)) => (best.error, best.rom, Some(best.suspects)),
        (false, None) => (f64::NAN, current, None),
    }
}

/// `rom` as returned: its sampling `report` and the run's `solves` (the verification's too)
/// in its provenance, its basis only when `keep_basis`, and the loop's wall time `seconds`.
pub(super) fn finished(
    mut rom: Rom,
    report: SamplingReport,
    solves: SolveAccuracy,
    keep_basis: bool,
    seconds: f64,
) -> Rom {
    if let Provenance::LineFit { sampling, fit, .. } = &mut rom.provenance {
        fit.solves = solves;
        *sampling = Some(report);
    }
    if !keep_basis {
        rom.basis = None;
    }
    rom.timings = vec![Timing {
        phase: "sampling loop (+ verification)".into(),
        seconds,
    }];
    rom
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_smaller_error_replaces_the_best() {
        assert!(improves(None, 0.5));
        assert!(improves(Some(1e-3), 5e-4));
        assert!(!improves(Some(1e-3), 1e-3));
        assert!(!improves(Some(1e-3), 2e-3));
        assert!(!improves(Some(1e-3), f64::NAN));
    }
}
