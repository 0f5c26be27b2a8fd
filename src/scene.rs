//! The scene: what the simulation needs from the body (docs/design.md §1) — where forces act
//! (inputs, the columns of B), what is measured (outputs, the rows of C) and the band.

/// Inputs, outputs and frequency band of a reduction or sweep. DoF indices are 0-based.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// DoFs where unit forces act (columns of B).
    pub inputs: Vec<usize>,
    /// DoFs that are measured (rows of C).
    pub outputs: Vec<usize>,
    /// Frequency band of interest [f_lo, f_hi] in Hz.
    pub band_hz: [f64; 2],
}

impl Scene {
    /// Checks DoF indices against the model size `n` (in range, unique, non-empty) and the
    /// band (finite, 0 ≤ f_lo < f_hi). `what` names the source for the message.
    ///
    /// # Errors
    /// [`crate::Error::InvalidSetting`] naming the offending field and value.
    pub fn validate(&self, n: usize, what: &str) -> crate::Result<()> {
        check_dofs(&self.inputs, n, &format!("{what} inputs"))?;
        check_dofs(&self.outputs, n, &format!("{what} outputs"))?;
        let [lo, hi] = self.band_hz;
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > lo) {
            return Err(crate::Error::InvalidSetting(format!(
                "{what} band_hz = [{lo}, {hi}]: need finite 0 <= f_lo < f_hi"
            )));
        }
        Ok(())
    }
}

/// Checks a DoF list: non-empty, every index < n, no duplicates.
///
/// # Errors
/// [`crate::Error::DofOutOfRange`] naming `what`, the index and the valid range;
/// [`crate::Error::InvalidSetting`] for an empty list or a repeated DoF.
pub fn check_dofs(dofs: &[usize], n: usize, what: &str) -> crate::Result<()> {
    if dofs.is_empty() {
        return Err(crate::Error::InvalidSetting(format!(
            "{what}: empty DoF list"
        )));
    }
    let mut seen = vec![false; n];
    for &d in dofs {
        if d >= n {
            return Err(crate::Error::DofOutOfRange {
                what: what.to_string(),
                dof: d,
                n,
            });
        }
        if std::mem::replace(&mut seen[d], true) {
            return Err(crate::Error::InvalidSetting(format!(
                "{what}: DoF {d} appears twice"
            )));
        }
    }
    Ok(())
}

/// The band with f_lo = 0 moved to min(1 Hz, f_hi/2): H is infinite at 0 Hz on a free body,
/// and the elastic part is quasi-static below the first mode anyway.
pub fn positive_band(band: [f64; 2]) -> [f64; 2] {
    if band[0] > 0.0 {
        band
    } else {
        [1.0_f64.min(0.5 * band[1]), band[1]]
    }
}
