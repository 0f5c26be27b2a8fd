//! Unit conversions shared by every module (no dependencies, so no import cycles).

/// Frequency (Hz) of an eigenvalue λ = ω² of K φ = λ M φ: sign(λ)·√|λ| / 2π (a slightly
/// negative λ of a rigid mode gives a slightly negative frequency, not NaN).
pub fn lambda_to_hz(l: f64) -> f64 {
    l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI)
}

/// Eigenvalue λ = ω² = (2πf)² of a frequency f (Hz) ≥ 0.
pub fn hz_to_lambda(f: f64) -> f64 {
    (2.0 * std::f64::consts::PI * f).powi(2)
}

/// Angular frequency ω = 2πf of a frequency f (Hz).
pub fn hz_to_omega(f: f64) -> f64 {
    2.0 * std::f64::consts::PI * f
}
