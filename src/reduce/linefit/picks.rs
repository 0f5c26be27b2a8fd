//! Where the sampling loop's next step solves (docs/design.md §3.5, step 4): functions of
//! the candidate grid, the indicator Δ on it (or the ROM's true error ε there, from a
//! shifted Krylov space) and the frequencies already sampled.
//!
//! - [`pick_maxima`]: the largest local maxima of Δ, none within 1.01 grid steps of a
//!   sampled frequency ([`near_sampled`]), at most one per thread.
//! - [`largest_away`]: when every local maximum lies next to a sampled point, the largest Δ
//!   away from them — only before the first measurement or right after a step within tol.
//! - [`step_points`]: the step's points from the rules above, or none (the loop stagnates).
//! - [`above_tol`]: after a verification pass that found the converged ROM above tol, its
//!   worst points.
//! - [`max_away`]: the largest Δ away from the sampled points (the fit-limit test of
//!   [`super::stop::fit_limited`] made on the grid).

/// Whether a frequency is a sampled one or a grid neighbour of one (within 1.01 grid steps).
fn near_sampled<'a>(grid: &[f64], sampled: &'a [f64]) -> impl Fn(f64) -> bool + 'a {
    let h = if grid.len() > 1 {
        grid[1] - grid[0]
    } else {
        1.0
    };
    move |f: f64| sampled.iter().any(|&s| (s - f).abs() <= 1.01 * h)
}

/// Up to `k` largest local maxima of `delta` on `grid`, largest first, skipping sampled
/// frequencies and their grid neighbours.
pub(super) fn pick_maxima(grid: &[f64], delta: &[f64], sampled: &[f64], k: usize) -> Vec<f64> {
    let near = near_sampled(grid, sampled);
    let mut maxima: Vec<usize> = (0..grid.len())
        .filter(|&i| {
            let l = if i > 0 {
                delta[i - 1]
            } else {
                f64::NEG_INFINITY
            };
            let r = if i + 1 < grid.len() {
                delta[i + 1]
            } else {
                f64::NEG_INFINITY
            };
            delta[i] >= l && delta[i] >= r && delta[i].is_finite() && !near(grid[i])
        })
        .collect();
    maxima.sort_by(|&a, &b| delta[b].total_cmp(&delta[a]));
    maxima.into_iter().take(k).map(|i| grid[i]).collect()
}

/// The frequency of largest finite `delta` away from the sampled points, for a step whose
/// local maxima all lie next to a sampled point (Δ falls away from it, e.g. a band without
/// resonances). It is solved even when Δ there is below tol — convergence needs a
/// measurement, not an estimate — but only while nothing away from the seeds has been
/// measured (`measured` false) or the last step was within tol (`streak` ≥ 1: one more is
/// needed to converge). After a step above tol, a maximum next to a sampled point means the
/// fit is at its limit there: `None`, and the loop stagnates (grows).
pub(super) fn largest_away(
    grid: &[f64],
    delta: &[f64],
    sampled: &[f64],
    measured: bool,
    streak: usize,
) -> Option<f64> {
    if measured && streak == 0 {
        return None;
    }
    let near = near_sampled(grid, sampled);
    (0..delta.len())
        .filter(|&i| !near(grid[i]) && delta[i].is_finite())
        .max_by(|&a, &b| delta[a].total_cmp(&delta[b]))
        .map(|i| grid[i])
}

/// The largest `delta` away from the sampled points (0 when there is none; an infinite
/// value, a candidate the Krylov space did not answer, counts).
pub(super) fn max_away(grid: &[f64], delta: &[f64], sampled: &[f64]) -> f64 {
    let near = near_sampled(grid, sampled);
    (0..delta.len())
        .filter(|&i| !near(grid[i]))
        .map(|i| delta[i])
        .fold(0.0, f64::max)
}

/// The points a step solves: a failed verification's worst points (`forced`) when there are
/// any, else up to `k` largest maxima of `delta` ([`pick_maxima`]), else the largest value
/// away from the sampled points ([`largest_away`], by its rule on `measured` and
/// `streak`). `None` when there is none: more frequencies cannot help.
pub(super) fn step_points(
    forced: Vec<f64>,
    grid: &[f64],
    delta: &[f64],
    sampled: &[f64],
    k: usize,
    measured: bool,
    streak: usize,
) -> Option<Vec<f64>> {
    if !forced.is_empty() {
        return Some(forced);
    }
    let maxima = pick_maxima(grid, delta, sampled, k);
    if !maxima.is_empty() {
        return Some(maxima);
    }
    largest_away(grid, delta, sampled, measured, streak).map(|f| vec![f])
}

