//! Shared fixtures of the integration tests: small random models and dense references.
#![allow(dead_code)]

use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use sparsemor::model::{Damping, Model};
use sparsemor::scene::Scene;
use sparsemor::sparse::{from_parts, Csc};

/// Dense copy of a sparse matrix.
pub fn dense(a: &Csc) -> Mat<f64> {
    let mut d = Mat::<f64>::zeros(a.nrows(), a.ncols());
    for j in 0..a.ncols() {
        for (&i, &v) in a
            .symbolic()
            .row_idx_of_col_raw(j)
            .iter()
            .zip(a.val_of_col(j))
        {
            d[(i, j)] += v;
        }
    }
    d
}

/// Sparse matrix from a dense one (entries with |a| > 0).
pub fn sparse(d: &Mat<f64>) -> Csc {
    let n = d.nrows();
    let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
    for j in 0..d.ncols() {
        for i in 0..n {
            if d[(i, j)] != 0.0 {
                ri.push(i);
                v.push(d[(i, j)]);
            }
        }
        cp.push(ri.len());
    }
    from_parts(n, d.ncols(), cp, ri, v)
}

/// A random banded symmetric "structure": K = Σ springs (SPD after adding a small diagonal
/// when `constrained`), M = SPD diagonally dominant; band width `bw`.
pub fn random_model(n: usize, bw: usize, seed: u64, damping: Damping) -> Model {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut k = Mat::<f64>::zeros(n, n);
    let mut m = Mat::<f64>::zeros(n, n);
    for i in 0..n {
        for j in i + 1..(i + bw + 1).min(n) {
            let s: f64 = rng.gen_range(0.5..2.0) * 1e6;
            k[(i, i)] += s;
            k[(j, j)] += s;
            k[(i, j)] -= s;
            k[(j, i)] -= s;
            let c: f64 = rng.gen_range(0.0..0.1);
            m[(i, j)] += c;
            m[(j, i)] += c;
        }
    }
    for i in 0..n {
        k[(i, i)] += 1e5 * rng.gen_range(0.5..1.5);
        let off: f64 = (0..n).filter(|&j| j != i).map(|j| m[(i, j)].abs()).sum();
        m[(i, i)] = off + rng.gen_range(0.5..1.5);
    }
    let scene = Scene {
        inputs: vec![0, n / 2, n - 1],
        outputs: vec![1, n / 3, n - 2],
        band_hz: [0.0, 500.0],
    };
    Model::new(
        "random".into(),
        sparse(&m),
        sparse(&k),
        damping,
        None,
        3,
        scene,
    )
    .expect("valid model")
    .0
}

/// Dense H(iω) = C (K − ω²M + iωD)⁻¹ B.
pub fn dense_h(model: &Model, f: f64, inputs: &[usize], outputs: &[usize]) -> Mat<c64> {
    let w = 2.0 * std::f64::consts::PI * f;
    let (m, k) = (dense(&model.mass), dense(&model.stiffness));
    let d = match &model.damping {
        Damping::None => Mat::zeros(m.nrows(), m.ncols()),
        Damping::Rayleigh { alpha, beta } => Mat::from_fn(m.nrows(), m.ncols(), |i, j| {
            alpha * m[(i, j)] + beta * k[(i, j)]
        }),
        Damping::Matrix(d) => dense(d),
    };
    let a = Mat::<c64>::from_fn(m.nrows(), m.ncols(), |i, j| {
        c64::new(k[(i, j)] - w * w * m[(i, j)], w * d[(i, j)])
    });
    let mut b = Mat::<c64>::zeros(m.nrows(), inputs.len());
    for (j, &i) in inputs.iter().enumerate() {
        b[(i, j)] = c64::new(1.0, 0.0);
    }
    let x = a.partial_piv_lu().solve(&b);
    Mat::from_fn(outputs.len(), inputs.len(), |o, j| x[(outputs[o], j)])
}

/// ‖a − b‖_F / ‖b‖_F.
pub fn rel_err(a: &Mat<c64>, b: &Mat<c64>) -> f64 {
    (a - b).norm_l2() / b.norm_l2()
}

/// Random frequencies in (lo, hi).
pub fn random_freqs(count: usize, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count).map(|_| rng.gen_range(lo..hi)).collect()
}

/// Dense generalized eigendecomposition K Φ = M Φ Λ with ΦᵀMΦ = I (ascending λ).
pub fn dense_modes(model: &Model) -> (Vec<f64>, Mat<f64>) {
    use faer::linalg::solvers::DenseSolveCore;
    let (m, k) = (dense(&model.mass), dense(&model.stiffness));
    let l = m.llt(faer::Side::Lower).expect("M SPD").L().to_owned();
    let linv = l.as_ref().partial_piv_lu().inverse();
    let c = &linv * &k * linv.transpose();
    let c = Mat::from_fn(c.nrows(), c.ncols(), |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    let eig = c.self_adjoint_eigen(faer::Side::Lower).expect("eigen converges");
    let lambdas: Vec<f64> = (0..c.nrows()).map(|i| eig.S()[i]).collect();
    let phi = linv.transpose() * eig.U();
    (lambdas, phi)
}

/// Modal elastic transfer function H1(iω) = C Φe diag(1/(λ − ω² + iω(α + βλ))) Φeᵀ B over the
/// modes with λ > `rigid_below` (Rayleigh damping only): an independent reference without
/// cancellation at any frequency.
pub fn modal_h1(lambdas: &[f64], phi: &Mat<f64>, alpha: f64, beta: f64, rigid_below: f64, f: f64, inputs: &[usize], outputs: &[usize]) -> Mat<c64> {
    let w = 2.0 * std::f64::consts::PI * f;
    Mat::from_fn(outputs.len(), inputs.len(), |o, i| {
        let mut s = c64::new(0.0, 0.0);
        for (j, &l) in lambdas.iter().enumerate() {
            if l > rigid_below {
                let d = c64::new(l - w * w, w * (alpha + beta * l));
                s += c64::new(phi[(outputs[o], j)] * phi[(inputs[i], j)], 0.0) / d;
            }
        }
        s
    })
}
