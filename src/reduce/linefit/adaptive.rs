//! Iterative frequency sampling (docs/design.md §3.5): the user asks for an accuracy, the loop
//! finds the reference frequencies (and, if allowed, grows the interface).
//!
//! A greedy loop in the shape of pyMOR's `weak_greedy`, over [`Loop`]:
//!
//! 1. [`Loop::seed`] checks the settings and solves the seeds: ⌈n/2p⌉ (at least 2) points
//!    spread over the band, both ends included (a band that starts at 0 starts at
//!    [`crate::scene::positive_band`]'s f_lo > 0), plus user seeds. When a default needs
//!    them, the elastic modes in the band are counted (inertia): the default interface is the
//!    outputs + max(⌈q/2⌉, ⌈c/2⌉) spread DoFs, the default order cap
//!    [`SamplingOptions::auto_max_order`]. The streamed QR absorbs every solved frequency
//!    once, and the ROM is fitted from it ([`Loop::refit`]).
//! 2. [`Loop::refine`] evaluates an error on a fine candidate grid: the ROM's true error from
//!    the shifted Krylov space's responses at the outputs when one answers (docs/design.md
//!    §3.10), else the residual indicator Δ ([`super::indicator::Indicator`]), at a cost
//!    independent of N. It picks the largest maxima ([`super::picks`]), solves them in
//!    parallel, measures the current ROM's TRUE error there and at the sampled points
//!    ([`super::true_error`]; the snapshots give H1 at the outputs), absorbs them — no
//!    frequency is ever solved twice — and asks the stop rules ([`super::stop`]) what comes
//!    next ([`Next`]).
//! 3. On stagnation [`Loop::grow`] adds interface DoFs ([`super::growth`], [`Growth`]) and
//!    refits from the kept snapshots, while `max_order` allows.
//! 4. A converged ROM must pass the verification pass ([`super::verification`]), else the
//!    loop goes on from the verification's points above tol; [`Loop::report`] verifies the
//!    ROM it returns and attaches its [`SamplingReport`]. Why the loop stopped is returned as
//!    data ([`Outcome`]); front ends word the hints.
//!
//! Snapshot memory rule: snapshots are kept only when the order may grow. They stay in
//! memory while max_points · N · p · 16 bytes fits `snapshot_memory` (default a quarter of the
//! available memory), else every snapshot is spilled to a temporary file and streamed back;
//! then the default budget of full solves is lowered to what the temporary directory has room
//! for, and an explicit budget that does not fit is refused before any solve ([`spill_cap`]).

use super::fit::{check_rows, Partition};
use super::growth::{self, elastic_modes_below};
use super::indicator::Indicator;
use super::options::{Growth, LineFitOptions, SamplingOptions};
use super::picks;
use super::stop;
use super::true_error::{max_error, rel_errs};
use super::verification::{self, Suspects};
use super::Interface;
use crate::body::Body;
use crate::engine::{Engine, Keep};
use crate::grid::linspace;
use crate::lsq::StreamedQr;
use crate::reduce::rom::{Provenance, Rom, Timing};
use crate::reduce::sampling_report::{Outcome, SamplingReport, Step, Verified};
use crate::scene::{positive_band, Scene};
use crate::snapshots::GrowBy;
use crate::sweep::{ProgressFn, Response};
use crate::{Error, Result};
use faer::{c64, Mat};
use std::time::Instant;

