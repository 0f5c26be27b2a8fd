//! The N-independent error indicator of the sampling loop (docs/design.md §3.5, step 3).
//!
//! The residual of the ROM's reduced solution lifted to the full model,
//! Res(s) = PB − A(s) V X̃(s) with X̃ = Ar(s)⁻¹ Br and A(s) = s²M + sD + K, is
//! Res(s) = Z c(s) with Z = [PB, MV, DV, KV] (N × (p + 3n)) and c = [I; −s²X̃; −sX̃; −X̃];
//! with structural damping H (§3.12) Z gains HV and c gains −iX̃.
//! With the thin QR Z = Q R (done once per ROM), ‖Res(s)‖_F = ‖R c(s)‖_F — the QR form of
//! the Gram identity ‖Res‖² = tr(cᴴ ZᵀZ c), without its loss of half the digits. The indicator
//! is Δ(s) = ‖Res(s)‖_F / ‖PB‖_F; each evaluation costs O((p + 3n)² p), independent of N.

use crate::body::Body;
use crate::pencil::Coefficient;
use crate::reduce::rom::Rom;
use crate::{Error, Result};
use faer::{c64, Mat};

/// The residual indicator of one ROM; see the module doc.
pub struct Indicator {
    r: Mat<f64>,
    p: usize,
    norm_pb: f64,
}

impl Indicator {
    /// Forms Z = [PB, MV, DV, KV] for the ROM's V (which must be kept) and its thin QR. P is
    /// the body's inertia-relief projector (identity on a constrained body).
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] when the ROM has no basis.
    pub fn new(body: &Body, rom: &Rom) -> Result<Self> {
        let v = rom
            .basis
            .as_ref()
            .ok_or_else(|| Error::InvalidSetting("the indicator needs the ROM's basis V".into()))?;
        let pencil = body.pencil();
        let (n_full, n, p) = (body.n(), v.ncols(), rom.inputs.len());
        let pb = body.elastic_load(&rom.inputs);
        let mv = pencil.mul(Coefficient::Mass, v.as_ref());
        let kv = pencil.mul(Coefficient::Stiffness, v.as_ref());
        let dv = pencil.damping_term(&mv, &kv, |d| d(v.as_ref()));
        let hv = pencil.structural_term(&kv, || pencil.mul(Coefficient::Structural, v.as_ref()));
        let blocks = [Some(&mv), Some(&dv), Some(&kv), hv.as_ref()];
        let blocks: Vec<&Mat<f64>> = blocks.into_iter().flatten().collect();
        let w = p + blocks.len() * n;
        let z = Mat::<f64>::from_fn(n_full, w, |i, j| {
            if j < p {
                pb[(i, j)]
            } else {
                blocks[(j - p) / n][(i, (j - p) % n)]
            }
        });
        let norm_pb = z.as_ref().subcols(0, p).norm_l2();
        let r = z.qr().thin_R().to_owned();
        Ok(Indicator { r, p, norm_pb })
    }

    /// Δ(f) = ‖PB − A(iω) V X̃‖_F / ‖PB‖_F.
    pub fn eval(&self, rom: &Rom, f_hz: f64) -> f64 {
        let w = 2.0 * std::f64::consts::PI * f_hz;
        let n = rom.order();
        let x = rom.reduced_response(w);
        // c = [I; −s²X̃; −sX̃; −X̃; −iX̃] with s = iω: −s² = ω², −s = −iω
        let factors = [
            c64::new(w * w, 0.0),
            c64::new(0.0, -w),
            c64::new(-1.0, 0.0),
            c64::new(0.0, -1.0),
        ];
        let c = Mat::<c64>::from_fn(self.r.ncols(), self.p, |i, j| {
            if i < self.p {
                c64::new(if i == j { 1.0 } else { 0.0 }, 0.0)
            } else {
                x[((i - self.p) % n, j)] * factors[(i - self.p) / n]
            }
        });
        let rc = Mat::<c64>::from_fn(self.r.nrows(), self.r.ncols(), |i, j| {
            c64::new(self.r[(i, j)], 0.0)
        }) * &c;
        rc.norm_l2() / self.norm_pb
    }
}
