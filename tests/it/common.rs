//! Shared fixtures of the integration tests: small random models and dense references.
#![allow(dead_code)]

use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::{c64, Mat};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use sparsemor::body::Body;
use sparsemor::metrics::Reference;
use sparsemor::model::{Damping, Model};
use sparsemor::scene::Scene;
use sparsemor::sparse::{from_parts, Csc};
use sparsemor::sweep::{no_progress, SweepOptions};

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
    Model::new("random".into(), sparse(&m), sparse(&k), damping, None, 3)
        .expect("valid model")
        .0
}

/// The scene of [`random_model`]: three inputs, three outputs, band [0, 500] Hz.
pub fn random_scene(n: usize) -> Scene {
    Scene {
        inputs: vec![0, n / 2, n - 1],
        outputs: vec![1, n / 3, n - 2],
        band_hz: [0.0, 500.0],
    }
}

/// Dense H(iω) = C (K + iH − ω²M + iωD)⁻¹ B, H = ηK + K₄ the structural damping.
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
    let eta = model.structural.eta;
    let k4 = model.structural.matrix.as_ref().map(dense);
    let h = |i, j| eta * k[(i, j)] + k4.as_ref().map_or(0.0, |k4: &Mat<f64>| k4[(i, j)]);
    let a = Mat::<c64>::from_fn(m.nrows(), m.ncols(), |i, j| {
        c64::new(k[(i, j)] - w * w * m[(i, j)], w * d[(i, j)] + h(i, j))
    });
    let mut b = Mat::<c64>::zeros(m.nrows(), inputs.len());
    for (j, &i) in inputs.iter().enumerate() {
        b[(i, j)] = c64::new(1.0, 0.0);
    }
    let x = a.partial_piv_lu().solve(&b);
    Mat::from_fn(outputs.len(), inputs.len(), |o, j| x[(outputs[o], j)])
}

/// The largest componentwise backward error (`FreqStats::backward_error`) the tests accept as
/// a backward-stable sweep solve: a few hundred ε. The factorizations pivot inside a supernode
/// only and the measure is componentwise; the largest seen is 1.1e-14 (the real LBLᵀ of an
/// undamped random 400-DoF model on METIS's ordering), most are 3–6e-16.
pub const STABLE_BACKWARD_ERROR: f64 = 1e-13;

