//! Craig–Bampton (docs/design.md §3.8): the boundary DoFs b (the interface) stay physical
//! coordinates, the interior i is described by static constraint modes and c fixed-interface
//! modes:
//!
//! ```text
//! V = Πᵀ [ I    0  ]     Ψ = −K_ii⁻¹ K_ib        (static constraint modes, n_b columns)
//!        [ Ψ   Φ_c ]     K_ii Φ_c = M_ii Φ_c Λ_c (the c lowest fixed-interface modes)
//! ```
//!
//! Sparse throughout: K_ii, M_ii and K_ib are sparse submatrices; K_ii is factored once — a
//! sparse Cholesky when it is positive definite, otherwise an LBLᵀ (faer, Bunch–Kaufman) — and
//! Ψ is solved in column blocks of [`BLOCK`] right-hand sides; Φ_c comes from the partial
//! eigensolver (§3.6) on the interior body (K_ii, M_ii) ([`Body::restricted`]: no nodes,
//! so no rigid part: the fixed interface holds the body). A free body needs no special case: its
//! rigid motions lie in span [I; Ψ] as soon as the boundary holds them (checked: V0 restricted
//! to the boundary rows must have rank 6). The ROM comes from the shared projection
//! ([`project`], §3.4); its coordinates are the n_b boundary DoFs ([`Rom::dofs`]) followed
//! by the c modal amplitudes.
//!
//! With a damping whose remainder after its proportional part lives on few DoFs (dashpots,
//! §3.12), the fixed-interface modes alone have no static response to the dampers' forces;
//! the basis then gains the residual vectors R = [0; K_ii⁻¹ U_i] of the remainder's force
//! patterns U (its rows on the interior), M_ii-orthogonalized against Φ_c and each other
//! (Nastran's residual vectors for viscous elements), after the modes.
//!
//! Entry point: [`reduce`].

use super::interface::Interface;
use super::projection::project;
use super::rom::{CraigBamptonReport, Provenance, Rom, Timing};
use crate::body::Body;
use crate::eigen::{eigenpairs, EigenOptions, Request};
use crate::factor::{Analysis, Backend, Cholesky};
use crate::pencil::Coefficient;
use crate::pool::resolve_threads;
use crate::scene::{check_dofs, Scene};
use crate::sparse::Csc;
use crate::{Error, Result};
use faer::{c64, Mat, MatMut, Par};
use std::time::Instant;

/// Right-hand sides of Ψ = −K_ii⁻¹K_ib solved at once: the dense block is N_i × BLOCK.
pub const BLOCK: usize = 64;

/// σ_min/σ_max of V0 on the boundary rows below this: the boundary does not hold the rigid
/// motions of a free body (K_ii singular).
pub const RIGID_HOLD_RTOL: f64 = 1e-8;

/// Settings of a Craig–Bampton reduction.
#[derive(Clone, Debug)]
pub struct CraigBamptonOptions {
    /// The boundary DoFs (explicit, or the outputs + k spread DoFs as for line-fitting).
    pub interface: Interface,
    /// c, the number of fixed-interface modes (0 = Guyan's static condensation).
    pub modes: usize,
    /// Keep V (N×n).
    pub keep_basis: bool,
    /// Eigensolver settings of the fixed-interface problem.
    pub eigen: EigenOptions,
    /// Threads of the factorization of K_ii and the block solves; 0 = all cores.
    pub threads: usize,
}

impl CraigBamptonOptions {
    /// Defaults (no basis kept, all threads, eigensolver shift scaled to `band_end_hz`) for a
    /// boundary and c modes.
    pub fn new(interface: Interface, modes: usize, band_end_hz: f64) -> Self {
        CraigBamptonOptions {
            interface,
            modes,
            keep_basis: false,
            eigen: EigenOptions::for_band(band_end_hz),
            threads: 0,
        }
    }
}

