//! The sweep's transfer functions equal dense direct solves (issue: foundation, acceptance 1).

use crate::common::*;
use sparsemor::factor::Backend;
use sparsemor::model::Damping;
use sparsemor::sweep::SweepOptions;

fn check(damping: Damping, backend: Backend, threads: usize) {
    let model = random_model(400, 7, 11, damping);
    let opts = SweepOptions {
        backend,
        threads,
        ..Default::default()
    };
    let freqs = random_freqs(6, 1.0, 400.0, 5);
    assert_sweep_matches_dense(&model, &random_scene(400), &freqs, &opts, 1e-9);
}

#[test]
fn lblt_damped_matches_dense() {
    check(
        Damping::Rayleigh {
            alpha: 0.5,
            beta: 1e-5,
        },
        Backend::FaerLblt,
        2,
    );
}

#[test]
fn lblt_undamped_real_path_matches_dense() {
    check(Damping::None, Backend::FaerLblt, 2);
}

#[test]
fn ldlt_damped_matches_dense() {
    check(
        Damping::Rayleigh {
            alpha: 0.5,
            beta: 1e-5,
        },
        Backend::Ldlt,
        2,
    );
}

#[test]
fn ldlt_undamped_real_path_matches_dense() {
    check(Damping::None, Backend::Ldlt, 1);
}

#[test]
fn lu_damped_matches_dense() {
    check(
        Damping::Rayleigh {
            alpha: 0.0,
            beta: 1e-5,
        },
        Backend::FaerLu,
        1,
    );
}

#[test]
fn lu_undamped_matches_dense() {
    check(Damping::None, Backend::FaerLu, 2);
}

#[cfg(feature = "umfpack")]
#[test]
fn umfpack_damped_matches_dense() {
    check(
        Damping::Rayleigh {
            alpha: 0.5,
            beta: 1e-5,
        },
        Backend::Umfpack,
        2,
    );
}

#[cfg(feature = "umfpack")]
#[test]
fn umfpack_undamped_matches_dense() {
    check(Damping::None, Backend::Umfpack, 2);
}
