//! Where line-fitting's extra interface DoFs and its reference frequencies go when the user
//! gives only their number (docs/design.md §3.3).

use crate::{Error, Result};

/// Relative offset δ of the reference points placed beside each resonance: f(1 ± δ).
pub const RESONANCE_OFFSET: f64 = 0.03;

/// `z` reference frequencies for the band from its resonances (the paper's Figure 4 rule,
/// made explicit): a point on each side of every in-band resonance f_j·(1 ± δ) (δ =
/// [`RESONANCE_OFFSET`]), the midpoint between consecutive resonances (where the
/// anti-resonances of driving-point FRFs lie), the midpoints between the band start and the
/// first resonance and between the last resonance and f_hi, and f_hi itself. Then, while
/// there are fewer than z points, the midpoint of the widest gap (band start included) is
/// added; while there are more, the later point of the closest pair is dropped. All points
/// are in (max(f_lo, 0), f_hi], so f = 0 is never used (a free body's A(0) is singular).
///
/// # Errors
/// [`Error::InvalidSetting`] for z = 0 or an empty band.
pub fn place_reference_frequencies(
    resonances_hz: &[f64],
    band_hz: [f64; 2],
    z: usize,
) -> Result<Vec<f64>> {
    let [lo, hi] = band_hz;
    if z == 0 || !(hi > lo && lo >= 0.0) {
        return Err(Error::InvalidSetting(format!(
            "reference points: need z >= 1 and a band 0 <= f_lo < f_hi (got z = {z}, {band_hz:?})"
        )));
    }
    let res: Vec<f64> = resonances_hz
        .iter()
        .copied()
        .filter(|&f| f > lo && f < hi)
        .collect();
    let mut pts = vec![hi];
    let mut prev = lo;
    for &f in &res {
        pts.extend([
            f * (1.0 - RESONANCE_OFFSET),
            f * (1.0 + RESONANCE_OFFSET),
            0.5 * (prev + f),
        ]);
        prev = f;
    }
    if !res.is_empty() {
        pts.push(0.5 * (prev + hi));
    }
    pts.retain(|&f| f > lo && f <= hi);
    pts.sort_by(f64::total_cmp);
    pts.dedup();
    while pts.len() < z {
        let mut best = (pts[0] - lo, 0);
        for k in 1..pts.len() {
            if pts[k] - pts[k - 1] > best.0 {
                best = (pts[k] - pts[k - 1], k);
            }
        }
        let left = if best.1 == 0 { lo } else { pts[best.1 - 1] };
        pts.insert(best.1, 0.5 * (left + pts[best.1]));
    }
    while pts.len() > z {
        let k = (1..pts.len())
            .min_by(|&a, &b| (pts[a] - pts[a - 1]).total_cmp(&(pts[b] - pts[b - 1])))
            .unwrap_or(0);
        pts.remove(k);
    }
    Ok(pts)
}
