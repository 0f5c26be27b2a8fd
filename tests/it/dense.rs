//! `dense::sym_eigen`: backward-stable at every scale. faer's divide and conquer (order ≥ 128)
//! deflates with an absolute tolerance, so a matrix of norm 1e-9 with close eigenvalues came
//! back with residuals ~1e-6 of its norm; the wrapper scales first.

use faer::Mat;
use proptest::prelude::*;
use sparsemor::dense::{sym_eigen, sym_eigenvalues};

/// A = s · Q D Qᵀ of order n: a random orthogonal Q (QR of a seeded random matrix) and a graded
/// spectrum with clusters like a Ritz matrix of S = (K − σM)⁻¹M: six equal leading values,
/// then decreasing values each repeated up to three times with relative gaps of 1e-7.
fn graded(n: usize, scale: f64, seed: u64) -> (Mat<f64>, Vec<f64>) {
    let mut state = seed | 1;
    let mut rnd = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let g = Mat::from_fn(n, n, |_, _| rnd());
    let q = g.qr().compute_Q();
    let mut d = Vec::with_capacity(n);
    for k in 0..n {
        let v = if k < 6 {
            1.0
        } else {
            let base = 1.0 / (1.0 + (k / 3) as f64).powi(2);
            base * (1.0 + 1e-7 * (k % 3) as f64)
        };
        d.push(v * scale);
    }
    let a = Mat::from_fn(n, n, |i, j| {
        (0..n).map(|l| q[(i, l)] * d[l] * q[(j, l)]).sum()
    });
    d.sort_by(f64::total_cmp);
    (a, d)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(6))]

    #[test]
    fn eigenpairs_are_backward_stable_at_any_scale(
        n in 128usize..180,
        exp in prop::sample::select(vec![-12i32, -9, 0, 9]),
        seed in 1u64..1000,
    ) {
        let scale = 10f64.powi(exp);
        let (a, d) = graded(n, scale, seed);
        let (values, u) = sym_eigen(a.as_ref()).unwrap();
        let only = sym_eigenvalues(a.as_ref()).unwrap();
        let r = &a * &u - Mat::from_fn(n, n, |i, j| u[(i, j)] * values[j]);
        let mut worst = 0.0f64;
        for j in 0..n {
            worst = worst.max(r.col(j).norm_l2());
        }
        prop_assert!(worst <= 1e-13 * scale, "max ‖Ay − θy‖ = {:.1e}·‖A‖", worst / scale);
        let orth = (u.transpose() * &u - Mat::<f64>::identity(n, n)).norm_max();
        prop_assert!(orth <= 1e-13, "‖UᵀU − I‖ = {orth:.1e}");
        for k in 0..n {
            prop_assert!((values[k] - d[k]).abs() <= 1e-13 * scale, "λ{k}: {} vs {}", values[k], d[k]);
            prop_assert!((only[k] - d[k]).abs() <= 1e-13 * scale, "eigenvalues only, λ{k}");
        }
    }
}
