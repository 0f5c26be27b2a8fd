//! Fixed-precision iterative refinement of the solves of a sparse symmetric factorization
//! (docs/design.md §3.1).
//!
//! A supernodal LBLᵀ pivots inside each supernode only, so where a diagonal block is nearly
//! singular — an interior shift of the eigensolver, a frequency next to a lightly damped
//! resonance — a solve's backward error rises above ε; and where A is ill-conditioned, even a
//! backward error of a few ε is a large forward error. As PARDISO does after its perturbed
//! pivots and LAPACK's xGERFS for any solve, the solution is refined with the exact matrix,
//! x ← x + A⁻¹(b − A x), at most [`MAX_REFINEMENTS`] steps, while a backward error says it
//! pays ([`Stop`]). Refinement in working precision drives the backward error to ~ε; it does
//! not lower the forward error below about cond(A)·ε, which the sweep's probe then measures.

use super::pattern::{self, Scalar};
use faer::{c64, Mat, MatMut, Par};

/// At most this many refinement steps per solve (each one solve and one product with A).
pub const MAX_REFINEMENTS: usize = 3;

/// The componentwise backward error at which refinement stops: 4ε. xGERFS stops at ε/2 or
/// when a step does not halve the error, but the error of a refined sparse solve settles at
/// 3–7e-16 (2–3ε; the residual's own rounding), so that rule would take one more solve and
/// one more residual every time to find no halving. On the 10⁶-DoF bar (β = 1e-5, ten
/// columns; 5, 20 and 300 Hz) such a second step leaves the backward error where it is and
/// moves the probe errors only within the noise of the conditioning floor (at 5 and 20 Hz to
/// 1.1–1.7e-6, above the default probe tolerance), for about a third of the frequency's solve
/// time (docs/design.md §3.1).
pub const BACKWARD_ERROR_FLOOR: f64 = 4.0 * f64::EPSILON;

/// When to take another refinement step; "worst" is the largest backward error over the
/// columns.
#[derive(Clone, Copy, Debug)]
pub(super) enum Stop {
    /// While the normwise backward error ‖b − A x‖∞ / (‖A‖∞ ‖x‖∞ + ‖b‖∞) exceeds `above`:
    /// a cheap test for solves that are backward stable unless the factor grew.
    Normwise {
        /// ‖A‖∞ ([`pattern::symmetric_norm_inf`]).
        norm_inf: f64,
        /// The threshold.
        above: f64,
    },
    /// LAPACK xGERFS's rule with a floor: while the componentwise backward error
    /// maxᵢ |b − A x|ᵢ / (|A||x| + |b|)ᵢ exceeds [`BACKWARD_ERROR_FLOOR`] and halved in the
    /// last step. The componentwise error sees what the normwise one hides on smooth
    /// solutions: on the 10⁶-DoF bar at 5 Hz (β = 1e-5) unrefined point-load responses have
    /// normwise 3e-16, componentwise 1–3e-15 and a forward error of 1.2e-4, which refinement
    /// cuts to the conditioning floor, ~1e-6 (docs/design.md §3.1).
    Componentwise,
}

/// The buffers of [`refine`] (the residual's), kept by the caller between calls (a sweep
/// worker's factorization, an interior shift) so refinements allocate once, not per solve.
pub(super) type Buffers<T> = pattern::ResidualScratch<T>;

