//! The steps of a sampling run so far (docs/design.md §3.5, "Every step is logged") and the
//! counts its stop and growth rules read: the convergence streak, where the last growth was,
//! the full solves of failed verification passes, and what the last refine step measured
//! before it decided to grow.

use crate::reduce::sampling_report::Step;

/// The steps so far and the counts read from them.
pub(super) struct History {
    pub(super) steps: Vec<Step>,
    /// Consecutive steps within tol ([`super::stop::streak`]).
    pub(super) streak: usize,
    /// The index in `steps` of the last growth (0 before any).
    pub(super) grown_at: usize,
    /// Full solves spent by verification passes that found the ROM above tol.
    pub(super) verify_spent: usize,
    /// Indicator max of the last refine step (for a grow step).
    pub(super) delta_max: f64,
    /// The error at the sampled points that decided a growth without the grid (else NaN).
    pub(super) sampled_error: f64,
    /// Full solves before the last refine step (for a grow step).
    pub(super) used: usize,
}

impl History {
    /// The history of a run after its `seed` step.
    pub(super) fn new(seed: Step) -> Self {
        History {
            steps: vec![seed],
            streak: 0,
            grown_at: 0,
            verify_spent: 0,
            delta_max: f64::NAN,
            sampled_error: f64::NAN,
            used: 0,
        }
    }

    /// Full solves so far: the last step's and those of failed verification passes since.
    pub(super) fn solves(&self) -> usize {
        self.steps.last().map_or(0, |s| s.solves) + self.verify_spent
    }

    /// Whether the last step is a growth.
    pub(super) fn just_grown(&self) -> bool {
        self.grown_at > 0 && self.steps.len() == self.grown_at + 1
    }

    /// The steps since the last growth (all before any), the stagnation window's.
    pub(super) fn since_growth(&self) -> &[Step] {
        &self.steps[self.grown_at..]
    }

    /// Full solves at a growth: those before the last refine step, or the last step's when a
    /// refine step spent more.
    pub(super) fn solves_at_growth(&self) -> usize {
        self.used
            .max(self.steps.last().map(|s| s.solves).unwrap_or(0))
    }

    /// Logs the growth `step`.
    pub(super) fn grew(&mut self, step: Step) {
        self.grown_at = self.steps.len();
        self.steps.push(step);
    }
}

/// A step at `order` with `solves` full solves, `factorizations` and `seconds` so far, and
/// no measurement (the caller sets what it measured).
pub(super) fn step(
    order: usize,
    solves: usize,
    factorizations: usize,
    seconds: f64,
    action: String,
) -> Step {
    Step {
        order,
        points_hz: Vec::new(),
        indicator_max: f64::NAN,
        true_error_max: f64::NAN,
        sampled_error_max: f64::NAN,
        solves,
        factorizations,
        seconds,
        action,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn logged(solves: usize, action: &str) -> Step {
        step(14, solves, solves, 0.0, action.into())
    }

    /// Seeds of 3 solves, a refine step to 7, a failed verification of 4: 11 so far; a
    /// growth then counts the 7, not the verification's.
    #[test]
    fn the_solves_count_the_failed_verifications_and_a_growth_starts_a_window() {
        let mut h = History::new(logged(3, "seed"));
        assert_eq!(h.solves(), 3);
        assert!(!h.just_grown());
        h.steps.push(logged(7, "refine"));
        h.verify_spent = 4;
        assert_eq!(h.solves(), 11);
        h.used = 3;
        assert_eq!(h.solves_at_growth(), 7);
        h.used = 9;
        assert_eq!(h.solves_at_growth(), 9);
        h.grew(logged(9, "grow"));
        assert_eq!(h.grown_at, 2);
        assert!(h.just_grown());
        assert_eq!(h.since_growth().len(), 1);
        h.steps.push(logged(12, "refine"));
        assert!(!h.just_grown());
        assert_eq!(h.since_growth()[1].solves, 12);
    }
}
