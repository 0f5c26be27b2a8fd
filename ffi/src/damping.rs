//! The damping of a model handle (docs/design.md §3.12, §6): structural damping given after
//! the model was created, and the split of the damping the reductions answer.
//!
//! With viscous damping D and structural damping H = ηK + K₄,
//! A(iω) = K + iH − ω²M + iωD (§3.1). The body fits D ≈ αM + βK and K₄ ≈ γM + η₄K and
//! keeps what is left, E = D − αM − βK and F = K₄ − γM − η₄K (§3.12):
//!
//! ```text
//! A(iω) = (1 + iη' + iωβ) K − (ω² − iωα − iγ) M + iωE + iF,   η' = η + η₄,
//! ```
//!
//! a shift of one real pencil when E = F = 0, that shift plus a Sherman–Morrison–Woodbury
//! correction of rank r when E and F live on few DoFs, and a factorization per frequency
//! otherwise. `sparsemor_model_damping_info` reports which.
//!
//! Entry points: `sparsemor_model_set_structural_damping`, `sparsemor_model_damping_info`.

use crate::error::{ffi_body, Failure, SparsemorStatus};
use crate::model::{csc_from_c, SparsemorCsc, SparsemorModel};
use crate::pool::in_pool;
use crate::scene::couple_scene;
use crate::util::{obj, obj_mut, write_out};
use sparsemor::body::Body;
use sparsemor::model::Structural;
use sparsemor::proportional::Split;

/// `SparsemorDampingInfo::kind`: no damping (D = 0, H = 0): A(iω) = K − ω²M is real.
pub const SPARSEMOR_DAMPING_NONE: u32 = 0;
/// `SparsemorDampingInfo::kind`: proportional to rounding, D = αM + βK and K₄ = γM + η₄K
/// (Rayleigh damping, a loss factor, a D file written as αM + βK): one shifted real pencil
/// answers every frequency (docs/design.md §3.10, §3.12).
pub const SPARSEMOR_DAMPING_PROPORTIONAL: u32 = 1;
/// `SparsemorDampingInfo::kind`: proportional but for a remainder of rank
/// `remainder_rank` on `remainder_dofs` DoFs (dashpots, bushings, a damped joint): the
/// shifted pencil plus a Sherman–Morrison–Woodbury correction (§3.12).
pub const SPARSEMOR_DAMPING_LOW_RANK: u32 = 2;
/// `SparsemorDampingInfo::kind`: a remainder on many DoFs (material-wise damping): one
/// linearized Krylov space answers every frequency (§3.13), from a complex factorization
/// when there is structural damping (η or K₄).
pub const SPARSEMOR_DAMPING_GENERAL: u32 = 3;

/// How a model's damping is answered (docs/design.md §3.12), from
/// `sparsemor_model_damping_info`: A(iω) = (1 + iη + iωβ)K − (ω² − iωα − iγ)M + the
/// remainder iωE + iF.
///
/// For `SPARSEMOR_DAMPING_GENERAL` with `remainder_dofs == SIZE_MAX` the fit was rejected
/// (more than half of D's or K₄'s entries off αM + βK, γM + η₄K, and off zero): α, β, η, γ
/// are then its last attempt and do not describe the damping; the responses come from the
/// exact A(iω) as for any `_GENERAL` damping. (A K₄ that is zero but for a few dampers has no proportional part
/// and a low-rank remainder.)
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SparsemorDampingInfo {
    /// `SPARSEMOR_DAMPING_NONE`, `_PROPORTIONAL`, `_LOW_RANK` or `_GENERAL`.
    pub kind: u32,
    /// Viscous, mass-proportional α (1/s) of the proportional part.
    pub alpha: f64,
    /// Viscous, stiffness-proportional β (s).
    pub beta: f64,
    /// Structural loss factor on K: the model's η plus the K-proportional part of K₄.
    pub eta: f64,
    /// Structural, mass-proportional γ (the M-proportional part of K₄).
    pub gamma: f64,
    /// Rank r of the low-rank remainder (`_LOW_RANK`; 0 otherwise).
    pub remainder_rank: usize,
    /// DoFs the remainder touches: |J| for `_LOW_RANK` and `_GENERAL` (`SIZE_MAX` for
    /// `_GENERAL` when the fit left more than half of the entries out: no proportional part
    /// to speak of); 0 otherwise.
    pub remainder_dofs: usize,
}

