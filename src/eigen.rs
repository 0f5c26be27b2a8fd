//! Partial eigenpairs K φ = λ M φ — only the ones needed (DESIGN.md §3.6).
//!
//! Shift-invert Krylov–Schur in the M-inner product: the operator S = (K − σM)⁻¹ M with
//! σ < 0 is self-adjoint in ⟨x, y⟩_M = xᵀMy, and K − σM is symmetric positive definite even
//! for a free body, so it is factored once by a sparse Cholesky (faer, AMD ordering). Its
//! eigenvalues θ = 1/(λ − σ) are largest for the λ closest to σ, i.e. the lowest modes
//! (rigid modes first). Each restart keeps the best Ritz vectors (thick restart): with full
//! M-orthogonalization (two Gram–Schmidt passes) the basis Q (N × m) is M-orthonormal and
//!
//! ```text
//! S Q_j = Q_j H_j + q_{j+1} h_{j+1}ᵀ,      residual of a Ritz pair (θ, Q y) = |h_{j+1}ᵀ y|.
//! ```
//!
//! Why our own Krylov–Schur and not faer's `partial_self_adjoint_eigen`: faer's routine works
//! in the Euclidean inner product, so it would need the Cholesky factor of M as well
//! (L⁻¹ (K − σM)⁻¹ L⁻ᵀ) — a second sparse factorization and 2 extra triangular solves per
//! step — whereas the M-inner product needs only a sparse product with M. Memory:
//! O(nnz(L) + N·m) with m = the Krylov dimension.
//!
//! "All modes up to f" is counted, not guessed: [`crate::factor::count_eigenvalues_below`]
//! gives the number of eigenvalues below (2πf)² from the inertia of K − (2πf)²M.
//!
//! Rigid modes are those with |λ| ≤ [`RIGID_RTOL`] · max_i K_ii/M_ii (a scale of the
//! largest eigenvalue); they are counted and reported separately.

use crate::factor::{count_eigenvalues_below, symbolic_cholesky};
use crate::model::Model;
use crate::pencil::Pencil;
use crate::sparse::mul_dense;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::LltRef;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Mat, MatRef, Par, Side};
use std::time::Instant;

/// |λ| ≤ RIGID_RTOL · max_i K_ii/M_ii marks a rigid-body mode.
pub const RIGID_RTOL: f64 = 1e-10;

/// Which eigenpairs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Request {
    /// The c lowest modes, rigid ones included.
    Lowest(usize),
    /// Every mode with frequency ≤ f_hi (Hz), counted exactly by inertia.
    UpTo(f64),
}

/// Settings of the eigensolver.
#[derive(Clone, Debug)]
pub struct EigenOptions {
    /// Shift σ < 0; `None` = −0.01·(2π f_hi)² with f_hi the request's bound or the model's
    /// band end.
    pub sigma: Option<f64>,
    /// Convergence: Ritz residual ≤ tol · θ.
    pub tol: f64,
    /// Krylov dimension; `None` = max(2·count + 20, 40), capped at N.
    pub krylov_dim: Option<usize>,
    /// Restart limit.
    pub max_restarts: usize,
}

impl Default for EigenOptions {
    fn default() -> Self {
        EigenOptions {
            sigma: None,
            tol: 1e-12,
            krylov_dim: None,
            max_restarts: 200,
        }
    }
}

/// What the eigensolver did.
#[derive(Clone, Debug, Default)]
pub struct EigenStats {
    /// Cholesky of K − σM (symbolic + numeric), s.
    pub factor_s: f64,
    /// Iterations, s.
    pub iterate_s: f64,
    /// Inertia count (for [`Request::UpTo`]), s.
    pub count_s: f64,
    /// Applications of S.
    pub solves: usize,
    /// Restarts.
    pub restarts: usize,
    /// Krylov dimension used.
    pub krylov_dim: usize,
    /// Shift used.
    pub sigma: f64,
    /// nnz of the Cholesky factor.
    pub factor_nnz: usize,
}

/// Eigenpairs in ascending order of λ.
#[derive(Clone, Debug)]
pub struct Modes {
    /// Eigenvalues λ = ω².
    pub lambdas: Vec<f64>,
    /// Eigenvectors (N × c), M-orthonormal.
    pub vectors: Mat<f64>,
    /// Relative residuals ‖Kφ − λMφ‖ / (‖Kφ‖ + |λ|‖Mφ‖).
    pub residuals: Vec<f64>,
    /// How many of them are rigid-body modes.
    pub rigid: usize,
    /// Measurements.
    pub stats: EigenStats,
}

