//! What line-fitting's adaptive sampling loop did (docs/design.md §3.5): its steps, why it
//! stopped, the error reached. Attached to the ROM it returns ([`crate::reduce::Rom::sampling`]).
//!
//! A room of `reduce` beside `rom.rs`, not of `linefit`: the ROM's provenance holds the
//! report and the loop (`linefit::adaptive`) writes it, so both import it and it imports
//! neither.

/// One step of the loop.
#[derive(Clone, Debug)]
pub struct Step {
    /// ROM order during this step.
    pub order: usize,
    /// Frequencies factored in this step (Hz).
    pub points_hz: Vec<f64>,
    /// Max of the indicator Δ over the candidates before picking (NaN for the seed step).
    pub indicator_max: f64,
    /// Max true elastic ε of the current ROM at the picked points, or at every candidate when
    /// the step measured the whole grid from a shifted Krylov space (NaN for the seed step and
    /// a growth step).
    pub true_error_max: f64,
    /// Max true elastic ε of the current ROM at the earlier sampled points (NaN when the
    /// step measured none: the seed step, and a growth step, which refits without new points).
    pub sampled_error_max: f64,
    /// Full solves so far (frequencies solved, seeds included).
    pub solves: usize,
    /// Factorizations so far: one per factored frequency, one per shifted Krylov space
    /// (docs/design.md §3.10).
    pub factorizations: usize,
    /// Wall time so far (s).
    pub seconds: f64,
    /// What happened: "seed", "refine", "grow interface by DoF d", ...
    pub action: String,
}

/// How the loop ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// The true error at the newly picked and all sampled points is ≤ tol (two steps).
    Converged,
    /// The loop stopped on its budget or on stagnation, but its best ROM was within tol at
    /// one step's picked and sampled points, and the verification pass over the band
    /// confirmed it (≤ tol again): two measurements within tol, as for [`Self::Converged`].
    Confirmed,
    /// The factorization budget ([`crate::reduce::linefit::SamplingOptions::max_points`]) is spent.
    Budget,
    /// More frequencies stopped helping and the order may not grow further
    /// ([`crate::reduce::linefit::SamplingOptions::max_order`]).
    Stagnated,
}

impl Outcome {
    /// The tolerance was reached ([`Self::Converged`] or [`Self::Confirmed`]).
    pub fn reached(&self) -> bool {
        matches!(self, Self::Converged | Self::Confirmed)
    }
}

/// The verification pass of a sampled ROM.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verified {
    /// Full solves, at points spread evenly over the band (ends included).
    pub points: usize,
    /// Max true elastic ε (eq. 23) of the returned ROM over them.
    pub error: f64,
}

/// What the sampling loop did: attached to the ROM it returns ([`crate::reduce::Rom::sampling`]).
#[derive(Clone, Debug)]
pub struct SamplingReport {
    /// The tolerance asked for.
    pub tol: f64,
    /// Every step.
    pub steps: Vec<Step>,
    /// How it ended.
    pub outcome: Outcome,
    /// The error of the returned ROM as the loop measured it: the max true ε at its step's
    /// new points (or candidates) and sampled points ([`Self::ERROR_KIND`]). On convergence the returned ROM is the
    /// last one measured; otherwise it is the measured ROM of smallest error (NaN when none
    /// was measured).
    pub error: f64,
    /// The DoF with the largest fit residual of the returned ROM (the next interface DoF
    /// that would help).
    pub suggested_dof: usize,
    /// The verification pass: max ε of the returned ROM over full solves at points spread
    /// evenly over the band ([`crate::reduce::linefit::SamplingOptions::verify_points`]).
    pub verified: Option<Verified>,
    /// Full solves of the loop (frequencies solved; the verification's come on top).
    pub solves: usize,
    /// Factorizations spent by the loop (the verification's come on top): the inertia
    /// count's, one per factored frequency, one per response space.
    pub factorizations: usize,
    /// Every factorization of the run: the loop's and the verification's.
    pub factorizations_in_all: usize,
    /// Elastic modes in the band, counted by inertia when a default (the interface, the order
    /// cap) needed them.
    pub modes_in_band: Option<usize>,
    /// Snapshots were spilled to a temporary file.
    pub spilled: bool,
    /// The budget of full solves when the temporary directory's free space lowered the
    /// default (the spill file would not have held more snapshots); `None` otherwise.
    pub spill_room: Option<usize>,
}

impl SamplingReport {
    /// What kind of number [`Self::error`] is.
    pub const ERROR_KIND: &'static str = "max true elastic eps (eq. 23) of the loop's ROMs at the sampled points and at the last step's points: the verified indicator maxima, or every candidate of the grid a shifted Krylov space answered (a lower bound of the max over the band)";

    /// "S full solves, F factorizations".
    pub fn cost(&self) -> String {
        format!(
            "{} full solves, {} factorizations",
            self.solves, self.factorizations
        )
    }

    /// One line on what was reached and, if the tolerance was not, what would help (named
    /// by the options' fields; front ends may word them as their flags).
    pub fn summary(&self, order: usize, sampled_points: usize) -> String {
        let last = self.steps.last();
        let verified = match &self.verified {
            Some(v) => format!(
                "; verified max eps {:.2e} over {} full solves across the band ({} \
                 factorizations in all)",
                v.error, v.points, self.factorizations_in_all
            ),
            None => String::new(),
        };
        match self.outcome {
            Outcome::Converged => format!(
                "tolerance {:.1e} reached: true error {:.2e} {} and all {} sampled points; order {}, {}{verified}",
                self.tol,
                self.error,
                match last.map_or(0, |s| s.points_hz.len()) {
                    // the last step measured the whole candidate grid (a shifted Krylov space)
                    0 => "on the candidate grid".to_string(),
                    k => format!("at the last {k} indicator maxima"),
                },
                sampled_points,
                order,
                self.cost()
            ),
            Outcome::Confirmed => format!(
                "tolerance {:.1e} reached: the best ROM measured (order {order}) had true error {:.2e} at one step's indicator maxima and sampled points, confirmed by the verification pass, after {}{verified}",
                self.tol,
                self.error,
                self.cost()
            ),
            _ => format!(
                "tolerance {:.1e} NOT reached ({}): the ROM returned (order {order}) has true error {:.2e} at its sampled points after {}{verified}. What would help: {}",
                self.tol,
                match self.outcome {
                    Outcome::Budget => "budget of full solves spent",
                    _ => "more frequencies stopped helping",
                },
                self.error,
                self.cost(),
                match self.outcome {
                    Outcome::Budget => match self.spill_room {
                        Some(n) => format!(
                            "room for more spilled snapshots (the temporary directory held {n}; \
                             point TMPDIR to a larger disk) and a larger budget of full solves \
                             (max_points)"
                        ),
                        None => "a larger budget of full solves (max_points)".to_string(),
                    },
                    _ => format!(
                        "a larger interface (max_order above {order}; the DoF with the largest fit residual is {})",
                        self.suggested_dof
                    ),
                }
            ),
        }
    }
}
