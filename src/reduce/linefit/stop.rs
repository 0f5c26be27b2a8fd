//! When the sampling loop stops, or grows the interface instead of sampling on
//! (docs/design.md §3.5, step 5): functions of the steps and the true errors ε (eq. 23) the
//! loop measured.
//!
//! - *Converged*: ε ≤ tol at every candidate of the Krylov space's grid and at every sampled
//!   point ([`within_tol_on_grid`]), or at the new and the earlier sampled points on
//!   [`CONVERGING_STREAK`] consecutive steps ([`streak`]). One step can be fooled: measured
//!   on the paper bar, the ROM of the two seeds has its indicator maximum at 175 Hz with
//!   true error 0.037 while the true maximum is 0.58 at 396 Hz. The sampled points count
//!   too: the fit is a least-squares compromise, not an interpolation, and a ROM's largest
//!   error often sits at a sampled point such as the band end.
//! - *Stagnated*: the step's error is above 0.9× the best of the previous
//!   max(3, ⌈6/threads⌉) steps since the last growth ([`stagnated`]), or the fit is at its
//!   limit ([`fit_limited`]).
//! - *Confirmed*: a loop stopped on its budget or on stagnation whose best ROM was within tol
//!   on one step, and within tol again in the verification pass ([`confirmed`]).

use crate::reduce::sampling_report::{Outcome, Step, Verified};

/// Consecutive steps within tol that converge the loop on its own points.
pub(super) const CONVERGING_STREAK: usize = 2;

/// The count of consecutive steps within `tol` after a step of error `error` (max ε at its
/// new and sampled points), `previous` the count before it.
pub(super) fn streak(previous: usize, error: f64, tol: f64) -> usize {
    if error <= tol {
        previous + 1
    } else {
        0
    }
}

/// Converged on the Krylov space's grid: the ROM's true error is within `tol` at every
/// candidate (`grid_max`) and at every sampled point (`sampled_error`).
pub(super) fn within_tol_on_grid(grid_max: f64, sampled_error: f64, tol: f64) -> bool {
    grid_max <= tol && sampled_error <= tol
}

/// The fit is at its limit: the error at the sampled points is above `tol` and no smaller
/// than `elsewhere`, the largest error measured away from them (the step's new points, the
/// grid's candidates away from the sampled points, or −∞ when nothing else was measured:
/// right after a growth, which was made for the sampled points). The fit there is the best
/// this order can do (more points only add rows to the least-squares problem, eq. 22), so
/// more frequencies cannot bring it within tol: the interface must grow.
pub(super) fn fit_limited(sampled_error: f64, elsewhere: f64, tol: f64) -> bool {
    sampled_error > tol && sampled_error >= elsewhere
}

/// Whether more frequencies stopped helping: the last measured step's error (max ε at its
/// new and sampled points) is above 0.9× the smallest of the w = max(3, ⌈6/threads⌉) steps
/// before it. `since_growth` are the steps since the last growth (a grown ROM's first steps
/// measure where the smaller one was never measured, so the window restarts); steps without
/// a measurement (a growth) are skipped. The window spans about 6 factorizations whatever
/// the number of threads.
pub(super) fn stagnated(since_growth: &[Step], threads: usize) -> bool {
    let errors: Vec<f64> = since_growth
        .iter()
        .filter(|s| s.true_error_max.is_finite())
        .map(|s| s.true_error_max.max(s.sampled_error_max))
        .collect();
    let w = 3.max(6usize.div_ceil(threads));
    let k = errors.len();
    k > w
        && errors[k - 1]
            > 0.9
                * errors[k - 1 - w..k - 1]
                    .iter()
                    .copied()
                    .fold(f64::INFINITY, f64::min)
}

