//! SEREP (paper §3.1, eq. 6–13; docs/design.md §3.6): V = U_c U_cr⁺, where U_c (N×c) holds c
//! eigenvectors and U_cr its rows at the r retained DoFs; the pseudo-inverse comes from an
//! SVD of the small U_cr (r×c). The ROM's coordinates are the retained DoFs.
//!
//! With c = r and U_cr invertible, span V = span U_c and the ROM reproduces the c
//! eigenfrequencies exactly. With c > r, U_cr has rank ≤ r and the ROM cannot hold all c
//! modes; an ill-conditioned U_cr gives nearly rank-deficient Mr, Kr. Both are reported.
//!
//! The projection is done in two steps, V = U_c T with T = U_cr⁺: first on the modes
//! (U_cᵀMU_c, U_cᵀKU_c, … — N-sized work, well conditioned), then T by congruence
//! (Mr = Tᵀ(U_cᵀMU_c)T, …; r×r work). Mathematically this is VᵀMV, VᵀKV; numerically,
//! forming K V directly lets the rounding error of the sparse product (≈ ε·λ_max) reach the
//! ROM eigenvalues amplified by cond(U_cr): on the paper bar (c = r = 9 on its I/O DoFs,
//! cond 6.8e4) the ROM eigenfrequencies err by up to 1.7e-7 that way and by 2.6e-8 in two
//! steps, the limit of storing Mr, Kr in double precision for that U_cr (docs/design.md §3.6).
//!
//! Entry point: [`reduce`].

use super::projection::{project, Projected};
use super::rom::{Provenance, Rom, Timing};
use crate::body::Body;
use crate::dense::sym;
use crate::eigen::{eigenpairs, EigenOptions, Modes, Request};
use crate::scene::{check_dofs, Scene};
use crate::{Error, Result};
use faer::Mat;
use std::time::Instant;

/// cond(U_cr) above this is reported as ill-conditioned.
pub const ILL_CONDITIONED: f64 = 1e8;

/// Which modes SEREP keeps.
#[derive(Clone, Debug, PartialEq)]
pub enum ModeChoice {
    /// The c lowest deformation (non-rigid) modes.
    LowestDeformation(usize),
    /// These mode numbers, 1-based among all modes in ascending order, rigid ones included
    /// (on a free body modes 1–6 are rigid).
    Numbers(Vec<usize>),
}

/// Settings of a SEREP reduction.
#[derive(Clone, Debug)]
pub struct SerepOptions {
    /// The modes.
    pub modes: ModeChoice,
    /// Retained DoFs (the ROM coordinates); `None` = the outputs.
    pub retain: Option<Vec<usize>>,
    /// Keep V (N×r).
    pub keep_basis: bool,
    /// Eigensolver settings.
    pub eigen: EigenOptions,
}

