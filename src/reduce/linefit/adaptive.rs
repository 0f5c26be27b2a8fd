//! Iterative frequency sampling (docs/design.md §3.5): the user asks for an accuracy, the loop
//! finds the reference frequencies (and, if allowed, grows the interface).
//!
//! A greedy loop in the shape of pyMOR's `weak_greedy`, over [`Loop`]; what it reads and
//! decides lives in rooms of its own, and the loop only drives the frequency engine:
//!
//! 1. [`Loop::seed`] resolves the run's [`Plan`] ([`super::plan`]: the settings checked, the
//!    interface, the order cap, the budget of full solves, where snapshots are kept), solves
//!    the seeds — the streamed QR absorbs every solved frequency once — and fits the first
//!    ROM ([`Loop::refit`]).
//! 2. [`Loop::refine`] evaluates an error on the candidate grid: the ROM's true error from
//!    the shifted Krylov space's responses at the outputs when one answers
//!    ([`super::true_error::grid_errors`], docs/design.md §3.10), else the residual indicator
//!    Δ ([`super::indicator::Indicator`]), at a cost independent of N, and picks the largest
//!    maxima ([`super::picks`]). [`Loop::solve`] solves them in parallel, measures the
//!    current ROM's TRUE error there and at the sampled points ([`super::true_error`]; the
//!    snapshots give H1 at the outputs), absorbs them — no frequency is ever solved twice —
//!    and asks the stop rules ([`super::stop`]) what comes next ([`Next`]).
//! 3. On stagnation [`Loop::grow`] adds interface DoFs ([`super::growth`]) and
//!    refits from the kept snapshots, while `max_order` allows.
//! 4. A converged ROM must pass the verification pass ([`super::verification`]), else the
//!    loop goes on from the verification's points above tol; [`Loop::report`] verifies the
//!    ROM it returns and attaches its [`SamplingReport`]. Why the loop stopped is returned as
//!    data ([`Outcome`]); front ends word the hints.

