//! The settings of a sampling run, resolved before its first solve (docs/design.md §3.5,
//! step 1, step 7 and "Defaults that reach the tolerance"): a [`Plan`] the loop reads and
//! never changes.
//!
//! - The elastic modes in the band c are counted (inertia: of the shifted Krylov space's
//!   factor, made about the band's top, when one answers the run, else one real
//!   factorization of their own) only when a default needs them: the interface
//!   [`Interface::Auto`] becomes the outputs + max(⌈q/2⌉, ⌈c/2⌉) spread DoFs, the order
//!   cap defaults to [`SamplingOptions::auto_max_order`] (never below the initial order).
//! - The growth rule [`Growth::Auto`] is Q-DEIM in one process, the largest fit residuals
//!   over the ranks (whose snapshots stay on them); Q-DEIM over ranks is refused.
//! - A step solves as many frequencies as the run has threads over all ranks, at least 4
//!   when a shifted Krylov space answers them (§3.10: cheap beside the refit).
//! - Seeds: max(2, ⌈n/2p⌉) points spread over the band, ends included, plus the user's,
//!   within the budget of full solves and with 2pz ≥ n rows.
//! - Snapshots are kept only when the order may grow: in memory while ⌈max_points/ranks⌉ ·
//!   N · p · 16 bytes fits the snapshot budget (by default a quarter of the available memory
//!   shared by the ranks of a machine), else spilled; a spill file lowers the default budget
//!   of full solves to what the temporary directory holds ([`spill_cap`]).

use super::fit::{check_rows, Partition};
use super::growth::elastic_modes_below;
use super::options::{Growth, LineFitOptions, SamplingOptions};
use super::Interface;
use crate::body::Body;
use crate::engine::{Engine, Keep};
use crate::grid::linspace;
use crate::scene::{positive_band, Scene};
use crate::sweep::Response;
use crate::{Error, Result};

/// What a sampling run resolved before its first solve.
pub(super) struct Plan {
    /// The band, starting above 0 ([`positive_band`]).
    pub(super) band: [f64; 2],
    /// The elastic modes in the band, when counted.
    pub(super) modes_in_band: Option<usize>,
    /// Factorizations outside the engine: the inertia count of the modes in the band, when
    /// no shifted space of the engine counted them.
    pub(super) counted: usize,
    /// The growth rule ([`Growth::Auto`] resolved).
    pub(super) growth: Growth,
    /// Frequencies solved per step.
    pub(super) threads: usize,
    pub(super) max_order: usize,
    /// Budget of full solves ([`SamplingOptions::max_points`] or its default, lowered to the
    /// spill file's room).
    pub(super) max_points: usize,
    /// Whether the snapshots are kept (only when the order may grow), and where.
    pub(super) keep: Keep,
    /// The budget of full solves the spill file had room for, when it lowered the default.
    pub(super) spill_room: Option<usize>,
    /// The seed frequencies, sorted.
    pub(super) seeds: Vec<f64>,
    /// The candidate grid the error is evaluated on.
    pub(super) candidates: Vec<f64>,
}

/// Checks the settings and resolves the [`Plan`] of a run over `engine`, with the partition
/// of its initial interface. Counts the modes in the band when a default needs them; nothing
/// is solved.
///
/// # Errors
/// [`Error::InvalidSetting`] for a tolerance that is not > 0, a budget below the seeds, too
/// few seed rows, Q-DEIM over ranks or a spill file without room; those of the scene check,
/// the count and the partition.
pub(super) fn plan(
    body: &Body,
    scene: &Scene,
    opts: &LineFitOptions,
    sampling: &SamplingOptions,
    engine: &mut Engine<'_>,
) -> Result<(Plan, Partition)> {
    check_tol(sampling.tol)?;
    scene.validate(body.n(), "scene")?;
    let band = positive_band(scene.band_hz);
    let q = scene.outputs.len();
    let (modes_in_band, counted) = if needs_modes(&opts.interface, sampling.max_order) {
        let (c, outside) = elastic_modes_below(body, engine, &scene.inputs, band[1])?;
        (Some(c), outside)
    } else {
        (None, 0)
    };
    let part = Partition::new(body, scene, &interface(&opts.interface, q, modes_in_band))?;
    let p = scene.inputs.len();
    let growth = growth_rule(sampling.growth, engine.ranks());
    if growth == Growth::QDeim {
        // refused before any work: the snapshots of a distributed run stay on their ranks
        engine.check_qdeim()?;
    }
    let krylov = engine.by_space(Response::Elastic);
    let threads = threads_per_step(engine.concurrency(), krylov);
    let max_order = sampling
        .max_order
        .unwrap_or_else(|| {
            let memory = crate::memory::default_budget(1);
            SamplingOptions::auto_max_order(
                part.order(),
                q,
                modes_in_band.unwrap_or(0),
                body.n(),
                engine.concurrency(),
                memory,
            )
        })
        .max(part.order());
    let max_points = sampling
        .max_points
        .unwrap_or_else(|| SamplingOptions::auto_max_points(max_order, krylov));
    let seeds = seeds(band, part.order(), p, &sampling.seeds_hz);
    if seeds.len() > max_points {
        return Err(Error::InvalidSetting(format!(
            "max_points = {} is below the {} seed frequencies the interface needs (2pz >= n)",
            max_points,
            seeds.len()
        )));
    }
    check_rows(p, seeds.len(), part.order())?;
    let bytes_each = body.n() * p * 16;
    let keep = if max_order > part.order() {
        let budget = sampling
            .snapshot_memory
            .unwrap_or_else(|| crate::memory::default_budget(4) / engine.node_ranks());
        keep_where(max_points, engine.ranks(), bytes_each, budget)
    } else {
        Keep::No
    };
    let room = match keep {
        Keep::Spill => crate::snapshots::spill_room(bytes_each),
        _ => None,
    };
    let spill_room = match room {
        Some(room) => spill_cap(
            room,
            bytes_each,
            max_points,
            sampling.max_points.is_some(),
            seeds.len(),
            [engine.ranks(), engine.node_ranks()],
        )?,
        None => None,
    };
    let plan = Plan {
        band,
        modes_in_band,
        counted,
        growth,
        threads,
        max_order,
        max_points: spill_room.unwrap_or(max_points),
        keep,
        spill_room,
        seeds,
        candidates: linspace(band, sampling.candidates.max(3)),
    };
    Ok((plan, part))
}

