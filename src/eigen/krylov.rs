//! Krylov–Schur on S = (K − σM)⁻¹ M in the M-inner product (the default backend).
//!
//! Each restart keeps the best Ritz vectors (thick restart): with full M-orthogonalization
//! (two classical Gram–Schmidt passes) the basis Q (N × m) is M-orthonormal and
//!
//! ```text
//! S Q_j = Q_j H_j + q_{j+1} h_{j+1}ᵀ,      residual of a Ritz pair (θ, Q y) = |h_{j+1}ᵀ y|.
//! ```

use super::{random_vector, EigenOptions, EigenStats, ShiftInvert};
use crate::{Error, Result};
use faer::{Mat, MatRef, Side};

/// The `count` eigenpairs of (K, M) closest to σ with a Krylov dimension `m` (count ≤ m ≤ N):
/// (λ, M-orthonormal vectors), in no particular order.
pub(super) fn solve(
    op: &mut ShiftInvert<'_>,
    count: usize,
    m: usize,
    opts: &EigenOptions,
    stats: &mut EigenStats,
) -> Result<(Vec<f64>, Mat<f64>)> {
    let n = op.n();
    let mut q = Mat::<f64>::zeros(n, m + 1);
    let mut h = Mat::<f64>::zeros(m + 1, m);
    let (mut w, mut mw) = (Mat::<f64>::zeros(n, 1), Mat::<f64>::zeros(n, 1));
    // M-norm of w (overwrites mw with M w)
    let m_norm = |op: &ShiftInvert<'_>, w: MatRef<'_, f64>, mw: &mut Mat<f64>| -> f64 {
        op.mass_mul(w, mw.as_mut());
        (w.transpose() * mw.as_ref())[(0, 0)].max(0.0).sqrt()
    };
    w.copy_from(random_vector(n, 0));
    let nrm = m_norm(op, w.as_ref(), &mut mw);
    q.as_mut().col_mut(0).copy_from(w.col(0) / nrm);
    let mut start = 0;
    let (theta, y) = loop {
        for j in start..m {
            op.apply(q.as_ref().subcols(j, 1), w.as_mut());
            stats.solves += 1;
            let norm_w0 = m_norm(op, w.as_ref(), &mut mw);
            let basis = q.as_ref().subcols(0, j + 1);
            let c = orthogonalize(op, basis, &mut w, &mut mw);
            for i in 0..=j {
                h[(i, j)] = c[i];
            }
            let beta = m_norm(op, w.as_ref(), &mut mw);
            if beta > 1e-12 * norm_w0 {
                h[(j + 1, j)] = beta;
                q.as_mut().col_mut(j + 1).copy_from(w.col(0) / beta);
            } else {
                // invariant subspace found (S q_j ∈ span Q): h_{j+1,j} = 0, continue with a
                // fresh direction M-orthogonal to Q
                h[(j + 1, j)] = 0.0;
                w.copy_from(random_vector(n, j as u64 + 1));
                op.mass_mul(w.as_ref(), mw.as_mut());
                orthogonalize(op, basis, &mut w, &mut mw);
                // s = 0 only when Q already spans R^N (m = N, last step): q_{m} stays 0
                let s = m_norm(op, w.as_ref(), &mut mw);
                if s > 0.0 {
                    q.as_mut().col_mut(j + 1).copy_from(w.col(0) / s);
                }
            }
        }
        let hm = Mat::from_fn(m, m, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
        let eig = hm
            .self_adjoint_eigen(Side::Lower)
            .map_err(|_| Error::Factor("dense Ritz eigenproblem did not converge".into()))?;
        // descending θ
        let theta: Vec<f64> = (0..m).rev().map(|i| eig.S()[i]).collect();
        let y = Mat::from_fn(m, m, |r, c| eig.U()[(r, m - 1 - c)]);
        let coupling = |c: usize| (0..m).map(|r| h[(m, r)] * y[(r, c)]).sum::<f64>();
        let converged = (0..count).all(|c| coupling(c).abs() <= opts.tol * theta[c].abs());
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
            hn[(keep, c)] = coupling(c);
        }
        q.as_mut().subcols_mut(0, keep).copy_from(&qy);
        q.as_mut().col_mut(keep).copy_from(&last);
        h = hn;
        start = keep;
    };
    let lambdas = theta[..count].iter().map(|&t| op.sigma + 1.0 / t).collect();
    let vectors = q.as_ref().subcols(0, m) * y.as_ref().subcols(0, count);
    Ok((lambdas, vectors))
}

/// Two classical Gram–Schmidt passes in the M-inner product: w ← w − Q c with c = Qᵀ M w,
/// accumulated over both passes (returned). On entry `mw` holds M w; on exit it is stale.
fn orthogonalize(
    op: &ShiftInvert<'_>,
    basis: MatRef<'_, f64>,
    w: &mut Mat<f64>,
    mw: &mut Mat<f64>,
) -> Vec<f64> {
    let mut total = vec![0.0; basis.ncols()];
    for pass in 0..2 {
        if pass > 0 {
            op.mass_mul(w.as_ref(), mw.as_mut());
        }
        let c = basis.transpose() * &*mw;
        *w -= basis * &c;
        for (t, i) in total.iter_mut().zip(0..) {
            *t += c[(i, 0)];
        }
    }
    total
}
