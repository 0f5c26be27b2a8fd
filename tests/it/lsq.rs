//! Streamed QR least squares (docs/design.md §3.3) against dense least squares of the stacked
//! system.
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas

use faer::prelude::*;
use faer::{Accum, Mat, MatRef};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use sparsemor::lsq::{LsqOptions, LsqSolution, StreamedQr};
use sparsemor::Error;

fn uniform(rng: &mut StdRng, r: usize, c: usize) -> Mat<f64> {
    Mat::from_fn(r, c, |_, _| rng.gen_range(-1.0..1.0))
}

fn rel_fro(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
    let d = Mat::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] - b[(i, j)]);
    let nb = b.norm_l2();
    if nb == 0.0 {
        d.norm_l2()
    } else {
        d.norm_l2() / nb
    }
}

/// Per column j of `b`: ‖a·xt_j − b_j‖ / ‖b_j‖ (0 if b_j = 0), xt = Wᵀ (n × m).
fn true_residuals(a: MatRef<'_, f64>, xt: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Vec<f64> {
    let mut r = b.to_owned();
    faer::linalg::matmul::matmul(r.as_mut(), Accum::Add, a, xt, -1.0, Par::Seq);
    (0..b.ncols())
        .map(|j| {
            let nb = b.col(j).norm_l2();
            if nb == 0.0 {
                0.0
            } else {
                r.col(j).norm_l2() / nb
            }
        })
        .collect()
}

/// Minimum-norm least squares by a truncated SVD of the stacked `a` (rows × n).
fn pinv_solve(a: MatRef<'_, f64>, b: MatRef<'_, f64>, rtol: f64) -> Mat<f64> {
    let svd = a.thin_svd().unwrap();
    let (u, s, v) = (svd.U(), svd.S(), svd.V());
    let n = a.ncols();
    let smax = s[0];
    let k = (0..n).take_while(|&i| s[i] > rtol * smax).count();
    let mut utb = Mat::<f64>::zeros(k, b.ncols());
    faer::linalg::matmul::matmul(
        utb.as_mut(),
        Accum::Replace,
        u.subcols(0, k).transpose(),
        b,
        1.0,
        Par::Seq,
    );
    for i in 0..k {
        for j in 0..b.ncols() {
            utb[(i, j)] /= s[i];
        }
    }
    let mut x = Mat::<f64>::zeros(n, b.ncols());
    faer::linalg::matmul::matmul(
        x.as_mut(),
        Accum::Replace,
        v.subcols(0, k),
        utb.as_ref(),
        1.0,
        Par::Seq,
    );
    x
}

fn cond(a: MatRef<'_, f64>) -> f64 {
    let s = a.singular_values().unwrap();
    s[0] / s[s.len() - 1]
}

/// How a stacked problem is streamed: row blocks, which state absorbs each, merge order.
struct Split<'a> {
    /// (first row, rows) per block.
    blocks: &'a [(usize, usize)],
    /// State index per block.
    owner: &'a [usize],
    nstates: usize,
    /// Pairs (i, j): remove state i, then state j (mod the current count), push the merge.
    merge_picks: &'a [(usize, usize)],
    chunk: Option<usize>,
    /// Hand F over as a transposed (row-major) view.
    row_major_f: bool,
}

/// Absorbs the row blocks of (a, b) into several states and merges them (a TSQR tree).
fn streamed(a: MatRef<'_, f64>, b: MatRef<'_, f64>, sp: &Split<'_>) -> StreamedQr {
    let (n, m) = (a.ncols(), b.ncols());
    let Split {
        blocks,
        owner,
        nstates,
        merge_picks,
        chunk,
        row_major_f,
    } = *sp;
    let mut states: Vec<StreamedQr> = (0..nstates)
        .map(|_| {
            let mut s = StreamedQr::new(n, m);
            if let Some(c) = chunk {
                s.set_chunk_cols(c);
            }
            s
        })
        .collect();
    for (&(r0, q), &o) in blocks.iter().zip(owner) {
        let g = a.subrows(r0, q).to_owned();
        if row_major_f {
            // F handed over as a transposed view of an m × q column-major matrix.
            let ft = b.subrows(r0, q).transpose().to_owned();
            states[o].absorb(g.as_ref(), ft.transpose()).unwrap();
        } else {
            let f = b.subrows(r0, q).to_owned();
            states[o].absorb(g.as_ref(), f.as_ref()).unwrap();
        }
    }
    let mut picks = merge_picks.iter();
    while states.len() > 1 {
        let &(i, j) = picks.next().unwrap_or(&(0, 1));
        let i = i % states.len();
        let s1 = states.swap_remove(i);
        let j = j % states.len();
        let s2 = states.swap_remove(j);
        states.push(s1.merge(s2).unwrap());
    }
    states.pop().unwrap()
}

