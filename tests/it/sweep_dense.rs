//! The sweep's transfer functions equal dense direct solves (issue: foundation, acceptance 1).

use crate::common::*;
use sparsemor::factor::Backend;
use sparsemor::model::Damping;
use sparsemor::sweep::{SolveMethod, SweepOptions};

fn check(damping: Damping, backend: Backend, threads: usize) {
    check_with(damping, backend, threads, SolveMethod::Factored);
}

fn check_with(damping: Damping, backend: Backend, threads: usize, method: SolveMethod) {
    let model = random_model(400, 7, 11, damping);
    let opts = SweepOptions {
        backend,
        threads,
        method,
        ..Default::default()
    };
    let freqs = random_freqs(6, 1.0, 400.0, 5);
    assert_sweep_matches_dense(&model, &random_scene(400), &freqs, &opts, 1e-9);
}

/// The responses of the shifted Krylov space (one real factorization, each response
/// certified by its residual) equal dense solves, damped proportionally or undamped.
#[test]
fn krylov_matches_dense() {
    for damping in [
        Damping::Rayleigh {
            alpha: 0.5,
            beta: 1e-5,
        },
        Damping::None,
    ] {
        check_with(damping, Backend::Auto, 2, SolveMethod::Auto);
    }
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

#[cfg(feature = "mumps")]
#[test]
fn mumps_damped_and_undamped_match_dense() {
    let rayleigh = Damping::Rayleigh {
        alpha: 0.5,
        beta: 1e-5,
    };
    for damping in [rayleigh, Damping::None] {
        check(damping, Backend::Mumps, 2);
    }
}

/// Out of core, MUMPS writes the factors to the directory and reads them back in the solves:
/// the same transfer functions as dense solves (every frequency factored: out of core no
/// shifted Krylov space is made), and the directory is empty afterwards.
#[cfg(feature = "mumps")]
#[test]
fn mumps_out_of_core_matches_dense_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let model = random_model(
        400,
        7,
        11,
        Damping::Rayleigh {
            alpha: 0.5,
            beta: 1e-5,
        },
    );
    let opts = SweepOptions {
        backend: Backend::Mumps,
        threads: 2,
        out_of_core: Some(dir.path().to_path_buf()),
        ..Default::default()
    };
    let freqs = random_freqs(6, 1.0, 400.0, 5);
    assert_sweep_matches_dense(&model, &random_scene(400), &freqs, &opts, 1e-9);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// MUMPS whose in-core factorization exceeds the memory budget keeps its factors on disk
/// by itself (in the temporary directory) and says so in the analysis' statistics; every
/// frequency factored, so that the factors on disk are the ones solved with.
#[cfg(feature = "mumps")]
#[test]
fn mumps_over_the_memory_budget_goes_out_of_core() {
    use sparsemor::frf::{transfer_function, Part};
    let model = random_model(400, 7, 11, Damping::None);
    let body = sparsemor::body::Body::new(&model).unwrap();
    let scene = random_scene(400);
    let freqs = random_freqs(3, 1.0, 400.0, 5);
    let run = |budget: Option<usize>| {
        let opts = SweepOptions {
            backend: Backend::Mumps,
            memory_budget: budget,
            method: SolveMethod::Factored,
            ..Default::default()
        };
        let progress = &sparsemor::sweep::no_progress;
        transfer_function(&body, &scene, &freqs, Part::Total, &opts, None, progress).unwrap()
    };
    let (in_core, on_disk) = (run(None), run(Some(1)));
    assert!(!in_core.symbolic.as_ref().unwrap().out_of_core);
    assert!(on_disk.symbolic.as_ref().unwrap().out_of_core);
    let opts = SweepOptions {
        backend: Backend::Mumps,
        memory_budget: Some(1),
        method: SolveMethod::Factored,
        ..Default::default()
    };
    assert_sweep_matches_dense(&model, &scene, &freqs, &opts, 1e-9);
}

/// An out-of-core directory needs the MUMPS backend, and it must exist.
#[test]
fn out_of_core_with_another_backend_or_no_directory_is_refused() {
    let model = random_model(60, 3, 11, Damping::None);
    let body = sparsemor::body::Body::new(&model).unwrap();
    let scene = random_scene(60);
    let missing = std::env::temp_dir().join("sparsemor-no-such-ooc-dir");
    let backends: &[(Backend, &str)] = if cfg!(feature = "mumps") {
        &[
            (Backend::Ldlt, "backend mumps"),
            (Backend::Mumps, "not an existing directory"),
        ]
    } else {
        &[
            (Backend::Ldlt, "backend mumps"),
            (Backend::Mumps, "--features mumps"),
        ]
    };
    for &(backend, says) in backends {
        let opts = SweepOptions {
            backend,
            out_of_core: Some(missing.clone()),
            ..Default::default()
        };
        let Err(err) = sparsemor::frf::transfer_function(
            &body,
            &scene,
            &[10.0],
            sparsemor::frf::Part::Total,
            &opts,
            None,
            &sparsemor::sweep::no_progress,
        ) else {
            panic!("{backend}: an out-of-core directory was not refused");
        };
        assert!(err.to_string().contains(says), "{backend}: {err}");
    }
}

/// A frequency-parallel sweep gives the numbers of a one-thread sweep, bit for bit. A worker
/// that runs out of frequencies lends its thread to the phases the others start after that
/// (factorization, solves, residuals), and each phase computes the same numbers on any
/// thread count. Seven frequencies on two workers, so one of them waits for the other at
/// the end; a bar whose bisected order splits the factorization and the solves between two
/// threads (2×3×150 elements, N = 5436).
#[test]
fn an_idle_worker_lending_its_thread_changes_no_number() {
    use sparsemor::body::Body;
    use sparsemor::fe::{bar_model, BoxSpec};
    use sparsemor::frf::{transfer_function, Part};
    use sparsemor::sweep::{no_progress, Schedule};
    let spec = BoxSpec {
        elements: [2, 3, 150],
        ..BoxSpec::paper_bar()
    };
    let model = bar_model(&spec).unwrap();
    let body = Body::new(&model).unwrap();
    let scene = random_scene(model.n());
    let freqs = [10.0, 35.0, 120.0, 400.0, 900.0, 1500.0, 2500.0];
    let sweep = |threads| {
        let opts = SweepOptions {
            threads,
            ..Default::default()
        };
        transfer_function(
            &body,
            &scene,
            &freqs,
            Part::Elastic,
            &opts,
            None,
            &no_progress,
        )
        .unwrap()
    };
    let (one, two) = (sweep(1), sweep(2));
    assert_eq!(
        two.schedule,
        Some(Schedule::FrequencyParallel { workers: 2 })
    );
    for (k, f) in freqs.iter().enumerate() {
        assert_eq!(one.h[k], two.h[k], "H at {f} Hz");
        let (a, b) = (&one.freq_stats[k], &two.freq_stats[k]);
        assert_eq!(
            (
                a.probe_error.to_bits(),
                a.backward_error.to_bits(),
                a.refinement_steps
            ),
            (
                b.probe_error.to_bits(),
                b.backward_error.to_bits(),
                b.refinement_steps
            ),
            "stats at {f} Hz"
        );
    }
}