/// The outcome after the verification pass of the returned ROM: a loop stopped on its
/// budget or on stagnation is [`Outcome::Confirmed`] when its best ROM was within `tol` on
/// one step (`error`) and the pass measures it within `tol` again — two measurements, as
/// for convergence. Any other outcome stays.
pub(super) fn confirmed(
    outcome: Outcome,
    error: f64,
    verified: Option<Verified>,
    tol: f64,
) -> Outcome {
    let within = |e: f64| e <= tol;
    match (&outcome, verified) {
        (Outcome::Budget | Outcome::Stagnated, Some(v)) if within(error) && within(v.error) => {
            Outcome::Confirmed
        }
        _ => outcome,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step measured at `true_error` (new points) and `sampled_error`; NaN for a growth.
    fn step(true_error: f64, sampled_error: f64) -> Step {
        Step {
            order: 10,
            points_hz: Vec::new(),
            indicator_max: f64::NAN,
            true_error_max: true_error,
            sampled_error_max: sampled_error,
            solves: 0,
            factorizations: 0,
            seconds: 0.0,
            action: String::new(),
        }
    }

    #[test]
    fn two_steps_within_tol_in_a_row_converge() {
        let tol = 1e-3;
        let s = streak(0, 9e-4, tol);
        assert_eq!(s, 1);
        assert_eq!(streak(s, 1e-3, tol), CONVERGING_STREAK);
        assert_eq!(streak(s, 1.1e-3, tol), 0);
        assert!(within_tol_on_grid(1e-3, 5e-4, tol));
        assert!(!within_tol_on_grid(1e-3, 2e-3, tol));
        assert!(!within_tol_on_grid(f64::INFINITY, 5e-4, tol));
    }

    #[test]
    fn the_fit_is_the_limit_only_above_tol_and_no_better_at_the_sampled_points() {
        let tol = 1e-3;
        assert!(fit_limited(5e-3, 4e-3, tol));
        assert!(fit_limited(5e-3, 5e-3, tol));
        assert!(!fit_limited(5e-3, 6e-3, tol));
        assert!(!fit_limited(9e-4, 1e-4, tol));
        // right after a growth nothing else is measured
        assert!(fit_limited(2e-3, f64::NEG_INFINITY, tol));
        assert!(!fit_limited(f64::NAN, f64::NEG_INFINITY, tol));
    }

    #[test]
    fn stagnation_compares_the_last_step_with_the_best_of_its_window() {
        // two threads: a window of 3 steps
        let steps = |e: &[f64]| e.iter().map(|&e| step(e, 0.0)).collect::<Vec<_>>();
        assert!(!stagnated(&steps(&[1.0, 0.5, 0.6]), 2)); // 2 steps before the last
        assert!(stagnated(&steps(&[1.0, 0.5, 0.4, 0.45]), 2)); // 0.45 > 0.9 · 0.4
        assert!(!stagnated(&steps(&[1.0, 0.5, 0.4, 0.35]), 2)); // 0.35 < 0.36
        assert!(stagnated(&steps(&[1.0, 0.5, 0.4, 0.3, 0.36]), 2)); // 0.36 > 0.9 · 0.3
                                                                    // one thread: a window of 6 steps
        assert!(!stagnated(&steps(&[1.0, 0.5, 0.4, 0.45]), 1));
        // the sampled points' error counts; a growth step (NaN) is skipped
        let mut s = steps(&[1.0, 0.5, 0.4, 0.3]);
        s.insert(2, step(f64::NAN, 0.1));
        s.push(step(0.1, 0.29));
        assert!(stagnated(&s, 2));
        s.last_mut().unwrap().sampled_error_max = 0.2;
        assert!(!stagnated(&s, 2));
    }

    #[test]
    fn a_stop_within_tol_twice_is_confirmed() {
        let tol = 1e-3;
        let v = |error| Some(Verified { points: 5, error });
        assert_eq!(
            confirmed(Outcome::Budget, 8e-4, v(9e-4), tol),
            Outcome::Confirmed
        );
        assert_eq!(
            confirmed(Outcome::Stagnated, 8e-4, v(9e-4), tol),
            Outcome::Confirmed
        );
        assert_eq!(
            confirmed(Outcome::Budget, 8e-4, v(1.1e-3), tol),
            Outcome::Budget
        );
        assert_eq!(
            confirmed(Outcome::Budget, 2e-3, v(9e-4), tol),
            Outcome::Budget
        );
        assert_eq!(
            confirmed(Outcome::Stagnated, 8e-4, None, tol),
            Outcome::Stagnated
        );
        assert_eq!(
            confirmed(Outcome::Converged, 2e-3, v(2e-3), tol),
            Outcome::Converged
        );
    }
}