fn w_t(sol: &LsqSolution) -> Mat<f64> {
    sol.w.transpose().to_owned()
}

#[derive(Debug, Clone)]
struct Case {
    n: usize,
    m: usize,
    block_rows: Vec<usize>,
    owner: Vec<usize>,
    nstates: usize,
    merge_picks: Vec<(usize, usize)>,
    chunk: Option<usize>,
    noise: f64,
    row_major_f: bool,
    seed: u64,
}

fn case() -> impl Strategy<Value = Case> {
    (1usize..12, 1usize..60, 1usize..=8).prop_flat_map(|(n, m, nb)| {
        (
            prop::collection::vec(0usize..=(2 * n + 2), nb),
            prop::collection::vec(0usize..8, nb),
            1usize..=nb,
            prop::collection::vec((0usize..8, 0usize..8), 8),
            prop_oneof![Just(None), (1usize..17).prop_map(Some)],
            prop_oneof![Just(1.0), Just(1e-6), Just(0.0)],
            any::<bool>(),
            any::<u64>(),
            0usize..nb,
        )
            .prop_map(
                move |(
                    mut block_rows,
                    owner,
                    nstates,
                    merge_picks,
                    chunk,
                    noise,
                    rm,
                    seed,
                    fix,
                )| {
                    // Total rows ≥ n + 2: put any deficit on one block.
                    let total: usize = block_rows.iter().sum();
                    if total < n + 2 {
                        block_rows[fix] += n + 2 - total;
                    }
                    let owner = owner.iter().map(|o| o % nstates).collect();
                    Case {
                        n,
                        m,
                        block_rows,
                        owner,
                        nstates,
                        merge_picks,
                        chunk,
                        noise,
                        row_major_f: rm,
                        seed,
                    }
                },
            )
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn streamed_equals_dense(c in case()) {
        let mut rng = StdRng::seed_from_u64(c.seed);
        let rows: usize = c.block_rows.iter().sum();
        let a = uniform(&mut rng, rows, c.n);
        // Random cases are well conditioned with overwhelming probability (rows ≥ n + 2);
        // skip the rare exception instead of loosening the tolerance.
        prop_assume!(cond(a.as_ref()) < 1e3);
        // T_nᵀ = T_oᵀ X + noise·E: noise 0 is an exact fit (residual ~ rounding).
        let x = uniform(&mut rng, c.n, c.m);
        let noise = uniform(&mut rng, rows, c.m);
        let b = Mat::from_fn(rows, c.m, |i, j| {
            (0..c.n).map(|k| a[(i, k)] * x[(k, j)]).sum::<f64>() + c.noise * noise[(i, j)]
        });
        let mut blocks = Vec::new();
        let mut r0 = 0;
        for &q in &c.block_rows {
            blocks.push((r0, q));
            r0 += q;
        }
        let split = Split {
            blocks: &blocks,
            owner: &c.owner,
            nstates: c.nstates,
            merge_picks: &c.merge_picks,
            chunk: c.chunk,
            row_major_f: c.row_major_f,
        };
        let st = streamed(a.as_ref(), b.as_ref(), &split);
        prop_assert_eq!(st.rows(), rows);
        let sol = st.finish(&LsqOptions::default()).unwrap();
        prop_assert_eq!(sol.rows, rows);
        prop_assert_eq!(sol.rank, c.n);
        prop_assert!(!sol.truncated);
        prop_assert_eq!(sol.w.nrows(), c.m);
        prop_assert_eq!(sol.w.ncols(), c.n);

        let wt_ref = a.qr().solve_lstsq(&b);
        let wt = w_t(&sol);
        let err = rel_fro(wt.as_ref(), wt_ref.as_ref());
        prop_assert!(err <= 1e-10, "‖W − W_ref‖/‖W_ref‖ = {err:e}");

        let res_ref = true_residuals(a.as_ref(), wt_ref.as_ref(), b.as_ref());
        for (j, (&r, &rr)) in sol.residual.iter().zip(&res_ref).enumerate() {
            prop_assert!(
                (r - rr).abs() <= 1e-10 * rr + 1e-12,
                "column {j}: residual {r:e} vs dense {rr:e}"
            );
        }
        let max = res_ref.iter().cloned().fold(0.0, f64::max);
        prop_assert!((sol.residual_max - max).abs() <= 1e-10 * max + 1e-12);
        prop_assert!(sol.residual[sol.residual_argmax] == sol.residual_max);
        let mean = sol.residual.iter().sum::<f64>() / c.m as f64;
        prop_assert!((sol.residual_mean - mean).abs() <= 1e-14);
        prop_assert!(sol.cond_equilibrated >= 1.0 && sol.cond_equilibrated < 1e4);
    }
}

/// Random problem split into blocks of `q` rows (last block shorter).
fn blocks_of(rows: usize, q: usize) -> Vec<(usize, usize)> {
    (0..rows)
        .step_by(q)
        .map(|r0| (r0, q.min(rows - r0)))
        .collect()
}

fn absorb_all(a: MatRef<'_, f64>, b: MatRef<'_, f64>, q: usize) -> StreamedQr {
    let mut st = StreamedQr::new(a.ncols(), b.ncols());
    for (r0, q) in blocks_of(a.nrows(), q) {
        st.absorb(a.subrows(r0, q), b.subrows(r0, q)).unwrap();
    }
    st
}

#[test]
fn column_scaling_is_equilibrated() {
    let (n, m, rows) = (8, 25, 40);
    let mut rng = StdRng::seed_from_u64(7);
    let a0 = uniform(&mut rng, rows, n);
    let b = uniform(&mut rng, rows, m);
    // Columns scaled by 1e-8 … 1e8.
    let s: Vec<f64> = (0..n)
        .map(|j| 10f64.powf(-8.0 + 16.0 * j as f64 / (n - 1) as f64))
        .collect();
    let a = Mat::from_fn(rows, n, |i, j| a0[(i, j)] * s[j]);
    let sol = absorb_all(a.as_ref(), b.as_ref(), 6)
        .finish(&LsqOptions::default())
        .unwrap();
    assert!(!sol.truncated);
    assert!(sol.cond_raw > 1e12, "cond_raw = {:e}", sol.cond_raw);
    assert!(
        sol.cond_equilibrated < 1e2,
        "cond_equilibrated = {:e}",
        sol.cond_equilibrated
    );
    // Dense reference on the equilibrated problem: z = argmin ‖A D z − B‖, Wᵀ = D z.
    let d: Vec<f64> = (0..n).map(|j| 1.0 / a.col(j).norm_l2()).collect();
    for j in 0..n {
        let rel = (sol.col_norms[j] * d[j] - 1.0).abs();
        assert!(rel < 1e-13, "column norm {j}: {rel:e}");
    }
    let ad = Mat::from_fn(rows, n, |i, j| a[(i, j)] * d[j]);
    let z_ref = ad.qr().solve_lstsq(&b);
    // Compare in the equilibrated variables z = D⁻¹ Wᵀ: every row of Wᵀ is O(1/s_j) there.
    let z = Mat::from_fn(n, m, |j, k| sol.w[(k, j)] / d[j]);
    let err = rel_fro(z.as_ref(), z_ref.as_ref());
    assert!(err <= 1e-10, "equilibrated ‖Z − Z_ref‖/‖Z_ref‖ = {err:e}");
    for j in 0..n {
        let e = rel_fro(z.row(j).as_mat(), z_ref.row(j).as_mat());
        assert!(e <= 1e-10, "interface column {j}: {e:e}");
    }
    let wt = w_t(&sol);
    let res = true_residuals(a.as_ref(), wt.as_ref(), b.as_ref());
    for (r, rr) in sol.residual.iter().zip(&res) {
        assert!((r - rr).abs() <= 1e-10 * rr + 1e-12);
    }
}

#[test]
fn rank_deficient_duplicate_column() {
    let (n, m, rows) = (6, 30, 36);
    let mut rng = StdRng::seed_from_u64(11);
    let mut a = uniform(&mut rng, rows, n);
    for i in 0..rows {
        a[(i, 4)] = a[(i, 2)];
    }
    let b = uniform(&mut rng, rows, m);
    for q in [1, 5, 12, 36] {
        let sol = absorb_all(a.as_ref(), b.as_ref(), q)
            .finish(&LsqOptions::default())
            .unwrap();
        assert!(sol.truncated, "q = {q}");
        assert_eq!(sol.rank, n - 1, "q = {q}: σ = {:?}", sol.singular_values);
        assert!(sol.cond_equilibrated > 1e12);
        let wt = w_t(&sol);
        // Reported residual = true residual of the returned W.
        let res = true_residuals(a.as_ref(), wt.as_ref(), b.as_ref());
        for (j, (r, rr)) in sol.residual.iter().zip(&res).enumerate() {
            assert!(
                (r - rr).abs() <= 1e-10 * rr + 1e-12,
                "q = {q}, column {j}: reported {r:e}, true {rr:e}"
            );
        }
        // Minimum-norm solution: the duplicated columns share the weight equally.
        let wt_ref = pinv_solve(a.as_ref(), b.as_ref(), 1e-10);
        let err = rel_fro(wt.as_ref(), wt_ref.as_ref());
        assert!(
            err <= 1e-10,
            "q = {q}: ‖W − W_minnorm‖/‖W_minnorm‖ = {err:e}"
        );
        for k in 0..m {
            assert!((sol.w[(k, 2)] - sol.w[(k, 4)]).abs() <= 1e-10 * sol.w[(k, 2)].abs().max(1.0));
        }
        // The truncated solution keeps the optimal residual (the dropped direction is a
        // null vector of T_oᵀ).
        let res_ref = true_residuals(a.as_ref(), wt_ref.as_ref(), b.as_ref());
        for (r, rr) in sol.residual.iter().zip(&res_ref) {
            assert!((r - rr).abs() <= 1e-10 * rr + 1e-12);
        }
    }
}

#[test]
fn truncation_by_rcond_tol_reports_true_residual() {
    // A nearly dependent column (relative 1e-7) truncated by a user threshold: the residual
    // then includes the dropped direction and must still be the true one.
    let (n, m, rows) = (5, 20, 24);
    let mut rng = StdRng::seed_from_u64(3);
    let mut a = uniform(&mut rng, rows, n);
    let pert = uniform(&mut rng, rows, 1);
    for i in 0..rows {
        a[(i, 3)] = a[(i, 1)] + 1e-7 * pert[(i, 0)];
    }
    let b = uniform(&mut rng, rows, m);
    let st = absorb_all(a.as_ref(), b.as_ref(), 4);
    let full = st.finish(&LsqOptions::default()).unwrap();
    assert!(!full.truncated);
    let sol = st.finish(&LsqOptions { rcond_tol: 1e-5 }).unwrap();
    assert!(sol.truncated);
    assert_eq!(sol.rank, n - 1);
    assert_eq!(sol.rcond_used, 1e-5);
    let wt = w_t(&sol);
    let res = true_residuals(a.as_ref(), wt.as_ref(), b.as_ref());
    for (r, rr) in sol.residual.iter().zip(&res) {
        assert!((r - rr).abs() <= 1e-9 * rr + 1e-12, "{r:e} vs {rr:e}");
    }
    // Dropping a direction can only increase the residual.
    for (r, rf) in sol.residual.iter().zip(&full.residual) {
        assert!(*r >= rf - 1e-12);
    }
}

#[test]
fn zero_row_blocks_and_fewer_rows_than_n() {
    let (n, m) = (7, 9);
    let mut rng = StdRng::seed_from_u64(5);
    let a = uniform(&mut rng, 12, n);
    let b = uniform(&mut rng, 12, m);
    let mut st = StreamedQr::new(n, m);
    st.set_chunk_cols(4);
    for (r0, q) in [(0, 0), (0, 2), (2, 0), (2, 3), (5, 1), (6, 6), (12, 0)] {
        st.absorb(a.subrows(r0, q), b.subrows(r0, q)).unwrap();
    }
    let sol = st.finish(&LsqOptions::default()).unwrap();
    let wt_ref = a.qr().solve_lstsq(&b);
    assert!(rel_fro(w_t(&sol).as_ref(), wt_ref.as_ref()) <= 1e-10);
    // Merging with empty states is the identity.
    let empty = StreamedQr::new(n, m);
    let sol2 = empty
        .merge(st.clone())
        .unwrap()
        .merge(StreamedQr::new(n, m))
        .unwrap()
        .finish(&LsqOptions::default())
        .unwrap();
    assert!(rel_fro(sol2.w.as_ref(), sol.w.as_ref()) <= 1e-15);
}

#[test]
fn exact_fit_with_rows_equal_n() {
    // 2pz = n, full rank: the fit is exact (residual ~ rounding), the paper's interpolation case.
    let (n, m) = (6, 10);
    let mut rng = StdRng::seed_from_u64(9);
    let a = uniform(&mut rng, n, n);
    let b = uniform(&mut rng, n, m);
    let sol = absorb_all(a.as_ref(), b.as_ref(), 2)
        .finish(&LsqOptions::default())
        .unwrap();
    assert!(sol.residual_max < 1e-13);
    let wt_ref = a.qr().solve_lstsq(&b);
    let tol = 1e-14 * cond(a.as_ref()).max(1.0);
    assert!(rel_fro(w_t(&sol).as_ref(), wt_ref.as_ref()) <= tol);
}

#[test]
fn zero_columns_of_t_n_have_zero_residual_and_m_zero_works() {
    let (n, m, rows) = (3, 4, 8);
    let mut rng = StdRng::seed_from_u64(1);
    let a = uniform(&mut rng, rows, n);
    let mut b = uniform(&mut rng, rows, m);
    for i in 0..rows {
        b[(i, 2)] = 0.0;
    }
    let sol = absorb_all(a.as_ref(), b.as_ref(), 3)
        .finish(&LsqOptions::default())
        .unwrap();
    assert_eq!(sol.residual[2], 0.0);
    assert!((0..n).all(|j| sol.w[(2, j)] == 0.0));

    let b0 = Mat::<f64>::zeros(rows, 0);
    let sol = absorb_all(a.as_ref(), b0.as_ref(), 3)
        .finish(&LsqOptions::default())
        .unwrap();
    assert_eq!(sol.w.nrows(), 0);
    assert!(sol.residual.is_empty());
    assert_eq!(sol.residual_max, 0.0);
    assert_eq!(sol.residual_mean, 0.0);
}

#[test]
fn memory_is_o_n_m() {
    let (n, m, q) = (14, 100_000, 18);
    let mut st = StreamedQr::new(n, m);
    let fresh = st.memory_bytes();
    // R (column stride padded to ≤ 16), Y, e.
    assert!(fresh >= 8 * (n * n + n * m + m), "{fresh}");
    assert!(fresh <= 8 * (16 * n + n * m + m), "{fresh}");
    let mut rng = StdRng::seed_from_u64(8);
    let g = uniform(&mut rng, q, n);
    let f = uniform(&mut rng, q, m);
    st.absorb(g.as_ref(), f.as_ref()).unwrap();
    // The idle chunk buffers kept for the next absorb: bounded independently of m.
    let kept = st.memory_bytes() - fresh;
    assert!(kept > 0 && kept <= st.absorb_workspace_bytes(q), "{kept}");
    assert!(st.absorb_workspace_bytes(q) < 8 * q * m / 2);
}

// ---------------------------------------------------------------- errors

fn invalid(r: Result<impl std::fmt::Debug, Error>) -> String {
    match r {
        Err(Error::InvalidSetting(msg)) => msg,
        other => panic!("expected InvalidSetting, got {other:?}"),
    }
}

#[test]
fn shape_errors_leave_state_unchanged() {
    let mut st = StreamedQr::new(3, 5);
    let g = Mat::<f64>::zeros(2, 3);
    let f = Mat::<f64>::zeros(2, 5);
    let msg = invalid(st.absorb(Mat::<f64>::zeros(2, 4).as_ref(), f.as_ref()));
    assert!(msg.contains("4 columns") && msg.contains("n = 3"), "{msg}");
    let msg = invalid(st.absorb(g.as_ref(), Mat::<f64>::zeros(2, 6).as_ref()));
    assert!(msg.contains("6 columns") && msg.contains("m = 5"), "{msg}");
    let msg = invalid(st.absorb(g.as_ref(), Mat::<f64>::zeros(3, 5).as_ref()));
    assert!(msg.contains("G has 2") && msg.contains("F has 3"), "{msg}");
    assert_eq!(st.rows(), 0);
}

#[test]
fn non_finite_entries_are_rejected() {
    let mut rng = StdRng::seed_from_u64(2);
    let mut st = StreamedQr::new(3, 5);
    st.set_chunk_cols(2);
    let g = uniform(&mut rng, 4, 3);
    let f = uniform(&mut rng, 4, 5);
    st.absorb(g.as_ref(), f.as_ref()).unwrap();
    let before = st.finish(&LsqOptions::default()).unwrap();

    let mut g_nan = g.clone();
    g_nan[(1, 2)] = f64::NAN;
    let msg = invalid(st.absorb(g_nan.as_ref(), f.as_ref()));
    assert!(
        msg.contains("G") && msg.contains("NaN") && msg.contains("row 1, column 2"),
        "{msg}"
    );

    let mut f_inf = f.clone();
    f_inf[(3, 4)] = f64::NEG_INFINITY;
    let msg = invalid(st.absorb(g.as_ref(), f_inf.as_ref()));
    assert!(
        msg.contains("F") && msg.contains("inf") && msg.contains("row 3, column 4"),
        "{msg}"
    );

    // Nothing was absorbed.
    assert_eq!(st.rows(), 4);
    let after = st.finish(&LsqOptions::default()).unwrap();
    assert_eq!(before.w, after.w);
    assert_eq!(before.residual, after.residual);
}

#[test]
fn merge_shape_mismatch() {
    let msg = invalid(StreamedQr::new(3, 5).merge(StreamedQr::new(4, 5)));
    assert!(msg.contains("3×5") && msg.contains("4×5"), "{msg}");
    let msg = invalid(StreamedQr::new(3, 5).merge(StreamedQr::new(3, 6)));
    assert!(msg.contains("3×6"), "{msg}");
}

#[test]
fn too_few_rows() {
    let mut rng = StdRng::seed_from_u64(4);
    let mut st = StreamedQr::new(10, 3);
    st.absorb(
        uniform(&mut rng, 6, 10).as_ref(),
        uniform(&mut rng, 6, 3).as_ref(),
    )
    .unwrap();
    let msg = invalid(st.finish(&LsqOptions::default()));
    assert!(
        msg.contains("2pz ≥ n") && msg.contains("6 rows") && msg.contains("n = 10"),
        "{msg}"
    );
    let msg = invalid(StreamedQr::new(2, 3).finish(&LsqOptions::default()));
    assert!(msg.contains("0 rows"), "{msg}");
}

#[test]
fn all_zero_t_o() {
    let mut st = StreamedQr::new(3, 4);
    st.absorb(
        Mat::<f64>::zeros(5, 3).as_ref(),
        Mat::<f64>::ones(5, 4).as_ref(),
    )
    .unwrap();
    let msg = invalid(st.finish(&LsqOptions::default()));
    assert!(msg.contains("all zero"), "{msg}");
}

#[test]
fn bad_options_and_n_zero() {
    let mut rng = StdRng::seed_from_u64(6);
    let st = absorb_all(
        uniform(&mut rng, 5, 2).as_ref(),
        uniform(&mut rng, 5, 3).as_ref(),
        5,
    );
    for tol in [-1.0, f64::NAN, f64::INFINITY, 1.0] {
        let msg = invalid(st.finish(&LsqOptions { rcond_tol: tol }));
        assert!(msg.contains("rcond_tol"), "{msg}");
    }
    let msg = invalid(StreamedQr::new(0, 3).finish(&LsqOptions::default()));
    assert!(msg.contains("n = 0"), "{msg}");
}

#[test]
fn several_reflector_panels_and_tsqr_tree() {
    // n > 2·32: the reflectors are applied in three compact-WY panels; blocks have q < n.
    let (n, m, rows) = (70, 45, 160);
    let mut rng = StdRng::seed_from_u64(12);
    let a = uniform(&mut rng, rows, n);
    let b = uniform(&mut rng, rows, m);
    let blocks = blocks_of(rows, 18);
    let owner: Vec<usize> = (0..blocks.len()).map(|k| k % 3).collect();
    let picks = [(2, 0), (1, 0)];
    let split = Split {
        blocks: &blocks,
        owner: &owner,
        nstates: 3,
        merge_picks: &picks,
        chunk: Some(8),
        row_major_f: false,
    };
    let st = streamed(a.as_ref(), b.as_ref(), &split);
    let sol = st.finish(&LsqOptions::default()).unwrap();
    assert_eq!(sol.rank, n);
    let wt_ref = a.qr().solve_lstsq(&b);
    assert!(cond(a.as_ref()) < 1e2);
    let err = rel_fro(w_t(&sol).as_ref(), wt_ref.as_ref());
    assert!(err <= 1e-10, "{err:e}");
    let res = true_residuals(a.as_ref(), wt_ref.as_ref(), b.as_ref());
    for (r, rr) in sol.residual.iter().zip(&res) {
        assert!((r - rr).abs() <= 1e-10 * rr + 1e-12, "{r:e} vs {rr:e}");
    }
}