/// The tolerance must be a positive relative error.
fn check_tol(tol: f64) -> Result<()> {
    if tol > 0.0 && tol.is_finite() {
        return Ok(());
    }
    Err(Error::InvalidSetting(format!(
        "tol = {tol}: must be > 0 (a relative error, e.g. 1e-3)"
    )))
}

/// Whether a default needs the count of the modes in the band: the interface unless it is
/// given, the order cap unless it is given.
fn needs_modes(interface: &Interface, max_order: Option<usize>) -> bool {
    !matches!(
        (interface, max_order),
        (Interface::Explicit(_) | Interface::OutputsPlus(_), Some(_))
    )
}

/// The initial interface: [`Interface::Auto`] with the modes in the band counted is the `q`
/// outputs + max(⌈q/2⌉, ⌈c/2⌉) spread DoFs, any other setting itself.
fn interface(interface: &Interface, q: usize, modes_in_band: Option<usize>) -> Interface {
    match (interface, modes_in_band) {
        (Interface::Auto, Some(c)) => {
            Interface::OutputsPlus(Interface::auto_extra(q).max(c.div_ceil(2)))
        }
        (i, _) => i.clone(),
    }
}

/// [`Growth::Auto`] resolved: the largest residuals over ranks, Q-DEIM in one process.
fn growth_rule(growth: Growth, ranks: usize) -> Growth {
    match growth {
        Growth::Auto if ranks > 1 => Growth::Residual,
        Growth::Auto => Growth::QDeim,
        g => g,
    }
}

/// Frequencies a step solves: one per thread of every rank (`concurrency`); responses from
/// a Krylov space cost little beside the refit a step needs, so at least 4 then (more points
/// per step, fewer steps).
fn threads_per_step(concurrency: usize, krylov: bool) -> usize {
    if krylov {
        concurrency.max(4)
    } else {
        concurrency
    }
}

/// The seeds: max(2, ⌈n/2p⌉) points spread over `band` (ends included) for the initial
/// order n and p inputs, with the user's `extra`, sorted, without duplicates.
fn seeds(band: [f64; 2], order: usize, p: usize, extra: &[f64]) -> Vec<f64> {
    let mut seeds = linspace(band, order.div_ceil(2 * p).max(2));
    seeds.extend(extra.iter().copied());
    seeds.sort_by(f64::total_cmp);
    seeds.dedup();
    seeds
}

/// Where the snapshots of a run whose order may grow are kept: each of `ranks` keeps those
/// it solved, about ⌈max_points/ranks⌉ of `bytes_each` bytes, in memory while they fit its
/// `budget`, else in a spill file.
fn keep_where(max_points: usize, ranks: usize, bytes_each: usize, budget: usize) -> Keep {
    let kept = max_points.div_ceil(ranks);
    if kept.saturating_mul(bytes_each) > budget {
        Keep::Spill
    } else {
        Keep::Memory
    }
}