use super::best::{self, Best};
use super::fit::Fitted;
use super::growth;
use super::history::{self, History};
use super::indicator::Indicator;
use super::options::{LineFitOptions, SamplingOptions};
use super::picks;
use super::plan::{self, Plan};
use super::stop;
use super::true_error::{errors_at, grid_errors, max_error, rel_errs, Sampled};
use super::verification::{self, Suspects, Verdict};
use crate::body::Body;
use crate::engine::{Engine, Keep};
use crate::reduce::rom::Rom;
use crate::reduce::sampling_report::{Outcome, SamplingReport, Step, Verified};
use crate::scene::Scene;
use crate::sweep::ProgressFn;
use crate::{Error, Result};
use std::time::Instant;

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
    /// The settings resolved before the first solve.
    plan: Plan,
    /// The current interface, its QR state and ROM.
    fit: Fitted,
    /// Every frequency absorbed into the QR state, with its H1 at the outputs.
    sampled: Sampled,
    history: History,
    /// The measured ROM of smallest error so far; returned when the tolerance is not reached.
    best: Option<Best>,
    /// Frequencies a failed verification measured above tol: the next step solves them
    /// instead of the indicator's maxima.
    forced: Vec<f64>,
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
            Next::Stagnated if state.may_grow() => {
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
    /// Resolves the plan, solves the seed frequencies and fits the first ROM.
    fn seed(
        body: &'a Body,
        scene: &'a Scene,
        opts: &'a LineFitOptions,
        sampling: &'a SamplingOptions,
        progress: ProgressFn<'a>,
    ) -> Result<Self> {
        let start = Instant::now();
        let mut engine = Engine::new(body, &opts.sweep, opts.cluster.clone());
        let (plan, part) = plan::plan(body, scene, opts, sampling, &mut engine)?;
        let absorbed = engine.absorb(
            &part.split,
            &scene.inputs,
            &scene.outputs,
            &plan.seeds,
            plan.keep,
            progress,
        )?;
        let sampled = Sampled::new(plan.seeds.clone(), absorbed.h);
        let seed = Step {
            points_hz: plan.seeds.clone(),
            ..history::step(
                part.order(),
                plan.seeds.len(),
                plan.counted + engine.accuracy().factorizations(),
                start.elapsed().as_secs_f64(),
                "seed".into(),
            )
        };
        let rom = part.finish(
            body,
            scene,
            &absorbed.qr,
            &opts.lsq,
            &sampled.freqs,
            engine.accuracy(),
        )?;
        Ok(Loop {
            body,
            scene,
            opts,
            sampling,
            progress,
            engine,
            plan,
            fit: Fitted {
                part,
                qr: absorbed.qr,
                rom,
            },
            sampled,
            history: History::new(seed),
            best: None,
            forced: Vec::new(),
            verified: None,
            start,
        })
    }

    /// Refits the ROM from the current QR state and sampled frequencies.
    fn refit(&mut self) -> Result<()> {
        self.fit.rom = self.fit.part.finish(
            self.body,
            self.scene,
            &self.fit.qr,
            &self.opts.lsq,
            &self.sampled.freqs,
            self.engine.accuracy(),
        )?;
        Ok(())
    }

    /// Whether the interface may grow: its order is below the cap.
    fn may_grow(&self) -> bool {
        self.fit.part.order() < self.plan.max_order
    }

    /// A step at the current order with `solves` full solves so far, the factorizations and
    /// the time so far, and no measurement (the caller sets what it measured).
    fn step(&self, solves: usize, action: String) -> Step {
        history::step(
            self.fit.part.order(),
            solves,
            self.plan.counted + self.engine.accuracy().factorizations(),
            self.start.elapsed().as_secs_f64(),
            action,
        )
    }

    /// One refinement step: the error over the candidates (the grid's true error, else the
    /// indicator), the points to solve — its largest maxima, or a failed verification's
    /// points — and [`Loop::solve`] (unless the loop converged on the grid, or stagnates
    /// before solving). Right after a growth whose ROM is still above tol at the sampled
    /// points, the step is another growth, decided without the grid.
    fn refine(&mut self) -> Result<Next> {
        let tol = self.sampling.tol;
        // right after a growth, a fit still above tol at the sampled points grows again: the
        // growth was made for them, and the grid's error is not needed to see it fall short
        let mut known_sampled_error = None;
        if self.history.just_grown() && self.forced.is_empty() && self.may_grow() {
            let sampled_error = self.sampled.error(&self.fit.rom);
            if stop::fit_limited(sampled_error, f64::NEG_INFINITY, tol) {
                self.history.delta_max = f64::NAN;
                self.history.sampled_error = sampled_error;
                return Ok(Next::Stagnated);
            }
            known_sampled_error = Some(sampled_error);
        }
        self.history.sampled_error = f64::NAN;
        let candidates = &self.plan.candidates;
        let grid = grid_errors(&mut self.engine, self.scene, &self.fit.rom, candidates)?;
        let on_grid = grid.is_some();
        let delta: Vec<f64> = match grid {
            Some(e) => e,
            None => {
                let indicator = Indicator::new(self.body, &self.fit.rom)?;
                candidates
                    .iter()
                    .map(|&f| indicator.eval(&self.fit.rom, f))
                    .collect()
            }
        };
        let delta_max = delta.iter().copied().fold(0.0, f64::max);
        let mut fit_limited = false;
        if on_grid && self.forced.is_empty() {
            // the ROM's error over the whole grid is known: within tol there and at the
            // sampled points, it has converged (the verification pass certifies it)
            let sampled_error =
                known_sampled_error.unwrap_or_else(|| self.sampled.error(&self.fit.rom));
            if stop::within_tol_on_grid(delta_max, sampled_error, tol) {
                let action = format!("within tol on all {} candidates", candidates.len());
                self.history.steps.push(Step {
                    indicator_max: delta_max,
                    true_error_max: delta_max,
                    sampled_error_max: sampled_error,
                    ..self.step(self.history.solves(), action)
                });
                return Ok(Next::Stop(Outcome::Converged));
            }
            // the fit-limit test of a step, made before its solves are spent (from the second
            // step on, when a step has been measured)
            fit_limited = self.best.is_some()
                && self.may_grow()
                && stop::fit_limited(
                    sampled_error,
                    picks::max_away(candidates, &delta, &self.sampled.freqs),
                    tol,
                );
        }
        self.history.delta_max = delta_max;
        self.history.used = self.history.solves();
        self.history.verify_spent = 0;
        if fit_limited {
            return Ok(Next::Stagnated);
        }
        let Some(points) = picks::step_points(
            std::mem::take(&mut self.forced),
            candidates,
            &delta,
            &self.sampled.freqs,
            self.plan.threads,
            self.best.is_some(),
            self.history.streak,
        ) else {
            // no new maximum away from the sampled points: more frequencies cannot help
            return Ok(Next::Stagnated);
        };
        // the largest maxima first, as many as the budget has left
        match self.plan.max_points.saturating_sub(self.history.used) {
            0 => Ok(Next::Stop(Outcome::Budget)),
            left => self.solve(points.into_iter().take(left).collect(), &delta),
        }
    }

    /// Solves a step's `points`, measures the current ROM's true error there and at the
    /// sampled points, keeps it if [`Best`], absorbs the new snapshots (also when the loop
    /// stops here: a verification that disagrees continues from them; the ROM returned on
    /// convergence is the one measured, not refit) and asks the stop rules what comes next.
    fn solve(&mut self, points: Vec<f64>, delta: &[f64]) -> Result<Next> {
        let tol = self.sampling.tol;
        let used = self.history.used;
        let absorbed = self.engine.absorb(
            &self.fit.part.split,
            &self.scene.inputs,
            &self.scene.outputs,
            &points,
            self.plan.keep,
            self.progress,
        )?;
        // the current ROM's true error at the new points, then at the sampled ones
        let measured = rel_errs(
            &self.fit.rom,
            points
                .iter()
                .copied()
                .zip(absorbed.h.iter().map(|h| h.as_ref()))
                .chain(self.sampled.responses()),
        );
        let true_error = max_error(&measured[..points.len()]);
        let sampled_error = max_error(&measured[points.len()..]);
        self.history.steps.push(Step {
            points_hz: points.clone(),
            indicator_max: self.history.delta_max,
            true_error_max: true_error,
            sampled_error_max: sampled_error,
            ..self.step(used + points.len(), "refine".into())
        });
        let error = true_error.max(sampled_error);
        self.keep_if_best(error, &measured, delta);
        self.history.streak = stop::streak(self.history.streak, error, tol);
        self.fit.merge(absorbed.qr)?;
        self.sampled.extend(&points, absorbed.h);
        if self.history.streak >= stop::CONVERGING_STREAK {
            return Ok(Next::Stop(Outcome::Converged));
        }
        let stagnated = stop::stagnated(self.history.since_growth(), self.plan.threads);
        let fit_limited = stop::fit_limited(sampled_error, true_error, tol) && self.may_grow();
        Ok(if stagnated || fit_limited {
            Next::Stagnated
        } else {
            Next::Refit
        })
    }

    /// Keeps the current ROM as the [`Best`] when its `error` (max ε at the step's new and
    /// sampled points, `measured`) is the smallest so far, with its [`Suspects`].
    fn keep_if_best(&mut self, error: f64, measured: &[(f64, f64)], delta: &[f64]) {
        if !best::improves(self.best.as_ref().map(|b| b.error), error) {
            return;
        }
        self.best = Some(Best {
            error,
            rom: self.fit.rom_copy(self.opts.keep_basis),
            suspects: Suspects::of(
                &self.plan.candidates,
                delta,
                measured,
                error,
                self.plan.threads,
            ),
        });
    }

    /// Grows the interface ([`super::options::Growth`], by [`growth::dofs_to_add`]) and refits the QR state
    /// from the kept snapshots.
    fn grow(&mut self) -> Result<()> {
        if self.plan.keep == Keep::No {
            return Err(Error::InvalidSetting(
                "the interface may not grow: no snapshots were kept".into(),
            ));
        }
        let order = self.fit.part.order();
        let room = self.plan.max_order - order;
        let missing =
            growth::missing_modes(self.plan.modes_in_band, &self.fit.rom, self.plan.band[1]);
        let g = growth::dofs_to_add(order, missing, room);
        let d = growth::dofs(
            self.plan.growth,
            &mut self.engine,
            &self.fit.part.split.interface,
            &self.fit.rom,
            [g, room],
            self.sampling.tol,
        )?;
        self.fit.part = self.fit.part.grown(self.body, self.scene, &d)?;
        self.fit.qr = self
            .engine
            .regrow(&self.fit.part.split, self.scene.inputs.len())?;
        let action = growth::action(missing, &d, self.fit.part.order());
        self.history.grew(Step {
            indicator_max: self.history.delta_max,
            sampled_error_max: self.history.sampled_error,
            ..self.step(self.history.solves_at_growth(), action)
        });
        Ok(())
    }

    /// Verifies the ROM the loop converged to. Within tol (or without a verification pass):
    /// true, kept for the report. Above tol: the verification's points above tol (the worst
    /// first, as many as a step solves, [`picks::above_tol`]) become the next step's picks,
    /// the loop's convergence count restarts, and false is returned; the budget of full
    /// solves, which counts the verification's, ends the loop if it cannot converge again.
    fn verify_converged(&mut self) -> Result<bool> {
        let points = verification::points_after(self.sampling.verify_points, self.history.solves());
        let rom = &self.fit.rom;
        let Some((v, errors)) = verification::verify(self.plan.band, points, None, |freqs| {
            errors_at(&mut self.engine, self.scene, rom, freqs, self.progress)
        })?
        else {
            return Ok(true);
        };
        let (tol, threads) = (self.sampling.tol, self.plan.threads);
        match verification::verdict(v, errors, tol, &self.sampled.freqs, threads) {
            Verdict::Passed(v) => {
                self.verified = Some(v);
                Ok(true)
            }
            Verdict::Failed { forced, spent } => {
                self.forced = forced;
                self.history.verify_spent += spent;
                self.history.streak = 0;
                Ok(false)
            }
        }
    }

    /// The ROM to return — on convergence the current one (verified at the last step's
    /// points), otherwise the measured ROM of smallest error — verified on
    /// [`SamplingOptions::verify_points`] full solves, with its sampling history.
    ///
    /// A best ROM that was within tol on one step gets the second measurement convergence
    /// needs from the verification pass, which then also measures at its [`Suspects`]:
    /// within tol there too, the outcome is [`Outcome::Confirmed`] ([`stop::confirmed`]).
    fn report(mut self, outcome: Outcome) -> Result<Rom> {
        let steps = self.history.steps;
        let (solves, factorizations) = steps
            .last()
            .map_or((0, 0), |s| (s.solves, s.factorizations));
        let points = verification::points_after(self.sampling.verify_points, solves);
        let converged = outcome == Outcome::Converged;
        let (error, rom, suspects) =
            best::returned(converged, self.best, self.fit.rom, steps.last());
        let verified = match self.verified {
            Some(v) if converged => Some(v),
            _ => verification::verify(self.plan.band, points, suspects.as_ref(), |freqs| {
                errors_at(&mut self.engine, self.scene, &rom, freqs, self.progress)
            })?
            .map(|(v, _)| v),
        };
        let outcome = stop::confirmed(outcome, error, verified, self.sampling.tol);
        let factorizations_in_all = self.plan.counted + self.engine.accuracy().factorizations();
        let report = SamplingReport {
            tol: self.sampling.tol,
            suggested_dof: rom.fit().map(|f| f.residual_argmax_dof).unwrap_or(0),
            steps,
            outcome,
            error,
            verified,
            solves,
            factorizations,
            factorizations_in_all,
            modes_in_band: self.plan.modes_in_band,
            spilled: self.engine.spilled(),
            spill_room: self.plan.spill_room,
        };
        let solves = self.engine.accuracy(); // every solve, the verification's too
        let seconds = self.start.elapsed().as_secs_f64();
        Ok(best::finished(
            rom,
            report,
            solves,
            self.opts.keep_basis,
            seconds,
        ))
    }
}