/// Reduces the body by Craig–Bampton for the scene's unit loads and outputs.
///
/// ```
/// use sparsemor::body::Body;
/// use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
/// use sparsemor::metrics::rom_eigenfrequencies;
/// use sparsemor::reduce::craig_bampton::{reduce, CraigBamptonOptions};
/// use sparsemor::reduce::interface::Interface;
///
/// let spec = BoxSpec::paper_bar();
/// let (model, scene) = (bar_model(&spec)?, paper_scene(&spec));
/// // boundary: the 9 output DoFs + 1 spread DoF (three collinear nodes alone do not hold
/// // the free bar's rotation about its axis); 4 fixed-interface modes: order 14
/// let opts = CraigBamptonOptions::new(Interface::OutputsPlus(1), 4, scene.band_hz[1]);
/// let rom = reduce(&Body::new(&model)?, &scene, &opts)?;
/// assert_eq!((rom.order(), rom.dofs.len()), (14, 10));
/// let f = rom_eigenfrequencies(&rom)?; // 6 rigid modes first, then the elastic ones
/// assert!(f[..6].iter().all(|f| f.abs() < 1e-2) && (f[6] - 142.9).abs() < 1.0, "{f:?}");
/// # Ok::<(), sparsemor::Error>(())
/// ```
///
/// # Errors
/// [`Error::InvalidSetting`] for bad or duplicate DoF lists, an empty boundary or one with
/// every DoF, more modes than interior DoFs, and a boundary that does not hold a free body's
/// rigid motions; [`Error::Singular`] when K_ii is singular (a constrained body whose boundary
/// does not hold it); the eigensolver's errors.
pub fn reduce(body: &Body, scene: &Scene, opts: &CraigBamptonOptions) -> Result<Rom> {
    let n_full = body.n();
    check_dofs(&scene.inputs, n_full, "inputs")?;
    check_dofs(&scene.outputs, n_full, "outputs")?;
    let boundary = opts.interface.resolve(body, &scene.outputs)?;
    check_dofs(&boundary, n_full, "boundary DoFs")?;
    if boundary.is_empty() || boundary.len() >= n_full {
        return Err(Error::InvalidSetting(format!(
            "Craig–Bampton needs 1..{} boundary DoFs (got {}): choose the interface DoFs",
            n_full - 1,
            boundary.len()
        )));
    }
    let n_i = n_full - boundary.len();
    let c = opts.modes;
    if c > n_i {
        return Err(Error::InvalidSetting(format!(
            "{c} fixed-interface modes asked but the interior has only {n_i} DoFs: use at most {n_i}"
        )));
    }
    check_holds_rigid_motion(body, &boundary)?;
    // interior index of each DoF (usize::MAX on the boundary), interior DoFs ascending
    let mut pos = vec![0usize; n_full];
    for &d in &boundary {
        pos[d] = usize::MAX;
    }
    let interior: Vec<usize> = (0..n_full).filter(|&d| pos[d] != usize::MAX).collect();
    for (k, &d) in interior.iter().enumerate() {
        pos[d] = k;
    }
    let t = Instant::now();
    let k_ib = body
        .pencil()
        .submatrix(Coefficient::Stiffness, &pos, &boundary);
    let inner_body = body.restricted(format!("{} (interior)", body.name()), &pos, &interior);
    let threads = resolve_threads(opts.threads);
    let par = if threads > 1 {
        Par::rayon(threads)
    } else {
        Par::Seq
    };
    // V in original DoF order: boundary columns [I; Ψ], then [0; Φ_c]
    let mut v = Mat::<f64>::zeros(n_full, boundary.len() + c);
    for (j, &d) in boundary.iter().enumerate() {
        v[(d, j)] = 1.0;
    }
    // the dampers' force patterns on the interior, solved with the same K_ii factor
    let mut dampers = body.pencil().remainder().map(|r| {
        let u = r.loads(n_full);
        Mat::<f64>::from_fn(n_i, r.rank(), |k, j| u[(interior[k], j)])
    });
    let statics = constraint_modes(
        &inner_body,
        &k_ib,
        &interior,
        v.as_mut(),
        dampers.as_mut(),
        par,
    )?;
    let statics_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (fixed_interface_hz, mode_residuals) = if c == 0 {
        (Vec::new(), Vec::new())
    } else {
        let modes = eigenpairs(&inner_body, Request::Lowest(c), &opts.eigen)?;
        for m in 0..c {
            for (k, &d) in interior.iter().enumerate() {
                v[(d, boundary.len() + m)] = modes.vectors[(k, m)];
            }
        }
        let hz = modes.lambdas.iter().map(|&l| crate::units::lambda_to_hz(l));
        (hz.collect(), modes.residuals)
    };
    let eigen_s = t.elapsed().as_secs_f64();
    let residual_vectors = match dampers {
        Some(r) => {
            let r = residual_vectors(&inner_body, r, v.as_ref(), &interior, boundary.len());
            let k = v.ncols();
            v.resize_with(n_full, k + r.ncols(), |_, _| 0.0);
            for j in 0..r.ncols() {
                for (i, &d) in interior.iter().enumerate() {
                    v[(d, k + j)] = r[(i, j)];
                }
            }
            r.ncols()
        }
        None => 0,
    };
    let t = Instant::now();
    let pr = project(body, scene, v.as_ref());
    let proj_s = t.elapsed().as_secs_f64();
    let mut warnings = Vec::new();
    if statics.pivot_ratio.is_some_and(|r| r < 1e-12) {
        warnings.push(format!(
            "K_ii is nearly singular (LBLᵀ pivot ratio {:.1e}): the boundary barely holds the body; add boundary DoFs",
            statics.pivot_ratio.unwrap_or(0.0)
        ));
    }
    let mut rom = Rom::from_projection(
        Provenance::CraigBampton(CraigBamptonReport {
            fixed_interface_hz,
            mode_residuals,
            factorization: statics.factorization.into(),
            pivot_ratio: statics.pivot_ratio,
            static_residual: statics.residual,
            residual_vectors,
        }),
        n_full,
        pr,
        boundary,
        scene,
        warnings,
        opts.keep_basis.then_some(v),
    );
    if body.rigid().is_some() {
        // span V holds the rigid motions, so Kr has exactly their 6 zero eigenvalues: say so
        // instead of the generic "not positive definite" warning, or what is wrong
        rom.warnings.retain(|w| !w.starts_with("Kr "));
        let ev = crate::dense::sym_eigenvalues(rom.kr.as_ref())
            .ok_or_else(|| Error::Factor("eigenvalues of Kr did not converge".into()))?;
        let top = ev.last().copied().unwrap_or(0.0);
        let zero = ev.iter().filter(|&&l| l.abs() <= 1e-10 * top).count();
        if zero != 6 || ev[0] < -1e-10 * top {
            rom.warnings.push(format!(
                "Kr of a free body should be positive semi-definite with exactly the 6 rigid modes in its null space; \
                 it has {zero} eigenvalues within 1e-10 of zero and the smallest is {:.3e} (largest {top:.3e})",
                ev[0]
            ));
        }
    }
    rom.timings = vec![
        Timing {
            phase: "constraint modes (K_ii factor + solves)".into(),
            seconds: statics_s,
        },
        Timing {
            phase: "fixed-interface modes".into(),
            seconds: eigen_s,
        },
        Timing {
            phase: "projection".into(),
            seconds: proj_s,
        },
    ];
    Ok(rom)
}