impl Modes {
    /// Frequencies f = sign(λ)·√|λ| / 2π (Hz).
    pub fn freqs_hz(&self) -> Vec<f64> {
        self.lambdas
            .iter()
            .map(|&l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }
}

/// The eigenpairs of (K, M) asked for.
///
/// # Errors
/// [`Error::InvalidSetting`] for c = 0, c > N, σ ≥ 0, f ≤ 0; [`Error::Factor`] when
/// K − σM is not positive definite (σ not below the spectrum) or the iteration does not
/// converge within the restart limit.
pub fn eigenpairs(model: &Model, req: Request, opts: &EigenOptions) -> Result<Modes> {
    let n = model.n();
    let pencil = Pencil::new(model);
    let mut stats = EigenStats::default();
    let f_ref = match req {
        Request::UpTo(f) if f.is_finite() && f > 0.0 => f,
        Request::UpTo(f) => {
            return Err(Error::InvalidSetting(format!(
                "modes up to {f} Hz: need a finite bound > 0"
            )))
        }
        Request::Lowest(_) => model.scene.band_hz[1].max(1.0),
    };
    let sigma = opts
        .sigma
        .unwrap_or(-0.01 * (2.0 * std::f64::consts::PI * f_ref).powi(2));
    if !(sigma < 0.0) {
        return Err(Error::InvalidSetting(format!(
            "shift sigma = {sigma}: must be < 0 so that K - sigma M is positive definite"
        )));
    }
    let count = match req {
        Request::Lowest(c) => c,
        Request::UpTo(f) => {
            let t = Instant::now();
            let c = count_eigenvalues_below(&pencil, (2.0 * std::f64::consts::PI * f).powi(2))?;
            stats.count_s = t.elapsed().as_secs_f64();
            c
        }
    };
    if count == 0 {
        return Err(Error::InvalidSetting(match req {
            Request::UpTo(f) => format!("no mode at or below {f} Hz"),
            _ => "mode count 0: ask for at least one mode".into(),
        }));
    }
    if count > n {
        return Err(Error::InvalidSetting(format!(
            "{count} modes asked but the model has only N = {n} DoFs"
        )));
    }
    let m = opts
        .krylov_dim
        .unwrap_or((2 * count + 20).max(40))
        .min(n)
        .max(count.min(n));

    // factor K − σM once
    let t = Instant::now();
    let sym = symbolic_cholesky(&pencil)?;
    let mut vals = vec![0.0; pencil.nnz()];
    pencil.fill_shifted(sigma, &mut vals);
    let mut l = vec![0.0; sym.len_val()];
    let req_mem = sym
        .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
        .or(sym.solve_in_place_scratch::<f64>(1, Par::Seq));
    let mut buf = MemBuffer::try_new(req_mem)
        .map_err(|_| Error::Factor("cannot allocate the Cholesky workspace".into()))?;
    let a = SparseColMatRef::new(
        unsafe {
            SymbolicSparseColMatRef::new_unchecked(n, n, pencil.col_ptr(), None, pencil.row_idx())
        },
        &vals,
    );
    sym.factorize_numeric_llt(&mut l, a, Side::Lower, Default::default(), Par::Seq, MemStack::new(&mut buf), Default::default())
        .map_err(|e| Error::Factor(format!("K - sigma M (sigma = {sigma:.3e}) is not positive definite ({e:?}): is M positive definite and K positive semi-definite?")))?;
    stats.factor_s = t.elapsed().as_secs_f64();
    stats.factor_nnz = sym.len_val();
    let llt = LltRef::new(&sym, &l);
    let mass = model.mass.as_ref();
    let apply_s = |x: MatRef<'_, f64>, buf: &mut MemBuffer| -> Mat<f64> {
        let mut y = mul_dense(mass, x);
        llt.solve_in_place_with_conj(Conj::No, y.as_mut(), Par::Seq, MemStack::new(buf));
        y
    };
    let m_dot = |x: MatRef<'_, f64>, y: MatRef<'_, f64>| -> f64 {
        (x.transpose() * mul_dense(mass, y))[(0, 0)]
    };