/// Reduces the body by SEREP for the scene's unit loads and outputs.
///
/// ```
/// use sparsemor::body::Body;
/// use sparsemor::eigen::EigenOptions;
/// use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
/// use sparsemor::metrics::rom_eigenfrequencies;
/// use sparsemor::reduce::serep::{reduce, ModeChoice, SerepOptions};
///
/// let spec = BoxSpec::paper_bar();
/// let (model, scene) = (bar_model(&spec)?, paper_scene(&spec));
/// // c = r = 9: the 9 lowest deformation modes on the 9 output DoFs
/// let opts = SerepOptions {
///     modes: ModeChoice::LowestDeformation(9),
///     retain: None,
///     keep_basis: false,
///     eigen: EigenOptions::for_band(scene.band_hz[1]),
/// };
/// let rom = reduce(&Body::new(&model)?, &scene, &opts, None)?;
/// assert_eq!((rom.order(), rom.modes()), (9, &(7..=15).collect::<Vec<_>>()[..]));
/// let f = rom_eigenfrequencies(&rom)?; // the kept modes' frequencies, reproduced
/// assert!((f[0] - 142.9).abs() < 0.1, "{f:?}");
/// # Ok::<(), sparsemor::Error>(())
/// ```
///
/// `known` are eigenpairs the caller already has (the c lowest modes asked for, or more, in
/// ascending order as [`eigenpairs`] returns them); when they cover the modes chosen, no
/// eigensolve is run, otherwise the modes are computed ([`Request::Lowest`]).
///
/// # Errors
/// [`Error::InvalidSetting`] for c = 0, fewer modes than retained DoFs (c < r: Mr, Kr
/// singular), more modes than DoFs, bad or duplicate DoF lists, mode numbers out of range or
/// repeated; the eigensolver's errors.
pub fn reduce(
    body: &Body,
    scene: &Scene,
    opts: &SerepOptions,
    known: Option<&Modes>,
) -> Result<Rom> {
    let n_full = body.n();
    let (inputs, outputs) = (&scene.inputs, &scene.outputs);
    check_dofs(inputs, n_full, "inputs")?;
    check_dofs(outputs, n_full, "outputs")?;
    let retain = opts.retain.clone().unwrap_or_else(|| outputs.to_vec());
    check_dofs(&retain, n_full, "retained DoFs")?;
    let t = Instant::now();
    let n_rigid = if body.rigid().is_some() { 6 } else { 0 };
    let (request, pick): (usize, Box<dyn Fn(usize) -> Vec<usize>>) = match &opts.modes {
        ModeChoice::LowestDeformation(0) => {
            return Err(Error::InvalidSetting(
                "SEREP with 0 modes: choose c >= 1".into(),
            ))
        }
        ModeChoice::LowestDeformation(c) => {
            let c = *c;
            (c + n_rigid, Box::new(move |rig| (rig..rig + c).collect()))
        }
        ModeChoice::Numbers(v) => {
            if v.is_empty() || v.contains(&0) {
                return Err(Error::InvalidSetting(
                    "SEREP mode numbers are 1-based and the list must not be empty".into(),
                ));
            }
            if let Some(&k) = v.iter().find(|&&k| k > n_full) {
                return Err(Error::InvalidSetting(format!(
                    "SEREP mode number {k} is out of range (the model has modes 1..={n_full})"
                )));
            }
            if let Some(k) = (1..v.len()).find_map(|i| v[..i].contains(&v[i]).then_some(v[i])) {
                return Err(Error::InvalidSetting(format!(
                    "SEREP mode {k} appears twice in the mode list"
                )));
            }
            let v2: Vec<usize> = v.iter().map(|k| k - 1).collect();
            (
                v.iter().copied().max().unwrap_or(1),
                Box::new(move |_| v2.clone()),
            )
        }
    };
    let (c, r) = match &opts.modes {
        ModeChoice::LowestDeformation(c) => (*c, retain.len()),
        ModeChoice::Numbers(v) => (v.len(), retain.len()),
    };
    if c < r {
        return Err(Error::InvalidSetting(format!(
            "SEREP with c = {c} modes < r = {r} retained DoFs: V = U_c U_cr⁺ has rank <= {c}, so Mr and Kr \
             (r×r) would be singular; use at least {r} modes or retain at most {c} DoFs"
        )));
    }
    if request > n_full {
        return Err(Error::InvalidSetting(format!(
            "SEREP needs {request} modes but the model has only N = {n_full} DoFs"
        )));
    }
    let computed;
    let modes = match known {
        Some(m) if m.lambdas.len() >= request => m,
        _ => {
            computed = eigenpairs(body, Request::Lowest(request), &opts.eigen)?;
            &computed
        }
    };
    let eigen_s = t.elapsed().as_secs_f64();
    let chosen = pick(modes.rigid);
    if let Some(&k) = chosen.iter().find(|&&k| k >= modes.lambdas.len()) {
        return Err(Error::InvalidSetting(format!(
            "mode number {} is not available ({} modes computed)",
            k + 1,
            modes.lambdas.len()
        )));
    }
    let (c, r) = (chosen.len(), retain.len());
    let t = Instant::now();
    let u_cr = Mat::<f64>::from_fn(r, c, |i, j| modes.vectors[(retain[i], chosen[j])]);
    let svd = u_cr
        .thin_svd()
        .map_err(|_| Error::Factor("SVD of U_cr did not converge".into()))?;
    let s = svd.S();
    let smax = (0..s.dim()).map(|i| s[i]).fold(0.0, f64::max);
    let smin = (0..s.dim()).map(|i| s[i]).fold(f64::INFINITY, f64::min);
    let cond = smax / smin;
    let tol = smax * f64::EPSILON * r.max(c) as f64;
    // U_cr⁺ = V_s Σ⁺ U_sᵀ (c×r), truncating σ ≤ tol
    let pinv = Mat::<f64>::from_fn(c, r, |i, j| {
        (0..s.dim())
            .filter(|&k| s[k] > tol)
            .map(|k| svd.V()[(i, k)] * svd.U()[(j, k)] / s[k])
            .sum()
    });
    let u_c = Mat::<f64>::from_fn(n_full, c, |i, j| modes.vectors[(i, chosen[j])]);
    let mut warnings = Vec::new();
    if c > r {
        warnings.push(format!("c = {c} modes > r = {r} retained DoFs: U_cr has rank <= {r}, the ROM cannot reproduce all {c} modes"));
    }
    // NaN (a failed SVD) counts as ill-conditioned
    if cond.is_nan() || cond > ILL_CONDITIONED {
        warnings.push(format!("U_cr is ill-conditioned (cond {cond:.1e}): Mr and Kr may be nearly singular; choose other retained DoFs or modes"));
    }
    // V = U_c T with T = U_cr⁺: project on the modes, then apply T by congruence (see the
    // module doc) — the same matrices as projecting on V, without amplifying rounding by cond(T)
    let modal = project(body, scene, u_c.as_ref());
    let congruence = |a: &Mat<f64>| sym((pinv.transpose() * a * &pinv).as_ref());
    let pr = Projected {
        mr: congruence(&modal.mr),
        dr: congruence(&modal.dr),
        kr: congruence(&modal.kr),
        k4r: modal.k4r.as_ref().map(congruence),
        br: pinv.transpose() * &modal.br,
        cr: &modal.cr * &pinv,
    };
    let basis = opts.keep_basis.then(|| &u_c * &pinv);
    drop(u_c);
    let proj_s = t.elapsed().as_secs_f64();
    let mut rom = Rom::from_projection(
        Provenance::Serep {
            modes: chosen.iter().map(|k| k + 1).collect(),
            cond,
        },
        n_full,
        pr,
        retain,
        scene,
        warnings,
        basis,
    );
    rom.timings = vec![
        Timing {
            phase: "eigenpairs".into(),
            seconds: eigen_s,
        },
        Timing {
            phase: "pseudo-inverse + projection".into(),
            seconds: proj_s,
        },
    ];
    Ok(rom)
}
