//! Partial eigenpairs against a dense generalized eigensolve (issue: SEREP, acceptance 1).

mod common;
use common::*;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::model::Damping;

#[test]
fn lowest_modes_of_a_random_model_match_dense() {
    let model = random_model(300, 5, 3, Damping::None);
    let lam = dense_eigenvalues(&model);
    let modes = eigenpairs(
        &model,
        Request::Lowest(12),
        &EigenOptions {
            sigma: Some(-1.0),
            ..Default::default()
        },
    )
    .unwrap();
    for (k, &l) in modes.lambdas.iter().enumerate() {
        let e = (l - lam[k]).abs() / lam[k].abs();
        assert!(e <= 1e-9, "mode {k}: {l} vs {} ({e:.1e})", lam[k]);
        assert!(
            modes.residuals[k] <= 1e-10,
            "residual {k}: {:.1e}",
            modes.residuals[k]
        );
    }
}

#[test]
fn up_to_counts_exactly() {
    let model = random_model(300, 5, 3, Damping::None);
    let lam = dense_eigenvalues(&model);
    let f = 0.5 * (lam[9].sqrt() + lam[10].sqrt()) / (2.0 * std::f64::consts::PI);
    let modes = eigenpairs(&model, Request::UpTo(f), &EigenOptions::default()).unwrap();
    assert_eq!(modes.lambdas.len(), 10);
}