/// Asserts that the sweep's total transfer functions of `model` at `freqs` (with `opts`)
/// equal dense solves ([`dense_h`]) to `tol` relative, and that every frequency reports the
/// backward error of a backward-stable solve (positive, at most [`STABLE_BACKWARD_ERROR`]) when
/// factored, its certificate when it came from the shifted Krylov space.
pub fn assert_sweep_matches_dense(
    model: &Model,
    scene: &Scene,
    freqs: &[f64],
    opts: &sparsemor::sweep::SweepOptions,
    tol: f64,
) {
    use sparsemor::frf::{transfer_function, Part};
    use sparsemor::sweep::no_progress;
    let body = sparsemor::body::Body::new(model).unwrap();
    let frf =
        transfer_function(&body, scene, freqs, Part::Total, opts, None, &no_progress).unwrap();
    for (k, &f) in freqs.iter().enumerate() {
        let st = &frf.freq_stats[k];
        let berr = st.backward_error;
        let accepted = if st.from_space() {
            berr <= sparsemor::sweep::CERTIFIED_BACKWARD_ERROR
                || st.relative_residual <= sparsemor::sweep::CERTIFIED_RELATIVE_RESIDUAL
                || st.normwise_backward_error <= sparsemor::sweep::CERTIFIED_NORMWISE_BACKWARD_ERROR
        } else {
            berr <= STABLE_BACKWARD_ERROR
        };
        assert!(
            berr > 0.0 && accepted,
            "{} ({:?}) at {f} Hz: backward error {berr:.1e} (Krylov dimension {})",
            model.name,
            opts.backend,
            st.space_dim
        );
        let e = rel_err(&frf.h[k], &dense_h(model, f, &scene.inputs, &scene.outputs));
        assert!(
            e <= tol,
            "{} ({:?}) at {f} Hz: rel err {e:.2e}",
            model.name,
            opts.backend
        );
    }
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

/// Dense generalized eigenvalues of K φ = λ M φ (ascending), from faer's eigenvalues-only
/// routine (its eigenvector routine was measured inaccurate on the 1656-DoF bar: backward
/// error 5e-4, so no test relies on dense eigenvectors).
pub fn dense_eigenvalues(model: &Model) -> Vec<f64> {
    use faer::linalg::solvers::DenseSolveCore;
    let (m, k) = (dense(&model.mass), dense(&model.stiffness));
    let l = m.llt(faer::Side::Lower).expect("M SPD").L().to_owned();
    let linv = l.as_ref().partial_piv_lu().inverse();
    let c = &linv * &k * linv.transpose();
    let c = Mat::from_fn(c.nrows(), c.ncols(), |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    c.self_adjoint_eigenvalues(faer::Side::Lower)
        .expect("eigenvalues converge")
}

/// Dense generalized eigenvalues of K φ = λ M φ (ascending) by dense shift-invert: the
/// eigenvalues θ of the symmetric Lᵀ (K − σM)⁻¹ L (M = LLᵀ, σ < 0 below the spectrum),
/// λ = σ + 1/θ.
/// Accurate at the LOW end, where the standard form L⁻¹KL⁻ᵀ of [`dense_eigenvalues`] has an
/// absolute error ≈ ε·λ_max: on the paper bar (λ_max = 8.4e12) that is 4.1e-9 relative at the
/// first elastic λ, measured against a double-double Rayleigh quotient, while this form with
/// σ = −(2π·300 Hz)² is within 3e-12 there. The top of its spectrum is inaccurate.
pub fn dense_eigenvalues_shift_invert(model: &Model, sigma: f64) -> Vec<f64> {
    let (m, k) = (dense(&model.mass), dense(&model.stiffness));
    let l = m.llt(faer::Side::Lower).expect("M SPD").L().to_owned();
    let a = Mat::from_fn(m.nrows(), m.ncols(), |i, j| k[(i, j)] - sigma * m[(i, j)]);
    let x = a.llt(faer::Side::Lower).expect("K - sigma M SPD").solve(&l);
    let c = l.transpose() * x;
    let c = Mat::from_fn(c.nrows(), c.ncols(), |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    let theta = c
        .self_adjoint_eigenvalues(faer::Side::Lower)
        .expect("eigenvalues converge");
    let mut lam: Vec<f64> = theta.iter().map(|t| sigma + 1.0 / t).collect();
    lam.sort_by(|a, b| a.total_cmp(b));
    lam
}

/// Dense elastic transfer function of a free body with viscous (and structural) damping that
/// does not load rigid motion, by the *deflated*
/// pencil Ã = A(iω) + c M V0 M0⁻¹ V0ᵀ M: its rigid eigenvalue is lifted to c = (2π·100 Hz)²
/// (near the first elastic one), so it is well conditioned down to ω = 0, and it acts on
/// elastic vectors (V0ᵀMx = 0) as A does: H1 = C Ã⁻¹ P B with P = I − M V0 M0⁻¹ V0ᵀ. A
/// formulation independent of the library's (which projects the result of a solve with A).
pub fn dense_h1_deflated(
    model: &Model,
    v0: &Mat<f64>,
    f: f64,
    inputs: &[usize],
    outputs: &[usize],
) -> Mat<c64> {
    let w = 2.0 * std::f64::consts::PI * f;
    let (m, k) = (dense(&model.mass), dense(&model.stiffness));
    let d = match &model.damping {
        Damping::Rayleigh { alpha, beta } => &m * *alpha + &k * *beta,
        Damping::None => Mat::zeros(m.nrows(), m.ncols()),
        Damping::Matrix(d) => dense(d),
    };
    let mv0 = &m * v0;
    let m0 = v0.transpose() * &mv0;
    let m0_inv = m0.partial_piv_lu().inverse();
    let lift = &mv0 * &m0_inv * mv0.transpose() * (2.0 * std::f64::consts::PI * 100.0).powi(2);
    let n = m.nrows();
    // structural damping H = ηK + K₄ (zero on rigid motion, as the lift needs)
    let eta = model.structural.eta;
    let k4 = model.structural.matrix.as_ref().map(dense);
    let h = |i, j| eta * k[(i, j)] + k4.as_ref().map_or(0.0, |k4: &Mat<f64>| k4[(i, j)]);
    let a = Mat::<c64>::from_fn(n, n, |i, j| {
        c64::new(
            k[(i, j)] - w * w * m[(i, j)] + lift[(i, j)],
            w * d[(i, j)] + h(i, j),
        )
    });
    let mut b = Mat::<f64>::zeros(n, inputs.len());
    for (j, &i) in inputs.iter().enumerate() {
        b[(i, j)] = 1.0;
    }
    let pb = &b - &mv0 * (&m0_inv * (v0.transpose() * &b));
    let pbc = Mat::<c64>::from_fn(n, inputs.len(), |i, j| c64::new(pb[(i, j)], 0.0));
    let x = a.partial_piv_lu().solve(&pbc);
    Mat::from_fn(outputs.len(), inputs.len(), |o, j| x[(outputs[o], j)])
}

/// The full model's transfer functions at `freqs` (the reference of ε), solved in this process
/// with the default sweep options.
pub fn full_reference(body: &Body, scene: &Scene, freqs: &[f64]) -> Reference {
    Reference::compute(
        body,
        scene,
        freqs,
        &SweepOptions::default(),
        None,
        &no_progress,
    )
    .unwrap()
}