/// Gives the model structural (hysteretic) damping H = `eta`·K + K₄:
/// A(iω) = K + iH − ω²M + iωD (docs/design.md §3.1, §3.12), replacing any it had (a model
/// directory's `[structural]`, an earlier call); `eta` = 0 with `k4` = NULL removes it.
///
/// - `eta`: the loss factor on K (Nastran's G, ANSYS's DMPSTR), finite and >= 0.
/// - `k4`: NULL, or the structural damping matrix K₄ (Nastran's K4): N×N, symmetric, finite
///   (the `SparsemorCsc` checks, both storages).
///
/// Everything else of the handle stays: M, K, D, the nodes and rigid part, the scene, the
/// remote points and a general scene (`sparsemor_model_set_scene_general`), which is coupled
/// again from the new body (K₄' = TᵀHT; the same points, functionals and band), exactly as
/// setting the scene after this call would. A ROM made afterwards carries
/// K₄r = VᵀHV (`SPARSEMOR_MATRIX_K4R`) and Hr(iω) = Cr(Kr + iK₄r − ω²Mr + iωDr)⁻¹Br; ROMs
/// made before are not changed. On failure the handle is unchanged.
///
/// Cost: the body is prepared again (its matrices rebuilt in full storage once, the rigid
/// part detected again), and so is a general scene's coupled body; the next call that
/// factors repeats the symbolic analysis.
///
/// # Safety
/// `model` a live handle not used concurrently; `k4` NULL or a valid `SparsemorCsc` whose
/// arrays have the lengths it claims.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_set_structural_damping(
    model: *mut SparsemorModel,
    eta: f64,
    k4: *const SparsemorCsc,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj_mut(model, "model")? };
        if !(eta.is_finite() && eta >= 0.0) {
            return Err(Failure::arg(format!(
                "eta = {eta}: the structural loss factor must be finite and >= 0 \
                 (e.g. 0.02 for 2 % structural damping; 0 for none)"
            )));
        }
        let n = m.body.n();
        let k4 = if k4.is_null() {
            None
        } else {
            let what = "k4 (structural damping matrix K4)";
            let k4 = unsafe { csc_from_c(obj(k4, "k4")?, what)? };
            if k4.nrows() != n {
                return Err(Failure::arg(format!(
                    "{what} is {0}×{0} but the model has N = {n} DoFs: K4 must be N×N \
                     like M and K",
                    k4.nrows()
                )));
            }
            Some(k4)
        };
        let body = in_pool(1, || -> Result<Body, Failure> {
            // the library's checks (symmetry) name K4; the caller's argument is k4
            let named = |e: sparsemor::Error| {
                let f = Failure::from(e);
                Failure::new(f.status, format!("k4: {}", f.message))
            };
            let model = m
                .body
                .to_model()?
                .with_structural(Structural { eta, matrix: k4 })
                .map_err(named)?;
            Ok(Body::new(&model)?)
        })??;
        // a general scene: coupled again from the new body, as setting it again would
        let coupled = match &m.coupled {
            None => None,
            Some(c) => {
                let [ins, outs] = c.functionals.clone();
                Some(couple_scene(&body, &c.points, ins, outs, c.scene.band_hz)?)
            }
        };
        m.body = body;
        if coupled.is_some() {
            m.coupled = coupled;
        }
        Ok(())
    })
}

/// How the damping of the model the reductions work on (the coupled one while a general
/// scene is set) is answered (docs/design.md §3.12; see `SparsemorDampingInfo`): its kind,
/// the proportional part α, β, η, γ and the remainder's rank and DoFs. Computed when the
/// body was prepared; this call only reads it.
///
/// # Safety
/// `model` a live handle; `info_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_model_damping_info(
    model: *const SparsemorModel,
    info_out: *mut SparsemorDampingInfo,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj(model, "model")? };
        let pencil = m.active_body().pencil();
        let split = pencil.split();
        let p = split.proportional();
        let (kind, remainder_rank, remainder_dofs) = match split {
            Split::Proportional(_) if pencil.is_real() => (SPARSEMOR_DAMPING_NONE, 0, 0),
            Split::Proportional(_) => (SPARSEMOR_DAMPING_PROPORTIONAL, 0, 0),
            Split::LowRank(_, r) => (SPARSEMOR_DAMPING_LOW_RANK, r.rank(), r.dofs.len()),
            Split::General(_, dofs) => (SPARSEMOR_DAMPING_GENERAL, 0, *dofs),
        };
        let info = SparsemorDampingInfo {
            kind,
            alpha: p.alpha,
            beta: p.beta,
            eta: p.eta,
            gamma: p.gamma,
            remainder_rank,
            remainder_dofs,
        };
        unsafe { write_out(info_out, info, "info_out") }
    })
}