/// On a free body, the boundary must hold the rigid motions: V0 (N×6) restricted to the
/// boundary rows has full rank 6, otherwise K_ii is singular (a rigid motion leaves the
/// boundary at rest).
fn check_holds_rigid_motion(body: &Body, boundary: &[usize]) -> Result<()> {
    let Some(rb) = body.rigid() else {
        return Ok(());
    };
    let v0 = rb.modes();
    let v0b = Mat::<f64>::from_fn(boundary.len(), 6, |r, j| v0[(boundary[r], j)]);
    let s = v0b
        .singular_values()
        .map_err(|_| Error::Factor("SVD of the boundary rows of V0 did not converge".into()))?;
    let smax = s.iter().copied().fold(0.0, f64::max);
    let smin = if s.len() < 6 {
        0.0
    } else {
        s.iter().copied().fold(f64::INFINITY, f64::min)
    };
    if !(smin > RIGID_HOLD_RTOL * smax) {
        return Err(Error::InvalidSetting(format!(
            "the {} boundary DoFs do not hold the free body's rigid motions (rank of V0 on them < 6, \
             σ_min/σ_max = {:.1e}), so K_ii is singular: add boundary DoFs at three or more \
             non-collinear nodes (e.g. one more spread DoF)",
            boundary.len(),
            smin / smax
        )));
    }
    Ok(())
}

/// How the static constraint modes were computed.
struct Statics {
    factorization: &'static str,
    /// LBLᵀ: min/max |pivot|; Cholesky: none.
    pivot_ratio: Option<f64>,
    /// max_j ‖K_ii ψ_j + K_ib e_j‖ / ‖K_ib e_j‖ (columns with K_ib e_j ≠ 0).
    residual: f64,
}