    // Krylov–Schur
    let t = Instant::now();
    let mut q = Mat::<f64>::zeros(n, m + 1);
    let mut h = Mat::<f64>::zeros(m + 1, m);
    let mut seed = 0x2545f4914f6cdd1du64;
    let mut random = |q: &mut Mat<f64>, j: usize| {
        for i in 0..n {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            q[(i, j)] = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        }
    };
    random(&mut q, 0);
    let nrm = m_dot(q.as_ref().subcols(0, 1), q.as_ref().subcols(0, 1)).sqrt();
    for i in 0..n {
        q[(i, 0)] /= nrm;
    }
    let mut start = 0;
    let (theta, y) = loop {
        for j in start..m {
            let mut w = apply_s(q.as_ref().subcols(j, 1), &mut buf);
            stats.solves += 1;
            let norm_w0 = m_dot(w.as_ref(), w.as_ref()).sqrt();
            let mut beta = 0.0;
            for attempt in 0..2 {
                for _pass in 0..2 {
                    let mw = mul_dense(mass, w.as_ref());
                    let c = q.as_ref().subcols(0, j + 1).transpose() * &mw;
                    w -= q.as_ref().subcols(0, j + 1) * &c;
                    if attempt == 0 {
                        for i in 0..=j {
                            h[(i, j)] += c[(i, 0)];
                        }
                    }
                }
                beta = m_dot(w.as_ref(), w.as_ref()).sqrt();
                if beta > 1e-12 * norm_w0 {
                    break;
                }
                // invariant subspace found: continue with a fresh direction
                random(&mut w, 0);
                beta = 0.0;
            }
            h[(j + 1, j)] = if beta > 0.0 { beta } else { 0.0 };
            let s = m_dot(w.as_ref(), w.as_ref()).sqrt();
            for i in 0..n {
                q[(i, j + 1)] = w[(i, 0)] / s;
            }
        }
        let hm = Mat::from_fn(m, m, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
        let eig = hm
            .self_adjoint_eigen(Side::Lower)
            .map_err(|_| Error::Factor("dense Ritz eigenproblem did not converge".into()))?;
        // descending θ
        let order: Vec<usize> = (0..m).rev().collect();
        let theta: Vec<f64> = order.iter().map(|&i| eig.S()[i]).collect();
        let y = Mat::from_fn(m, m, |r, c| eig.U()[(r, order[c])]);
        let coupling = |c: usize| (0..m).map(|r| h[(m, r)] * y[(r, c)]).sum::<f64>().abs();
        let converged = (0..count).all(|c| coupling(c) <= opts.tol * theta[c].abs());
        if converged || m == n {
            break (theta, y);
        }
        if stats.restarts >= opts.max_restarts {
            return Err(Error::Factor(format!(
                "eigensolver: {count} modes not converged after {} restarts (Krylov dimension {m}); increase the Krylov dimension or the restart limit",
                stats.restarts
            )));
        }
        stats.restarts += 1;
        let keep = (count + (m - count) / 2).min(m - 1).max(count);
        let qy = q.as_ref().subcols(0, m) * y.as_ref().subcols(0, keep);
        let last = q.as_ref().col(m).to_owned();
        let mut hn = Mat::<f64>::zeros(m + 1, m);
        for c in 0..keep {
            hn[(c, c)] = theta[c];
            hn[(keep, c)] = (0..m).map(|r| h[(m, r)] * y[(r, c)]).sum();
        }
        q.as_mut().subcols_mut(0, keep).copy_from(&qy);
        q.as_mut().col_mut(keep).copy_from(&last);
        h = hn;
        start = keep;
    };
    stats.iterate_s = t.elapsed().as_secs_f64();
    stats.krylov_dim = m;
    stats.sigma = sigma;

    let take = count.min(m);
    let mut pairs: Vec<(f64, usize)> = (0..take).map(|c| (sigma + 1.0 / theta[c], c)).collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let vectors = Mat::from_fn(n, take, |i, c| {
        (0..m).map(|r| q[(i, r)] * y[(r, pairs[c].1)]).sum()
    });
    let lambdas: Vec<f64> = pairs.iter().map(|p| p.0).collect();
    let kphi = mul_dense(model.stiffness.as_ref(), vectors.as_ref());
    let mphi = mul_dense(mass, vectors.as_ref());
    let residuals = (0..take)
        .map(|c| {
            let (k, mm) = (kphi.col(c), mphi.col(c));
            (k - mm * lambdas[c]).norm_l2() / (k.norm_l2() + lambdas[c].abs() * mm.norm_l2())
        })
        .collect();
    let scale = (0..n)
        .map(|i| diag(&model.stiffness, i) / diag(&model.mass, i))
        .fold(0.0, f64::max);
    let rigid = lambdas
        .iter()
        .filter(|&&l| l.abs() <= RIGID_RTOL * scale)
        .count();
    Ok(Modes {
        lambdas,
        vectors,
        residuals,
        rigid,
        stats,
    })
}

fn diag(a: &crate::sparse::Csc, i: usize) -> f64 {
    let rows = a.symbolic().row_idx_of_col_raw(i);
    rows.binary_search(&i)
        .map(|p| a.val_of_col(i)[p])
        .unwrap_or(0.0)
}