/// The budget of full solves the spill file has room for, when that is below `max_points`:
/// each rank spills its own snapshots (`bytes_each` each, `room` of them in its temporary
/// directory) and the ranks of one machine share that directory (`ranks` = [all, per
/// machine]). The default budget is lowered to it (`Some`); an `explicit` budget, or one
/// below the `seeds`, is refused before any work rather than failing when the disk is full.
///
/// # Errors
/// [`Error::InvalidSetting`] naming the directory, the room and the fix.
fn spill_cap(
    room: usize,
    bytes_each: usize,
    max_points: usize,
    explicit: bool,
    seeds: usize,
    ranks: [usize; 2],
) -> Result<Option<usize>> {
    let fits = room.saturating_mul(ranks[0]) / ranks[1].max(1);
    if fits >= max_points {
        return Ok(None);
    }
    if explicit || fits < seeds {
        return Err(Error::InvalidSetting(format!(
            "max_points = {max_points}: the snapshots kept for interface growth ({:.1} MB per \
             frequency) spill to the temporary directory {}, which has room for {room}; point \
             TMPDIR to a larger disk, or lower max_points to {fits} or max_order",
            bytes_each as f64 / 1e6,
            std::env::temp_dir().display()
        )));
    }
    Ok(Some(fits))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tolerance_must_be_positive_and_finite() {
        assert!(check_tol(1e-3).is_ok());
        for tol in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
            let err = check_tol(tol).unwrap_err().to_string();
            assert!(err.contains("must be > 0"), "{tol}: {err}");
        }
    }

    /// The modes are counted unless both the interface and the order cap are given.
    #[test]
    fn the_modes_are_counted_when_a_default_needs_them() {
        let explicit = Interface::Explicit(vec![1, 2]);
        let plus = Interface::OutputsPlus(3);
        assert!(!needs_modes(&explicit, Some(20)));
        assert!(!needs_modes(&plus, Some(20)));
        assert!(needs_modes(&plus, None));
        assert!(needs_modes(&Interface::Auto, Some(20)));
    }

    /// The 3 m bar: 9 outputs and 42 modes in the band give 9 + 21 spread DoFs; the paper
    /// bar's 9 outputs and 4 modes 9 + 5.
    #[test]
    fn the_automatic_interface_grows_with_the_modes_in_the_band() {
        assert_eq!(
            interface(&Interface::Auto, 9, Some(42)),
            Interface::OutputsPlus(21)
        );
        assert_eq!(
            interface(&Interface::Auto, 9, Some(4)),
            Interface::OutputsPlus(5)
        );
        assert_eq!(interface(&Interface::Auto, 9, None), Interface::Auto);
        assert_eq!(
            interface(&Interface::OutputsPlus(2), 9, Some(42)),
            Interface::OutputsPlus(2)
        );
    }

    #[test]
    fn automatic_growth_is_qdeim_in_one_process_and_residuals_over_ranks() {
        assert_eq!(growth_rule(Growth::Auto, 1), Growth::QDeim);
        assert_eq!(growth_rule(Growth::Auto, 4), Growth::Residual);
        assert_eq!(growth_rule(Growth::QDeim, 4), Growth::QDeim);
        assert_eq!(growth_rule(Growth::Residual, 1), Growth::Residual);
    }

    #[test]
    fn a_krylov_step_solves_at_least_four_frequencies() {
        assert_eq!(threads_per_step(2, true), 4);
        assert_eq!(threads_per_step(8, true), 8);
        assert_eq!(threads_per_step(2, false), 2);
    }

    /// Order 14 with 3 inputs: ⌈14/6⌉ = 3 spread points; the user's seeds join them once.
    #[test]
    fn the_seeds_are_spread_over_the_band_with_the_users() {
        assert_eq!(
            seeds([1.0, 1001.0], 14, 3, &[501.0, 200.0]),
            vec![1.0, 200.0, 501.0, 1001.0]
        );
        // never fewer than the band's two ends
        assert_eq!(seeds([10.0, 20.0], 2, 3, &[]), vec![10.0, 20.0]);
    }

    /// 60 points over 4 ranks: 15 kept per rank, 15 · 1000 bytes against the budget.
    #[test]
    fn snapshots_spill_when_a_ranks_share_exceeds_its_budget() {
        assert_eq!(keep_where(60, 4, 1000, 15_000), Keep::Memory);
        assert_eq!(keep_where(60, 4, 1000, 14_999), Keep::Spill);
        assert_eq!(keep_where(61, 4, 1000, 15_000), Keep::Spill);
    }

    /// Room for 10 per rank's directory, 4 ranks on 2 machines: 20 snapshots in all.
    #[test]
    fn a_spill_file_lowers_the_default_budget_and_refuses_an_explicit_one() {
        let ranks = [4, 2];
        assert_eq!(spill_cap(10, 1000, 20, true, 3, ranks).unwrap(), None);
        assert_eq!(spill_cap(10, 1000, 60, false, 3, ranks).unwrap(), Some(20));
        let err = spill_cap(10, 1000, 60, true, 3, ranks)
            .unwrap_err()
            .to_string();
        assert!(err.contains("lower max_points to 20"), "{err}");
        assert!(spill_cap(10, 1000, 60, false, 21, ranks).is_err());
    }
}
