//! Evenly spaced frequency grids: the sampling loop's seeds, candidates and verification points
//! (docs/design.md §3.5) and the CLI's `--band`/`--points` grids (§7).

/// `points` evenly spaced values over `band` = [lo, hi], both ends included:
/// f_k = lo + (hi − lo)·k / (points − 1), k = 0, …, points − 1, rounded in this order
/// ((hi − lo)·k, then the division, then the sum), so f_0 = lo and f_{points−1} = hi exactly.
/// One point is lo; zero points an empty grid.
///
/// ```
/// assert_eq!(sparsemor::grid::linspace([1.0, 3.0], 3), [1.0, 2.0, 3.0]);
/// assert_eq!(sparsemor::grid::linspace([1.0, 3.0], 1), [1.0]);
/// ```
pub fn linspace(band: [f64; 2], points: usize) -> Vec<f64> {
    if points == 1 {
        return vec![band[0]];
    }
    (0..points)
        .map(|k| band[0] + (band[1] - band[0]) * k as f64 / (points - 1) as f64)
        .collect()
}