/// Refines the solution `x` of A x = b as the module doc says, for the symmetric A given by
/// its lower triangle `a`; `b` writes the right-hand sides into the block it is given (once
/// per step, into the residual's buffer: the caller keeps no N × k copy of b for this);
/// `solve` applies A⁻¹ in place; `buffers` are reused between calls. Returns the steps
/// taken; fewer than [`MAX_REFINEMENTS`] means the refinement ended on a residual of the
/// solution it returns, so with [`Stop::Componentwise`] the buffers'
/// [`pattern::ResidualScratch::column_errors`] are that solution's backward errors.
pub(super) fn refine<T: Scalar>(
    a: pattern::Lower<'_, impl Fn(usize) -> T + Sync>,
    stop: Stop,
    b: impl Fn(MatMut<'_, T>),
    mut x: MatMut<'_, T>,
    mut solve: impl FnMut(MatMut<'_, T>),
    buffers: &mut Buffers<T>,
    par: Par,
) -> usize {
    let (n, k) = (x.nrows(), x.ncols());
    let mut last = f64::INFINITY;
    for step in 0..MAX_REFINEMENTS {
        b(buffers.block(n, k));
        let again = match stop {
            Stop::Normwise { norm_inf, above } => {
                let b_norms: Vec<f64> = buffers.block(n, k).col_iter().map(max_abs1).collect();
                pattern::symmetric_residual(a, x.as_ref(), false, buffers, par);
                let worst = b_norms
                    .iter()
                    .zip(buffers.block(n, k).col_iter().zip(x.as_ref().col_iter()))
                    .map(|(&bc, (rc, xc))| max_abs1(rc) / (norm_inf * max_abs1(xc) + bc))
                    .fold(0.0, f64::max);
                worst > above
            }
            Stop::Componentwise => {
                let worst = pattern::symmetric_residual(a, x.as_ref(), true, buffers, par);
                let again = worst > BACKWARD_ERROR_FLOOR && 2.0 * worst <= last;
                last = worst;
                again
            }
        };
        if !again {
            return step;
        }
        let mut r = buffers.block(n, k);
        solve(r.as_mut());
        x += &r;
    }
    MAX_REFINEMENTS
}

/// Krylov dimension of [`gmres`]: its basis holds N × (this + 1) values per column.
pub const GMRES_DIM: usize = 12;

/// Cycles of [`gmres`] per column at most (each of up to [`GMRES_DIM`] solves).
pub const GMRES_CYCLES: usize = 2;

/// GMRES on A x = b right-preconditioned by the factorization (`solve` applies its inverse),
/// from the solution `x` that [`refine`] left, column by column; for where refinement does
/// not converge. Why it converges where refinement does not: a factor with k perturbed
/// pivots (the LDLᵀ's static pivoting) is M = A + E with E of rank k, so AM⁻¹ = I − EM⁻¹
/// differs from I by rank k and GMRES is exact after k + 1 steps, however far from 1 the
/// spectrum of EM⁻¹ lies, which decides refinement (Arioli, Duff, Gratton and Pralet, "A
/// note on GMRES preconditioned by a perturbed LDLᵀ decomposition with static pivoting",
/// SIAM J. Sci. Comput. 29, 2007; the remedy of MA57 and PARDISO). Modified Gram–Schmidt
/// GMRES is backward stable (Paige, Rozložník and Strakoš 2006). Complex Givens rotations
/// keep the least-squares residual ‖r‖₂ of each step, and a cycle stops when it is
/// ε(‖A‖∞‖x‖₂ + ‖b‖₂) or at [`GMRES_DIM`] steps; the correction M⁻¹V y costs one more solve.
///
/// Returns the solves taken and whether every column stopped at its target (docs/design.md
/// §3.1). Memory: the basis, N × ([`GMRES_DIM`] + 1), and b, N × k.
pub(super) fn gmres<F: Fn(usize) -> c64 + Sync>(
    a: pattern::Lower<'_, F>,
    b: impl Fn(MatMut<'_, c64>),
    mut x: MatMut<'_, c64>,
    mut solve: impl FnMut(MatMut<'_, c64>),
    buffers: &mut Buffers<c64>,
    par: Par,
) -> (usize, bool) {
    let (n, k) = (x.nrows(), x.ncols());
    let norm_a = pattern::symmetric_norm_inf(a.pencil, a.entry);
    let mut rhs = Mat::<c64>::zeros(n, k);
    b(rhs.as_mut());
    let mut basis = Mat::<c64>::zeros(n, GMRES_DIM + 1);
    // one N-vector for M⁻¹v of a step and for the correction M⁻¹V y of a cycle
    let mut z = Mat::<c64>::zeros(n, 1);
    let mut solves = 0;
    let mut converged = true;
    for c in 0..k {
        let target = f64::EPSILON * (norm_a * x.as_ref().col(c).norm_l2() + rhs.col(c).norm_l2());
        // each cycle starts from the residual r = b − A x of the column, and the last one's
        // result is judged by its residual
        let mut done = false;
        for cycle in 0..=GMRES_CYCLES {
            buffers.block(n, 1).copy_from(rhs.as_ref().subcols(c, 1));
            pattern::symmetric_residual(a, x.as_ref().subcols(c, 1), false, buffers, par);
            let beta = buffers.block(n, 1).col(0).norm_l2();
            done = beta <= target;
            if done || cycle == GMRES_CYCLES {
                break;
            }
            let mut v0 = basis.as_mut().col_mut(0);
            v0.copy_from(buffers.block(n, 1).col(0));
            v0 *= faer::Scale(c64::new(1.0 / beta, 0.0));
            let (steps, y) = arnoldi(
                a, &mut basis, &mut z, beta, target, &mut solve, buffers, par,
            );
            // x += M⁻¹ V y
            z.copy_from(basis.as_ref().subcols(0, y.nrows()) * &y);
            solve(z.as_mut());
            solves += steps + 1;
            let mut xc = x.as_mut().subcols_mut(c, 1);
            xc += &z;
        }
        converged &= done;
    }
    (solves, converged)
}

/// One GMRES cycle from the unit vector in `basis`'s first column, ‖r₀‖₂ = `beta`: Arnoldi
/// on A M⁻¹ with two passes of modified Gram–Schmidt, the Hessenberg matrix reduced by
/// complex Givens rotations as it grows; stops when the residual estimate is ≤ `target`, on
/// a breakdown (the space is invariant: exact) or at [`GMRES_DIM`] steps. Returns the solves
/// taken and y, the coefficients of the correction M⁻¹V y.
#[allow(clippy::too_many_arguments)]
fn arnoldi<F: Fn(usize) -> c64 + Sync>(
    a: pattern::Lower<'_, F>,
    basis: &mut Mat<c64>,
    z: &mut Mat<c64>,
    beta: f64,
    target: f64,
    solve: &mut impl FnMut(MatMut<'_, c64>),
    buffers: &mut Buffers<c64>,
    par: Par,
) -> (usize, Mat<c64>) {
    let n = basis.nrows();
    let zero = c64::new(0.0, 0.0);
    let mut h = Mat::<c64>::zeros(GMRES_DIM + 1, GMRES_DIM);
    let mut rotations: Vec<(f64, c64)> = Vec::with_capacity(GMRES_DIM);
    let mut g = vec![zero; GMRES_DIM + 1];
    g[0] = c64::new(beta, 0.0);
    let mut steps = 0;
    while steps < GMRES_DIM {
        let j = steps;
        // the residual of x = M⁻¹ v_j against b = 0 is −A M⁻¹ v_j: w = −(that), built in
        // the next basis column
        z.copy_from(basis.as_ref().subcols(j, 1));
        solve(z.as_mut());
        steps += 1;
        buffers.block(n, 1).fill(zero);
        pattern::symmetric_residual(a, z.as_ref(), false, buffers, par);
        let (earlier, mut rest) = basis.as_mut().split_at_col_mut(j + 1);
        let earlier = earlier.as_ref();
        let mut w = rest.as_mut().col_mut(0);
        w.copy_from(buffers.block(n, 1).col(0));
        w *= faer::Scale(c64::new(-1.0, 0.0));
        for _ in 0..2 {
            for i in 0..=j {
                let hij = earlier.col(i).adjoint() * w.as_ref();
                h[(i, j)] += hij;
                w.as_mut()
                    .iter_mut()
                    .zip(earlier.col(i).iter())
                    .for_each(|(w, &v)| *w -= v * hij);
            }
        }
        let norm = w.norm_l2();
        h[(j + 1, j)] = c64::new(norm, 0.0);
        if norm > 0.0 {
            w *= faer::Scale(c64::new(1.0 / norm, 0.0));
        }
        for (i, &(cs, sn)) in rotations.iter().enumerate() {
            let (u, v) = (h[(i, j)], h[(i + 1, j)]);
            h[(i, j)] = u * cs + sn * v;
            h[(i + 1, j)] = v * cs - sn.conj() * u;
        }
        let (u, v) = (h[(j, j)], h[(j + 1, j)]);
        let r = u.norm().hypot(v.norm());
        if !(r > 0.0) {
            // A M⁻¹ v_j = 0 (or not finite): the step adds nothing to the correction
            return (steps, solve_triangle(&h, &g, j));
        }
        let phase = if u.norm() > 0.0 {
            u / u.norm()
        } else {
            c64::new(1.0, 0.0)
        };
        let (cs, sn) = (u.norm() / r, phase * v.conj() / r);
        h[(j, j)] = phase * r;
        h[(j + 1, j)] = zero;
        g[j + 1] = -sn.conj() * g[j];
        g[j] *= cs;
        rotations.push((cs, sn));
        if g[j + 1].norm() <= target || norm == 0.0 {
            break;
        }
    }
    (steps, solve_triangle(&h, &g, steps))
}

/// y (k × 1) of R y = g on the leading k × k triangle R of the rotated Hessenberg matrix
/// `h`.
fn solve_triangle(h: &Mat<c64>, g: &[c64], k: usize) -> Mat<c64> {
    let mut y = Mat::from_fn(k, 1, |i, _| g[i]);
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        h.as_ref().submatrix(0, 0, k, k),
        y.as_mut(),
        Par::Seq,
    );
    y
}

fn max_abs1<T: Scalar>(v: faer::ColRef<'_, T>) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs1()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, BoxSpec};
    use crate::pencil::Pencil;
    use faer::linalg::solvers::Solve;
    use faer::{c64, Mat, MatRef};

    /// The componentwise backward error maxᵢ |b − A x|ᵢ / (|A||x| + |b|)ᵢ of one column.
    fn berr(pencil: &Pencil, vals: &[f64], b: MatRef<'_, f64>, x: MatRef<'_, f64>) -> f64 {
        let entry = |p: usize| vals[p];
        let mut scratch = pattern::ResidualScratch::default();
        scratch.block(b.nrows(), b.ncols()).copy_from(b);
        let lower = pattern::Lower {
            pencil,
            entry: &entry,
        };
        pattern::symmetric_residual(lower, x, true, &mut scratch, Par::Seq)
    }

    /// K − σM of a small bar: its pencil, the lower values and the dense symmetric matrix.
    fn shifted_bar(elements: [usize; 3], sigma: f64) -> (Pencil, Vec<f64>, Mat<f64>) {
        let spec = BoxSpec {
            elements,
            ..BoxSpec::paper_bar()
        };
        let pencil = Pencil::new(&bar_model(&spec).unwrap());
        let n = pencil.n();
        let mut vals = vec![0.0; pencil.nnz()];
        pencil.fill_shifted(sigma, &mut vals);
        let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
        let mut a = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for p in cp[j]..cp[j + 1] {
                a[(ri[p], j)] = vals[p];
                a[(j, ri[p])] = vals[p];
            }
        }
        (pencil, vals, a)
    }

    /// b − A x in `T`'s own arithmetic, one column at a time, in the order the blocked pass
    /// promises to keep: per column j of the lower pattern, r_i −= a_ij x_j for its rows, then
    /// r_j −= Σ_{i≠j} a_ij x_i.
    fn residual_by_columns<T: Scalar>(
        pencil: &Pencil,
        vals: &[T],
        b: MatRef<'_, T>,
        x: MatRef<'_, T>,
    ) -> Mat<T> {
        let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
        let mut r = b.to_owned();
        for c in 0..x.ncols() {
            for j in 0..pencil.n() {
                let mut acc = T::from_parts(0.0, 0.0);
                for p in cp[j]..cp[j + 1] {
                    let i = ri[p];
                    r[(i, c)] -= vals[p] * x[(j, c)];
                    if i != j {
                        acc += vals[p] * x[(i, c)];
                    }
                }
                r[(j, c)] -= acc;
            }
        }
        r
    }

    /// The blocked residual r = b − A x and the componentwise backward error
    /// maxᵢ |r|ᵢ / (|A||x| + |b|)ᵢ against a dense product, for 1–37 columns (one block,
    /// several, a partial last one) sequentially and on two threads, with one scratch reused
    /// across calls: the same numbers either way, and the normwise call leaves the same r.
    /// r is also bit for bit that of [`residual_by_columns`]: the split rows and the AVX2
    /// pass change no rounding.
    fn blocked_residual_case<T: Scalar<Real = f64>>(
        vals: &[T],
        pencil: &Pencil,
        value: impl Fn(usize) -> T,
    ) {
        let n = pencil.n();
        let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
        let mut a = Mat::<T>::zeros(n, n);
        for j in 0..n {
            for p in cp[j]..cp[j + 1] {
                a[(ri[p], j)] = vals[p];
                a[(j, ri[p])] = vals[p];
            }
        }
        let abs_a = Mat::<f64>::from_fn(n, n, |i, j| a[(i, j)].abs1());
        let entry = |p: usize| vals[p];
        let lower = pattern::Lower {
            pencil,
            entry: &entry,
        };
        let mut scratch = pattern::ResidualScratch::default();
        for k in [1, 2, 3, 5, 9, 16, 17, 37] {
            let x = Mat::<T>::from_fn(n, k, |i, c| value(i * 13 + c * 5));
            let b = Mat::<T>::from_fn(n, k, |i, c| value(i * 3 + c * 11 + 1));
            let r_dense = &b - &a * &x;
            let abs_x = Mat::<f64>::from_fn(n, k, |i, c| x[(i, c)].abs1());
            let abs_b = Mat::<f64>::from_fn(n, k, |i, c| b[(i, c)].abs1());
            let s_dense = &abs_a * &abs_x + &abs_b;
            let column_dense: Vec<f64> = (0..k)
                .map(|c| {
                    (0..n)
                        .filter(|&i| s_dense[(i, c)] > 0.0)
                        .fold(0.0f64, |m, i| {
                            m.max(r_dense[(i, c)].abs1() / s_dense[(i, c)])
                        })
                })
                .collect();
            let berr_dense = column_dense.iter().fold(0.0f64, |m, &e| m.max(e));
            assert!(
                berr_dense > 0.1,
                "k = {k}: the case is too easy ({berr_dense:.1e})"
            );
            let mut results = Vec::new();
            for par in [Par::Seq, Par::rayon(2)] {
                scratch.block(n, k).copy_from(&b);
                let berr = pattern::symmetric_residual(lower, x.as_ref(), true, &mut scratch, par);
                let r = scratch.block(n, k).to_owned();
                assert!(
                    r == residual_by_columns(pencil, vals, b.as_ref(), x.as_ref()),
                    "k = {k}: the blocked pass rounds differently"
                );
                let er = (&r - &r_dense).norm_l2() / (&abs_a * &abs_x).norm_l2();
                let es = (berr - berr_dense).abs() / berr_dense;
                assert!(
                    er < 1e-14 && es < 1e-13,
                    "k = {k}: r {er:.1e}, berr {es:.1e}"
                );
                let columns = scratch.column_errors();
                assert_eq!(columns.len(), k);
                assert_eq!(columns.iter().fold(0.0f64, |m, &e| m.max(e)), berr);
                for (c, (&e, &d)) in columns.iter().zip(&column_dense).enumerate() {
                    assert!(
                        (e - d).abs() <= 1e-13 * d,
                        "k = {k}, column {c}: {e:.3e} against {d:.3e}"
                    );
                }
                let columns = columns.to_vec();
                scratch.block(n, k).copy_from(&b);
                let none = pattern::symmetric_residual(lower, x.as_ref(), false, &mut scratch, par);
                let same = scratch.block(n, k) == r;
                assert!(none == 0.0 && same, "k = {k}: normwise residual differs");
                results.push((r, berr, columns));
            }
            assert!(
                results[0] == results[1],
                "k = {k}: threads changed the residual"
            );
        }
    }

    /// [`blocked_residual_case`] for real and for complex-symmetric entries, on a bar of
    /// 1116 DoFs: more than two tiles of the row-major copies, the last one partial.
    #[test]
    fn blocked_residual_equals_a_dense_product() {
        let (pencil, vals, _) = shifted_bar([2, 3, 30], -3e5);
        assert_eq!(pencil.n(), 1116);
        let small = |m: usize| ((m % 17) as f64 - 8.0) / 8.0;
        blocked_residual_case(&vals, &pencil, small);
        // complex symmetric: a damping-like imaginary part on every entry
        let cvals: Vec<c64> = vals
            .iter()
            .enumerate()
            .map(|(p, &v)| c64::new(v, 0.3 * v * small(p)))
            .collect();
        blocked_residual_case(&cvals, &pencil, |m| c64::new(small(m), small(m / 3 + 5)));
    }

    /// Refinement with a solver of a perturbed matrix (A + E, |E| = 1e-8|A| on the diagonal)
    /// converges to the solution of A: both rules end at a backward error of a few ε and cut
    /// the distance to a dense solve of A by four orders or more.
    #[test]
    fn refinement_with_an_inexact_solver_reaches_the_exact_matrix() {
        // K + 10⁶ M: positive definite, cond ≈ 1e4
        let (pencil, vals, a) = shifted_bar([1, 1, 6], -1e6);
        let n = pencil.n();
        let mut perturbed = a.clone();
        for i in 0..n {
            perturbed[(i, i)] *= 1.0 + 1e-8 * if i % 2 == 0 { 1.0 } else { -1.0 };
        }
        let inexact = perturbed.partial_piv_lu();
        let b = Mat::<f64>::from_fn(n, 2, |i, c| ((i * 7 + c * 3) % 11) as f64 - 5.0);
        let exact = a.partial_piv_lu().solve(&b);
        let norm_inf = pattern::symmetric_norm_inf(&pencil, |p| vals[p]);
        for stop in [
            Stop::Componentwise,
            Stop::Normwise {
                norm_inf,
                above: 1e-14,
            },
        ] {
            let mut x = inexact.solve(&b);
            let diff_before = (&x - &exact).norm_l2() / exact.norm_l2();
            let before = berr(
                &pencil,
                &vals,
                b.as_ref().subcols(0, 1),
                x.as_ref().subcols(0, 1),
            );
            let mut buffers = Buffers::default();
            let steps = refine(
                pattern::Lower {
                    pencil: &pencil,
                    entry: &|p: usize| vals[p],
                },
                stop,
                |mut out| out.copy_from(&b),
                x.as_mut(),
                |mut r| {
                    let s = inexact.solve(&r);
                    r.copy_from(&s);
                },
                &mut buffers,
                Par::Seq,
            );
            let after = berr(
                &pencil,
                &vals,
                b.as_ref().subcols(0, 1),
                x.as_ref().subcols(0, 1),
            );
            // the residual that ended the refinement was of the returned x: its column
            // errors are those of a separate pass, bit for bit
            if let (Stop::Componentwise, true) = (stop, steps < MAX_REFINEMENTS) {
                assert_eq!(buffers.column_errors()[0], after);
            }
            let diff = (&x - &exact).norm_l2() / exact.norm_l2();
            assert!(
                before > 1e-10,
                "{stop:?}: the perturbed solve is not inexact: {before:.1e}"
            );
            assert!(
                (1..=MAX_REFINEMENTS).contains(&steps),
                "{stop:?}: {steps} steps"
            );
            // the componentwise rule runs to ~ε; the normwise one stops once ‖r‖∞ is below
            // 1e-14 relative, which leaves the componentwise error at 1.9e-15 here
            let bound = match stop {
                Stop::Componentwise => 1e-15,
                Stop::Normwise { .. } => 1e-14,
            };
            assert!(
                after <= bound,
                "{stop:?}: backward error {after:.1e} after {steps} steps"
            );
            println!("{stop:?}: {steps} steps, backward error {before:.1e} -> {after:.1e}, vs dense {diff_before:.1e} -> {diff:.1e}");
            // both cut the distance to the dense solve by four orders at least; the
            // componentwise rule, which runs on, reaches the floor cond(A)·ε (1.8e-11 here;
            // the normwise one stops at 5.2e-10)
            let floor = match stop {
                Stop::Componentwise => 1e-10,
                Stop::Normwise { .. } => f64::INFINITY,
            };
            assert!(
                diff <= 1e-4 * diff_before && diff <= floor,
                "{stop:?}: differs from the dense solve by {diff:.1e} (unrefined {diff_before:.1e})"
            );
        }
    }
}