/// The budget of full solves the spill file has room for, when that is below `max_points`:
/// each rank spills its own snapshots (`bytes_each` each) and the ranks of one machine share
/// its temporary directory. The default budget is lowered to it (`Some`); an explicit budget
/// (`sampling.max_points`), or one below the seed frequencies, is refused before any work
/// rather than failing when the disk is full.
///
/// # Errors
/// [`Error::InvalidSetting`] naming the directory, the room and the fix.
fn spill_cap(
    bytes_each: usize,
    max_points: usize,
    sampling: &SamplingOptions,
    sampled: &[f64],
    engine: &Engine<'_>,
) -> Result<Option<usize>> {
    let Some(room) = crate::snapshots::spill_room(bytes_each) else {
        return Ok(None);
    };
    let fits = room.saturating_mul(engine.ranks()) / engine.node_ranks().max(1);
    if fits >= max_points {
        return Ok(None);
    }
    if sampling.max_points.is_some() || fits < sampled.len() {
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

/// The true elastic error of `rom` at `freqs` (full solves): (frequency, ε) each.
fn errors_at(
    engine: &mut Engine<'_>,
    scene: &Scene,
    rom: &Rom,
    freqs: &[f64],
    progress: ProgressFn<'_>,
) -> Result<Vec<(f64, f64)>> {
    if freqs.is_empty() {
        return Ok(Vec::new());
    }
    let (h1, _) = engine.respond(
        Response::Elastic,
        &scene.inputs,
        &scene.outputs,
        freqs,
        progress,
    )?;
    Ok(rel_errs(
        rom,
        freqs.iter().copied().zip(h1.iter().map(|h| h.as_ref())),
    ))
}

/// A ROM the loop measured, kept as the one to return if the tolerance is not reached.
struct Best {
    /// Its max true ε at its step's new and sampled points.
    error: f64,
    rom: Rom,
    /// Where its verification measures beside the evenly spread points.
    suspects: Suspects,
}

/// What [`Loop::refine`] decided.
enum Next {
    /// Refit from the grown QR state and refine again.
    Refit,
    /// More frequencies stopped helping: grow the interface (or stop when it may not grow).
    Stagnated,
    /// Stop.
    Stop(Outcome),
}

/// The state of the sampling loop.
struct Loop<'a> {
    body: &'a Body,
    scene: &'a Scene,
    opts: &'a LineFitOptions,
    sampling: &'a SamplingOptions,
    progress: ProgressFn<'a>,
    /// Solves the frequencies (here or over the ranks) and keeps the snapshots.
    engine: Engine<'a>,
    /// Whether the snapshots are kept (only when the order may grow).
    keep: Keep,
    part: Partition,
    /// Frequencies solved per step: the threads of every rank.
    threads: usize,
    max_order: usize,
    /// Budget of full solves ([`SamplingOptions::max_points`] or its default).
    max_points: usize,
    /// The growth rule ([`Growth::Auto`] resolved).
    growth: Growth,
    /// Factorizations outside the engine: the inertia count of the modes in the band.
    counted: usize,
    /// The elastic modes in the band, when counted.
    modes_in_band: Option<usize>,
    /// The budget of full solves the spill file had room for, when it lowered the default.
    spill_room: Option<usize>,
    candidates: Vec<f64>,
    /// Every frequency absorbed into `qr`, in the order of absorption.
    sampled: Vec<f64>,
    /// H1 at the outputs of every sampled frequency.
    sampled_h1: Vec<(f64, Mat<c64>)>,
    qr: StreamedQr,
    rom: Rom,
    steps: Vec<Step>,
    /// Consecutive steps within tol ([`stop::streak`]).
    streak: usize,
    /// The index in `steps` of the last growth (0 before any).
    grown_at: usize,
    /// The measured ROM of smallest error so far; returned when the tolerance is not reached.
    best: Option<Best>,
    /// Indicator max of the last refine step (for a grow step).
    last_delta_max: f64,
    /// The error at the sampled points that decided a growth without the grid (else NaN).
    last_sampled_error: f64,
    /// Full solves before the last refine step (for a grow step).
    last_used: usize,
    /// Frequencies a failed verification measured above tol: the next step solves them
    /// instead of the indicator's maxima.
    forced: Vec<f64>,
    /// Full solves spent by verification passes that found the ROM above tol.
    verify_spent: usize,
    /// The verification of the current ROM, when it ran and passed.
    verified: Option<Verified>,
    start: Instant,
}

/// Line-fitting with iteratively chosen reference frequencies; see the module doc. The
/// whole loop runs in one pool of the sweep's threads (docs/design.md §3.5), which every
/// step's solves and growths then share.
pub(super) fn reduce(
    body: &Body,
    scene: &Scene,
    opts: &LineFitOptions,
    sampling: &SamplingOptions,
    progress: ProgressFn<'_>,
) -> Result<Rom> {
    crate::pool::with_pool(opts.sweep.resolved_threads(), || {
        run_loop(body, scene, opts, sampling, progress)
    })?
}

/// The loop of [`reduce`], inside its pool.
fn run_loop(
    body: &Body,
    scene: &Scene,
    opts: &LineFitOptions,
    sampling: &SamplingOptions,
    progress: ProgressFn<'_>,
) -> Result<Rom> {
    let mut state = Loop::seed(body, scene, opts, sampling, progress)?;
    let outcome = loop {
        match state.refine()? {
            Next::Refit => state.refit()?,
            Next::Stagnated if state.part.order() < state.max_order => {
                state.grow()?;
                state.refit()?;
            }
            Next::Stagnated => {
                state.refit()?;
                break Outcome::Stagnated;
            }
            // converged on the loop's points: the verification must agree, else the loop
            // goes on from the points where it found the ROM above tol
            Next::Stop(Outcome::Converged) => {
                if state.verify_converged()? {
                    break Outcome::Converged;
                }
                state.refit()?;
            }
            Next::Stop(outcome) => break outcome,
        }
    };
    state.report(outcome)
}

impl<'a> Loop<'a> {
    /// Checks the settings, solves the seed frequencies and fits the first ROM.
    fn seed(
        body: &'a Body,
        scene: &'a Scene,
        opts: &'a LineFitOptions,
        sampling: &'a SamplingOptions,
        progress: ProgressFn<'a>,
    ) -> Result<Self> {
        let start = Instant::now();
        if !(sampling.tol > 0.0 && sampling.tol.is_finite()) {
            return Err(Error::InvalidSetting(format!(
                "tol = {}: must be > 0 (a relative error, e.g. 1e-3)",
                sampling.tol
            )));
        }
        scene.validate(body.n(), "scene")?;
        let band = positive_band(scene.band_hz);
        let q = scene.outputs.len();
        // the resonances in the band set the default order: counted (inertia, one real
        // factorization) when a default needs them
        let modes_in_band = match (&opts.interface, sampling.max_order) {
            (Interface::Explicit(_) | Interface::OutputsPlus(_), Some(_)) => None,
            _ => Some(elastic_modes_below(body, band[1])?),
        };
        let interface = match (&opts.interface, modes_in_band) {
            (Interface::Auto, Some(c)) => {
                Interface::OutputsPlus(Interface::auto_extra(q).max(c.div_ceil(2)))
            }
            (i, _) => i.clone(),
        };
        let part = Partition::new(body, scene, &interface)?;
        let p = scene.inputs.len();
        let mut engine = Engine::new(body, &opts.sweep, opts.cluster.clone());
        let growth = match sampling.growth {
            Growth::Auto if engine.ranks() > 1 => Growth::Residual,
            Growth::Auto => Growth::QDeim,
            g => g,
        };
        if growth == Growth::QDeim {
            // refused before any work: the snapshots of a distributed run stay on their ranks
            engine.check_qdeim()?;
        }
        let krylov = engine.by_space(Response::Elastic);
        // responses from a Krylov space cost little beside the refit a step needs: more
        // points per step, fewer steps
        let threads = if krylov {
            engine.concurrency().max(4)
        } else {
            engine.concurrency()
        };
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
        let mut max_points = sampling
            .max_points
            .unwrap_or_else(|| SamplingOptions::auto_max_points(max_order, krylov));
        let counted = usize::from(modes_in_band.is_some());
        let z0 = part.order().div_ceil(2 * p).max(2);
        let mut sampled = linspace(band, z0);
        sampled.extend(sampling.seeds_hz.iter().copied());
        sampled.sort_by(f64::total_cmp);
        sampled.dedup();
        if sampled.len() > max_points {
            return Err(Error::InvalidSetting(format!(
                "max_points = {} is below the {} seed frequencies the interface needs (2pz >= n)",
                max_points,
                sampled.len()
            )));
        }
        check_rows(p, sampled.len(), part.order())?;
        // each rank keeps the snapshots it solved: about max_points / ranks of them, in a
        // budget shared by the ranks of a machine
        let keep = if max_order > part.order() {
            let budget = sampling
                .snapshot_memory
                .unwrap_or_else(|| crate::memory::default_budget(4) / engine.node_ranks());
            let kept = max_points.div_ceil(engine.ranks());
            if kept.saturating_mul(body.n() * p * 16) > budget {
                Keep::Spill
            } else {
                Keep::Memory
            }
        } else {
            Keep::No
        };
        let spill_room = match keep {
            Keep::Spill => spill_cap(body.n() * p * 16, max_points, sampling, &sampled, &engine)?,
            _ => None,
        };
        max_points = spill_room.unwrap_or(max_points);
        let nc = sampling.candidates.max(3);
        let candidates = linspace(band, nc);
        let absorbed = engine.absorb(
            &part.split,
            &scene.inputs,
            &scene.outputs,
            &sampled,
            keep,
            progress,
        )?;
        let qr = absorbed.qr;
        let sampled_h1 = sampled.iter().copied().zip(absorbed.h).collect();
        let steps = vec![Step {
            order: part.order(),
            points_hz: sampled.clone(),
            indicator_max: f64::NAN,
            true_error_max: f64::NAN,
            sampled_error_max: f64::NAN,
            solves: sampled.len(),
            factorizations: counted + engine.accuracy().factorizations(),
            seconds: start.elapsed().as_secs_f64(),
            action: "seed".into(),
        }];
        let rom = part.finish(body, scene, &qr, &opts.lsq, &sampled, engine.accuracy())?;
        Ok(Loop {
            body,
            scene,
            opts,
            sampling,
            progress,
            engine,
            keep,
            part,
            threads,
            max_order,
            max_points,
            growth,
            counted,
            modes_in_band,
            spill_room,
            candidates,
            sampled,
            sampled_h1,
            qr,
            rom,
            steps,
            streak: 0,
            grown_at: 0,
            best: None,
            last_delta_max: f64::NAN,
            last_sampled_error: f64::NAN,
            last_used: 0,
            forced: Vec::new(),
            verify_spent: 0,
            verified: None,
            start,
        })
    }

    /// Refits the ROM from the current QR state and sampled frequencies.
    fn refit(&mut self) -> Result<()> {
        self.rom = self.part.finish(
            self.body,
            self.scene,
            &self.qr,
            &self.opts.lsq,
            &self.sampled,
            self.engine.accuracy(),
        )?;
        Ok(())
    }

    /// A step at the current order with `solves` full solves so far, the factorizations and
    /// the time so far, and no measurement (the caller sets what it measured).
    fn step(&self, solves: usize, action: String) -> Step {
        Step {
            order: self.part.order(),
            points_hz: Vec::new(),
            indicator_max: f64::NAN,
            true_error_max: f64::NAN,
            sampled_error_max: f64::NAN,
            solves,
            factorizations: self.counted + self.engine.accuracy().factorizations(),
            seconds: self.start.elapsed().as_secs_f64(),
            action,
        }
    }

    /// Full solves so far: the last step's and those of failed verification passes since.
    fn solves(&self) -> usize {
        self.steps.last().map_or(0, |s| s.solves) + self.verify_spent
    }

    /// One refinement step: the indicator's largest maxima are solved, the current ROM's
    /// true error is measured there and at the sampled points, and the new snapshots are
    /// absorbed (unless the loop stops). Right after a growth whose ROM is still above tol at
    /// the sampled points, the step is another growth, decided without the grid.
    fn refine(&mut self) -> Result<Next> {
        let tol = self.sampling.tol;
        // right after a growth, a fit still above tol at the sampled points grows again: the
        // growth was made for them, and the grid's error is not needed to see it fall short
        let mut known_sampled_error = None;
        if self.grown_at > 0
            && self.steps.len() == self.grown_at + 1
            && self.forced.is_empty()
            && self.part.order() < self.max_order
        {
            let sampled_error = self.sampled_error();
            if stop::fit_limited(sampled_error, f64::NEG_INFINITY, tol) {
                self.last_delta_max = f64::NAN;
                self.last_sampled_error = sampled_error;
                return Ok(Next::Stagnated);
            }
            known_sampled_error = Some(sampled_error);
        }
        self.last_sampled_error = f64::NAN;
        let grid = self.grid_errors()?;
        let on_grid = grid.is_some();
        let delta: Vec<f64> = match grid {
            Some(e) => e,
            None => {
                let indicator = Indicator::new(self.body, &self.rom)?;
                self.candidates
                    .iter()
                    .map(|&f| indicator.eval(&self.rom, f))
                    .collect()
            }
        };
        let delta_max = delta.iter().copied().fold(0.0, f64::max);
        let mut fit_limited = false;
        if on_grid && self.forced.is_empty() {
            // the ROM's error over the whole grid is known: within tol there and at the
            // sampled points, it has converged (the verification pass certifies it)
            let sampled_error = known_sampled_error.unwrap_or_else(|| self.sampled_error());
            if stop::within_tol_on_grid(delta_max, sampled_error, tol) {
                let action = format!("within tol on all {} candidates", self.candidates.len());
                self.steps.push(Step {
                    indicator_max: delta_max,
                    true_error_max: delta_max,
                    sampled_error_max: sampled_error,
                    ..self.step(self.solves(), action)
                });
                return Ok(Next::Stop(Outcome::Converged));
            }
            // the fit-limit test of a step, made before its solves are spent (from the second
            // step on, when a step has been measured)
            fit_limited = self.best.is_some()
                && self.part.order() < self.max_order
                && stop::fit_limited(
                    sampled_error,
                    picks::max_away(&self.candidates, &delta, &self.sampled),
                    tol,
                );
        }
        let points = if self.forced.is_empty() {
            picks::pick_maxima(&self.candidates, &delta, &self.sampled, self.threads)
        } else {
            std::mem::take(&mut self.forced)
        };
        self.last_delta_max = delta_max;
        self.last_used = self.solves();
        self.verify_spent = 0;
        if fit_limited {
            return Ok(Next::Stagnated);
        }
        let points = if points.is_empty() {
            let measured = self.best.is_some();
            match picks::largest_away(
                &self.candidates,
                &delta,
                &self.sampled,
                measured,
                self.streak,
            ) {
                Some(f) => vec![f],
                // no new indicator maximum away from the sampled points: more frequencies
                // cannot help
                None => return Ok(Next::Stagnated),
            }
        } else {
            points
        };
        let used = self.last_used;
        // the largest maxima first, as many as the budget has left
        let points = match self.max_points.saturating_sub(used) {
            0 => return Ok(Next::Stop(Outcome::Budget)),
            left => points.into_iter().take(left).collect::<Vec<f64>>(),
        };
        let absorbed = self.engine.absorb(
            &self.part.split,
            &self.scene.inputs,
            &self.scene.outputs,
            &points,
            self.keep,
            self.progress,
        )?;
        // the current ROM's true error at the new points, then at the sampled ones
        let measured = rel_errs(
            &self.rom,
            points
                .iter()
                .copied()
                .zip(absorbed.h.iter().map(|h| h.as_ref()))
                .chain(self.sampled_h1.iter().map(|(f, h)| (*f, h.as_ref()))),
        );
        let true_error = max_error(&measured[..points.len()]);
        let sampled_error = max_error(&measured[points.len()..]);
        self.steps.push(Step {
            points_hz: points.clone(),
            indicator_max: self.last_delta_max,
            true_error_max: true_error,
            sampled_error_max: sampled_error,
            ..self.step(used + points.len(), "refine".into())
        });
        let error = true_error.max(sampled_error);
        self.keep_if_best(error, &measured, &delta);
        self.streak = stop::streak(self.streak, error, tol);
        // absorbed also when the loop stops here: a verification that disagrees continues
        // from them (the ROM returned on convergence is the one measured, not refit)
        let qr = std::mem::replace(&mut self.qr, StreamedQr::new(0, 0));
        self.qr = qr.merge(absorbed.qr)?;
        self.sampled_h1
            .extend(points.iter().copied().zip(absorbed.h));
        self.sampled.extend(points.iter().copied());
        if self.streak >= stop::CONVERGING_STREAK {
            return Ok(Next::Stop(Outcome::Converged));
        }
        let stagnated = stop::stagnated(&self.steps[self.grown_at..], self.threads);
        let fit_limited =
            stop::fit_limited(sampled_error, true_error, tol) && self.part.order() < self.max_order;
        Ok(if stagnated || fit_limited {
            Next::Stagnated
        } else {
            Next::Refit
        })
    }

    /// Keeps the current ROM as the [`Best`] when its `error` (max ε at the step's new and
    /// sampled points, `measured`) is the smallest so far, with its [`Suspects`]: the next
    /// maxima of `delta` away from the measured points, and its worst measured point.
    fn keep_if_best(&mut self, error: f64, measured: &[(f64, f64)], delta: &[f64]) {
        if !self.best.as_ref().is_none_or(|b| error < b.error) {
            return;
        }
        // V is needed only while the ROM is the loop's current one (indicator, growth)
        let basis = self.rom.basis.take();
        let mut copy = self.rom.clone();
        if self.opts.keep_basis {
            copy.basis = basis.clone();
        }
        self.rom.basis = basis;
        let points: Vec<f64> = measured.iter().map(|e| e.0).collect();
        self.best = Some(Best {
            error,
            rom: copy,
            suspects: Suspects {
                unmeasured: picks::pick_maxima(&self.candidates, delta, &points, self.threads),
                worst: measured
                    .iter()
                    .copied()
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap_or((f64::NAN, error)),
                points,
            },
        });
    }

    /// Grows the interface ([`Growth`], by [`growth::dofs_to_add`]) and refits the QR state
    /// from the kept snapshots.
    fn grow(&mut self) -> Result<()> {
        if self.keep == Keep::No {
            return Err(Error::InvalidSetting(
                "the interface may not grow: no snapshots were kept".into(),
            ));
        }
        let room = self.max_order - self.part.order();
        let top = positive_band(self.scene.band_hz)[1];
        let missing = growth::missing_modes(self.modes_in_band, &self.rom, top);
        let g = growth::dofs_to_add(self.part.order(), missing, room);
        let d: Vec<usize> = match self.growth {
            Growth::Residual | Growth::Auto => growth::largest_residuals(self.rom.fit(), g),
            Growth::QDeim => {
                let by = GrowBy {
                    at_least: g,
                    at_most: room,
                    rank_tol: self.sampling.tol,
                };
                self.engine.qdeim_next(&self.part.split.interface, by)?
            }
        };
        self.part = self.part.grown(self.body, self.scene, &d)?;
        self.qr = self
            .engine
            .regrow(&self.part.split, self.scene.inputs.len())?;
        let solves = self
            .last_used
            .max(self.steps.last().map(|s| s.solves).unwrap_or(0));
        self.grown_at = self.steps.len();
        let action = growth::action(missing, &d, self.part.order());
        self.steps.push(Step {
            indicator_max: self.last_delta_max,
            sampled_error_max: self.last_sampled_error,
            ..self.step(solves, action)
        });
        Ok(())
    }

    /// The current ROM's max true error at the sampled points (their H1 at the outputs is
    /// kept).
    fn sampled_error(&self) -> f64 {
        max_error(&rel_errs(
            &self.rom,
            self.sampled_h1.iter().map(|(f, h)| (*f, h.as_ref())),
        ))
    }

    /// The current ROM's true elastic error at every candidate, from the shifted Krylov
    /// space's responses at the outputs (docs/design.md §3.5, §3.10): `None` when no space
    /// answers (the residual indicator is used instead); a candidate the space does not
    /// answer counts as infinite error, so that it is solved.
    fn grid_errors(&mut self) -> Result<Option<Vec<f64>>> {
        let Some(h) = self.engine.rows_from_space(
            Response::Elastic,
            &self.scene.inputs,
            &self.scene.outputs,
            &self.candidates,
        )?
        else {
            return Ok(None);
        };
        let answered = rel_errs(
            &self.rom,
            self.candidates
                .iter()
                .enumerate()
                .filter_map(|(k, &f)| h.get(k).map(|h| (f, h))),
        );
        let mut answered = answered.into_iter().map(|e| e.1);
        Ok(Some(
            (0..h.len())
                .map(|k| match h.get(k) {
                    Some(_) => answered.next().unwrap_or(f64::INFINITY),
                    None => f64::INFINITY,
                })
                .collect(),
        ))
    }

    /// Verifies the ROM the loop converged to. Within tol (or without a verification pass):
    /// true, kept for the report. Above tol: the verification's points above tol (the worst
    /// first, as many as a step solves, [`picks::above_tol`]) become the next step's picks,
    /// the loop's convergence count restarts, and false is returned; the budget of full
    /// solves, which counts the verification's, ends the loop if it cannot converge again.
    fn verify_converged(&mut self) -> Result<bool> {
        let points = verification::points_after(self.sampling.verify_points, self.solves());
        let band = positive_band(self.scene.band_hz);
        let Some((v, errors)) = verification::verify(band, points, None, |freqs| {
            errors_at(
                &mut self.engine,
                self.scene,
                &self.rom,
                freqs,
                self.progress,
            )
        })?
        else {
            return Ok(true);
        };
        if v.error <= self.sampling.tol {
            self.verified = Some(v);
            return Ok(true);
        }
        self.forced = picks::above_tol(errors, self.sampling.tol, &self.sampled, self.threads);
        if self.forced.is_empty() {
            self.verified = Some(v);
            return Ok(true);
        }
        self.verify_spent += v.points;
        self.streak = 0;
        Ok(false)
    }

    /// The ROM to return — on convergence the current one (verified at the last step's
    /// points), otherwise the measured ROM of smallest error — verified on
    /// [`SamplingOptions::verify_points`] full solves, with its sampling history.
    ///
    /// A best ROM that was within tol on one step gets the second measurement convergence
    /// needs from the verification pass, which then also measures at its [`Suspects`]:
    /// within tol there too, the outcome is [`Outcome::Confirmed`] ([`stop::confirmed`]).
    fn report(mut self, outcome: Outcome) -> Result<Rom> {
        let (solves, factorizations) = self
            .steps
            .last()
            .map_or((0, 0), |s| (s.solves, s.factorizations));
        let points = verification::points_after(self.sampling.verify_points, solves);
        let (error, mut rom, suspects) = match (outcome == Outcome::Converged, self.best) {
            (true, _) => {
                let last = self
                    .steps
                    .last()
                    .map(|s| s.true_error_max.max(s.sampled_error_max));
                (last.unwrap_or(f64::NAN), self.rom, None)
            }
            (false, Some(best)) => (best.error, best.rom, Some(best.suspects)),
            // stopped before any ROM was measured: the current one, error unknown
            (false, None) => (f64::NAN, self.rom, None),
        };
        let verified = match self.verified {
            Some(v) if outcome == Outcome::Converged => Some(v),
            _ => {
                let band = positive_band(self.scene.band_hz);
                verification::verify(band, points, suspects.as_ref(), |freqs| {
                    errors_at(&mut self.engine, self.scene, &rom, freqs, self.progress)
                })?
                .map(|(v, _)| v)
            }
        };
        let outcome = stop::confirmed(outcome, error, verified, self.sampling.tol);
        let report = SamplingReport {
            tol: self.sampling.tol,
            suggested_dof: rom.fit().map(|f| f.residual_argmax_dof).unwrap_or(0),
            steps: self.steps,
            outcome,
            error,
            verified,
            solves,
            factorizations,
            modes_in_band: self.modes_in_band,
            spilled: self.engine.spilled(),
            spill_room: self.spill_room,
        };
        if let Provenance::LineFit { sampling, fit, .. } = &mut rom.provenance {
            fit.solves = self.engine.accuracy(); // every solve, the verification's too
            *sampling = Some(report);
        }
        if !self.opts.keep_basis {
            rom.basis = None;
        }
        rom.timings = vec![Timing {
            phase: "sampling loop (+ verification)".into(),
            seconds: self.start.elapsed().as_secs_f64(),
        }];
        Ok(rom)
    }
}