/// Ψ = −K_ii⁻¹ K_ib into the interior rows of the first n_b columns of `v`: one
/// factorization of K_ii (Cholesky, or LBLᵀ when K_ii is not positive definite), solves in
/// column blocks of [`BLOCK`], and the relative residual of every column; `extra` (interior
/// rows) is overwritten with K_ii⁻¹ `extra` by the same factor.
fn constraint_modes(
    inner: &Body,
    k_ib: &Csc,
    interior: &[usize],
    mut v: MatMut<'_, f64>,
    extra: Option<&mut Mat<f64>>,
    par: Par,
) -> Result<Statics> {
    let pencil = inner.pencil();
    let sym = inner.symbolic()?;
    let n_i = interior.len();
    let nb = k_ib.ncols();
    let block = BLOCK.min(nb);
    let mut chol = Cholesky::with_rhs(pencil, sym.clone(), par, block, inner.factor_storage())?;
    let spd = chol.factor(pencil, 0.0, par).is_ok();
    let analysis;
    let mut lblt = None;
    if !spd {
        analysis = Analysis::with_symbolic(pencil, Backend::FaerLblt, block, || Ok(sym.clone()))?;
        let mut num = analysis.numeric(pencil)?;
        num.factor(pencil, 0.0, par).map_err(|e| match e {
            Error::Singular { detail, .. } => Error::Singular {
                freq_hz: 0.0,
                detail: format!(
                    "K_ii (the stiffness with the boundary DoFs held) is singular — {detail}; \
                     the boundary does not hold the body: add boundary DoFs"
                ),
            },
            e => e,
        })?;
        lblt = Some(num);
    }
    let mut residual = 0.0f64;
    for start in (0..nb).step_by(block) {
        let w = block.min(nb - start);
        // −K_ib[:, block] dense
        let mut x = Mat::<f64>::zeros(n_i, w);
        for j in 0..w {
            let col = k_ib.symbolic().row_idx_of_col_raw(start + j);
            for (&r, &val) in col.iter().zip(k_ib.val_of_col(start + j)) {
                x[(r, j)] = -val;
            }
        }
        match &mut lblt {
            None => chol.solve_block(x.as_mut(), par),
            Some(num) => {
                let mut z = Mat::<c64>::from_fn(n_i, w, |i, j| c64::new(x[(i, j)], 0.0));
                num.solve(z.as_mut(), par);
                x = Mat::from_fn(n_i, w, |i, j| z[(i, j)].re);
            }
        }
        // residual K_ii x + K_ib e_j, relative to ‖K_ib e_j‖
        let kx = pencil.mul(Coefficient::Stiffness, x.as_ref());
        for j in 0..w {
            let col = k_ib.symbolic().row_idx_of_col_raw(start + j);
            let mut r = kx.col(j).to_owned();
            let mut norm_b = 0.0f64;
            for (&row, &val) in col.iter().zip(k_ib.val_of_col(start + j)) {
                r[row] += val;
                norm_b += val * val;
            }
            if norm_b > 0.0 {
                residual = residual.max(r.norm_l2() / norm_b.sqrt());
            }
            for (k, &d) in interior.iter().enumerate() {
                v[(d, start + j)] = x[(k, j)];
            }
        }
    }
    if let Some(x) = extra {
        for start in (0..x.ncols()).step_by(block.max(1)) {
            let w = block.min(x.ncols() - start);
            let mut part = x.as_mut().subcols_mut(start, w);
            match &mut lblt {
                None => chol.solve_block(part.as_mut(), par),
                Some(num) => {
                    let mut z = Mat::<c64>::from_fn(n_i, w, |i, j| c64::new(part[(i, j)], 0.0));
                    num.solve(z.as_mut(), par);
                    part.copy_from(Mat::<f64>::from_fn(n_i, w, |i, j| z[(i, j)].re));
                }
            }
        }
    }
    Ok(Statics {
        factorization: if spd { "cholesky" } else { "lblt" },
        pivot_ratio: lblt.as_ref().map(|n| n.pivot_ratio()),
        residual,
    })
}

/// The residual vectors `r` (interior rows, K_ii⁻¹U_i) M_ii-orthogonalized against the
/// fixed-interface modes (the columns of `v` from `first_mode` on, on the interior rows) and
/// M_ii-orthonormalized among themselves (Gram–Schmidt twice), dropping a vector left with
/// less than 1e-8 of its M_ii-norm: the directions the modes do not hold.
fn residual_vectors(
    inner: &Body,
    r: Mat<f64>,
    v: faer::MatRef<'_, f64>,
    interior: &[usize],
    first_mode: usize,
) -> Mat<f64> {
    let n_i = interior.len();
    let pencil = inner.pencil();
    let modes = v.ncols() - first_mode;
    let mut basis = Mat::<f64>::from_fn(n_i, modes, |i, j| v[(interior[i], first_mode + j)]);
    let mut m_basis = pencil.mul(Coefficient::Mass, basis.as_ref());
    let first = basis.ncols();
    for j in 0..r.ncols() {
        let mut x = r.col(j).to_owned();
        let norm0 = {
            let mx = pencil.mul(Coefficient::Mass, x.as_mat());
            (x.transpose() * mx.col(0)).max(0.0).sqrt()
        };
        for _ in 0..2 {
            let c = m_basis.transpose() * &x;
            x -= &basis * &c;
        }
        let mx = pencil.mul(Coefficient::Mass, x.as_mat());
        let norm = (x.transpose() * mx.col(0)).max(0.0).sqrt();
        if !(norm > 1e-8 * norm0) {
            continue;
        }
        let k = basis.ncols();
        basis.resize_with(n_i, k + 1, |i, _| x[i] / norm);
        m_basis.resize_with(n_i, k + 1, |i, _| mx[(i, 0)] / norm);
    }
    basis.subcols(first, basis.ncols() - first).to_owned()
}