/// The points of a verification pass (frequency, ε) where the ROM is above `tol` and which
/// are not sampled yet, the worst first, at most `k`: the next step solves them instead of
/// the indicator's maxima.
pub(super) fn above_tol(errors: Vec<(f64, f64)>, tol: f64, sampled: &[f64], k: usize) -> Vec<f64> {
    let mut above: Vec<(f64, f64)> = errors
        .into_iter()
        .filter(|&(f, e)| e > tol && !sampled.contains(&f))
        .collect();
    above.sort_by(|a, b| b.1.total_cmp(&a.1));
    above.iter().take(k).map(|&(f, _)| f).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of 11 points 0, 10, …, 100 Hz with local maxima at 20 (0.5), 50 (0.9), 80
    /// (0.7) and the end 100 (0.6).
    fn grid_and_delta() -> (Vec<f64>, Vec<f64>) {
        let grid: Vec<f64> = (0..11).map(|i| 10.0 * f64::from(i)).collect();
        let delta = vec![0.1, 0.2, 0.5, 0.3, 0.4, 0.9, 0.2, 0.3, 0.7, 0.5, 0.6];
        (grid, delta)
    }

    #[test]
    fn maxima_come_largest_first_and_skip_sampled_neighbours() {
        let (grid, delta) = grid_and_delta();
        assert_eq!(
            pick_maxima(&grid, &delta, &[], 10),
            [50.0, 80.0, 100.0, 20.0]
        );
        assert_eq!(pick_maxima(&grid, &delta, &[], 2), [50.0, 80.0]);
        // 60 is sampled: its neighbour 50 (one grid step away) is skipped, 80 is not
        assert_eq!(pick_maxima(&grid, &delta, &[60.0], 2), [80.0, 100.0]);
        // an infinite value (a candidate the Krylov space did not answer) is no maximum
        let mut inf = delta.clone();
        inf[5] = f64::INFINITY;
        assert_eq!(pick_maxima(&grid, &inf, &[], 1), [80.0]);
    }

    #[test]
    fn the_largest_value_away_is_picked_only_before_a_measurement_or_after_one_within_tol() {
        let (grid, delta) = grid_and_delta();
        let sampled = [50.0, 80.0];
        assert_eq!(largest_away(&grid, &delta, &sampled, false, 0), Some(100.0));
        assert_eq!(largest_away(&grid, &delta, &sampled, true, 1), Some(100.0));
        assert_eq!(largest_away(&grid, &delta, &sampled, true, 0), None);
        assert_eq!(max_away(&grid, &delta, &sampled), 0.6);
        assert_eq!(max_away(&grid, &delta, &[]), 0.9);
    }

    /// Forced points come first; then the maxima; with every maximum next to a sampled
    /// point, the largest value away (100 Hz), unless a step above tol was measured.
    #[test]
    fn a_step_solves_the_forced_points_the_maxima_or_the_largest_value_away() {
        let (grid, delta) = grid_and_delta();
        let forced = vec![35.0, 65.0];
        assert_eq!(
            step_points(forced.clone(), &grid, &delta, &[], 2, true, 0),
            Some(forced)
        );
        assert_eq!(
            step_points(Vec::new(), &grid, &delta, &[], 2, true, 0),
            Some(vec![50.0, 80.0])
        );
        let sampled = [20.0, 50.0, 80.0, 100.0];
        assert_eq!(
            step_points(Vec::new(), &grid, &delta, &sampled, 2, false, 0),
            Some(vec![0.0])
        );
        assert_eq!(
            step_points(Vec::new(), &grid, &delta, &sampled, 2, true, 0),
            None
        );
    }

    #[test]
    fn a_failed_verification_forces_its_worst_unsampled_points() {
        let errors = vec![
            (10.0, 2e-3),
            (20.0, 5e-3),
            (30.0, 4e-4),
            (40.0, 9e-3),
            (50.0, 3e-3),
        ];
        // 40 Hz is sampled already; 30 Hz is within tol
        assert_eq!(above_tol(errors.clone(), 1e-3, &[40.0], 2), [20.0, 50.0]);
        assert_eq!(above_tol(errors, 1e-3, &[40.0], 8), [20.0, 50.0, 10.0]);
    }
}
