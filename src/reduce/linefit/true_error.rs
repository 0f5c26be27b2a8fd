//! The ROM's true elastic error ε (paper eq. 23, docs/design.md §3.5, steps 3–4) wherever
//! the sampling loop knows the full model's response H1 at the outputs: ε(f) = ‖H1 − Hr‖_F /
//! ‖H1‖_F and its maximum over a set of points — at the sampled points ([`Sampled`], their
//! H1 kept), by full solves ([`errors_at`]), and on the candidate grid from the shifted
//! Krylov space's responses ([`grid_errors`], §3.10).

use crate::engine::Engine;
use crate::reduce::rom::Rom;
use crate::scene::Scene;
use crate::sweep::{ProgressFn, Response};
use crate::Result;
use faer::{c64, Mat, MatRef};

/// Every frequency absorbed into the loop's QR state, in the order of absorption, and H1 at
/// the outputs of each.
pub(super) struct Sampled {
    pub(super) freqs: Vec<f64>,
    pub(super) h1: Vec<(f64, Mat<c64>)>,
}

impl Sampled {
    /// `freqs` with their H1 `h`.
    pub(super) fn new(freqs: Vec<f64>, h: Vec<Mat<c64>>) -> Self {
        let h1 = freqs.iter().copied().zip(h).collect();
        Sampled { freqs, h1 }
    }

    /// Adds the absorbed `points` with their H1 `h`.
    pub(super) fn extend(&mut self, points: &[f64], h: Vec<Mat<c64>>) {
        self.h1.extend(points.iter().copied().zip(h));
        self.freqs.extend(points.iter().copied());
    }

    /// (f, H1) at each sampled point.
    pub(super) fn responses(&self) -> impl Iterator<Item = (f64, MatRef<'_, c64>)> {
        self.h1.iter().map(|(f, h)| (*f, h.as_ref()))
    }

    /// `rom`'s max true error at the sampled points.
    pub(super) fn error(&self, rom: &Rom) -> f64 {
        max_error(&rel_errs(rom, self.responses()))
    }
}

/// The true elastic error of `rom` at `freqs` (full solves): (frequency, ε) each.
pub(super) fn errors_at(
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

/// `rom`'s true elastic error at every candidate, from the shifted Krylov space's responses
/// at the outputs (docs/design.md §3.5, §3.10): `None` when no space answers (the residual
/// indicator is used instead); a candidate the space does not answer counts as infinite
/// error, so that it is solved.
pub(super) fn grid_errors(
    engine: &mut Engine<'_>,
    scene: &Scene,
    rom: &Rom,
    candidates: &[f64],
) -> Result<Option<Vec<f64>>> {
    let Some(h) =
        engine.rows_from_space(Response::Elastic, &scene.inputs, &scene.outputs, candidates)?
    else {
        return Ok(None);
    };
    let answered = rel_errs(
        rom,
        candidates
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
