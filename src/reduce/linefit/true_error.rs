//! The ROM's true elastic error ε (paper eq. 23, docs/design.md §3.5, step 4) where the
//! sampling loop knows the full model's response H1 at the outputs: ε(f) = ‖H1 − Hr‖_F /
//! ‖H1‖_F, and its maximum over a set of points.

use crate::reduce::rom::Rom;
use faer::{c64, MatRef};

/// (f, ‖H1 − Hr‖_F / ‖H1‖_F) at each (f, H1), the ROM evaluated at all of them at once
/// ([`Rom::transfers`]).
pub(super) fn rel_errs<'h>(
    rom: &Rom,
    points: impl IntoIterator<Item = (f64, MatRef<'h, c64>)>,
) -> Vec<(f64, f64)> {
    let (freqs, h1): (Vec<f64>, Vec<MatRef<'h, c64>>) = points.into_iter().unzip();
    freqs
        .iter()
        .zip(&h1)
        .zip(rom.transfer_differences(&freqs, &h1))
        .map(|((&f, h1), diff)| (f, diff / h1.norm_l2()))
        .collect()
}

/// The largest ε of (f, ε) pairs, 0 for none (a NaN ε is passed over).
pub(super) fn max_error(errors: &[(f64, f64)]) -> f64 {
    errors.iter().map(|e| e.1).fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_max_error_passes_over_nan_and_is_zero_for_none() {
        assert_eq!(max_error(&[]), 0.0);
        assert_eq!(
            max_error(&[(1.0, 2e-3), (2.0, f64::NAN), (3.0, 5e-3)]),
            5e-3
        );
    }
}
