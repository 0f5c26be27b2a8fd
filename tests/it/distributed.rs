//! Frequencies over ranks (docs/design.md §9) with ranks that are threads of this process: the
//! same protocol, engine and tree merge as an MPI run (the MPI transport itself is tested in
//! `mpi.rs` under cargo feature `mpi`). A distributed ROM of factored responses equals the
//! one-process ROM to rounding (each rank's own shifted Krylov space to its certificate),
//! the factored transfer functions are bit-identical, the sampling loop meets its tolerance,
//! and a failing rank fails the run with its error instead of hanging it.

use crate::common::*;
use proptest::prelude::*;
use sparsemor::body::Body;
use sparsemor::engine::{serve, stop, Cluster};
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::frf::{transfer_function, Part};
use sparsemor::model::{Damping, Model};
use sparsemor::reduce::linefit::{
    self, Growth, Interface, LineFitOptions, References, SamplingOptions,
};
use sparsemor::reduce::Rom;
use sparsemor::scene::Scene;
use sparsemor::sweep::{no_progress, SolveMethod, SweepOptions};
use sparsemor::Error;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex};

/// One rank of a cluster of threads: a channel per ordered pair of ranks, and one from rank 0
/// to each rank for broadcasts (as MPI keeps collectives apart from point-to-point messages).
#[derive(Debug)]
struct Threads {
    rank: usize,
    size: usize,
    to: Vec<Sender<Vec<u8>>>,
    from: Vec<Mutex<Receiver<Vec<u8>>>>,
    bcast_to: Vec<Sender<Vec<u8>>>,
    bcast_from: Option<Mutex<Receiver<Vec<u8>>>>,
}

impl Threads {
    fn world(size: usize) -> Vec<Threads> {
        let mut ranks: Vec<Threads> = (0..size)
            .map(|rank| Threads {
                rank,
                size,
                to: Vec::new(),
                from: Vec::new(),
                bcast_to: Vec::new(),
                bcast_from: None,
            })
            .collect();
        // from[b][a]: rank b's end of the channel from rank a
        let mut from: Vec<Vec<Mutex<Receiver<Vec<u8>>>>> = (0..size).map(|_| Vec::new()).collect();
        for rank in ranks.iter_mut() {
            for f in from.iter_mut() {
                let (t, r) = channel();
                rank.to.push(t);
                f.push(Mutex::new(r));
            }
        }
        for (rank, f) in ranks.iter_mut().zip(from) {
            rank.from = f;
        }
        for b in 1..size {
            let (t, r) = channel();
            ranks[0].bcast_to.push(t);
            ranks[b].bcast_from = Some(Mutex::new(r));
        }
        ranks
    }
}

impl Cluster for Threads {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.size
    }
    fn node_size(&self) -> usize {
        1
    }
    fn broadcast(&self, bytes: Vec<u8>) -> Vec<u8> {
        match &self.bcast_from {
            None => {
                self.bcast_to
                    .iter()
                    .for_each(|t| t.send(bytes.clone()).unwrap());
                bytes
            }
            Some(r) => r.lock().unwrap().recv().unwrap(),
        }
    }
    fn send(&self, to: usize, bytes: Vec<u8>) {
        self.to[to].send(bytes).unwrap();
    }
    fn receive(&self, from: usize) -> Vec<u8> {
        self.from[from].lock().unwrap().recv().unwrap()
    }
}

/// Runs `work` on rank 0 of `size` thread ranks (given the sweep options and the cluster) while
/// the others serve; returns its result and the exit codes the others were stopped with.
/// `readable(r)`: whether rank r can "read" the model (else it serves with an error).
fn on_ranks<T: Send>(
    model: &Model,
    size: usize,
    opts: &SweepOptions,
    readable: impl Fn(usize) -> bool + Sync,
    work: impl FnOnce(&Body, SweepOptions, Option<Arc<dyn Cluster>>) -> sparsemor::Result<T> + Send,
) -> (sparsemor::Result<T>, Vec<i32>) {
    let mut world = Threads::world(size).into_iter();
    let c0: Arc<dyn Cluster> = Arc::new(world.next().unwrap());
    std::thread::scope(|s| {
        let others: Vec<_> = world
            .map(|c| {
                let readable = &readable;
                s.spawn(move || {
                    let body = Body::new(model).unwrap();
                    let body = if readable(c.rank) {
                        Ok(&body)
                    } else {
                        Err("model.toml: no such file")
                    };
                    serve(&c, body, opts).unwrap()
                })
            })
            .collect();
        let body = Body::new(model).unwrap();
        let r = work(&body, opts.clone(), Some(c0.clone()));
        stop(&*c0, if r.is_ok() { 0 } else { 1 });
        let codes = others.into_iter().map(|h| h.join().unwrap()).collect();
        (r, codes)
    })
}

/// [`on_ranks`] with default sweep options, every rank reading the model.
fn on_all<T: Send>(
    model: &Model,
    size: usize,
    work: impl FnOnce(&Body, SweepOptions, Option<Arc<dyn Cluster>>) -> sparsemor::Result<T> + Send,
) -> (sparsemor::Result<T>, Vec<i32>) {
    on_ranks(model, size, &SweepOptions::default(), |_| true, work)
}

fn paper_bar() -> (Model, Scene) {
    let spec = BoxSpec::paper_bar();
    (bar_model(&spec).unwrap(), paper_scene(&spec))
}

fn fixed_opts(
    freqs: &[f64],
    sweep: SweepOptions,
    cluster: Option<Arc<dyn Cluster>>,
) -> LineFitOptions {
    let mut o = LineFitOptions::new(
        Interface::OutputsPlus(5),
        References::Explicit(freqs.to_vec()),
    );
    o.sweep = sweep;
    o.cluster = cluster;
    o
}

/// max over Mr, Kr, Dr, Br, Cr of ‖A − B‖_F / ‖B‖_F.
fn rom_difference(a: &Rom, b: &Rom) -> f64 {
    a.matrices()
        .iter()
        .zip(b.matrices())
        .map(|((_, x), (_, y))| (*x - y).norm_l2() / y.norm_l2().max(f64::MIN_POSITIVE))
        .fold(0.0, f64::max)
}

#[test]
fn linefit_over_ranks_equals_the_one_process_rom() {
    let (model, scene) = paper_bar();
    let freqs = [50.0, 100.0, 200.0, 400.0, 600.0, 800.0, 1000.0];
    // factored, the ranks' ROM differs from one process's by the TSQR merge's rounding only;
    // from the Krylov space, each rank grows its own space for its own frequencies, and the
    // responses agree to their certificates (relative residual 1e-10)
    for (method, tol) in [(SolveMethod::Factored, 1e-12), (SolveMethod::Auto, 1e-10)] {
        let one = SweepOptions {
            threads: 1,
            method,
            ..Default::default()
        };
        let body = Body::new(&model).unwrap();
        let reference = linefit::reduce(
            &body,
            &scene,
            &fixed_opts(&freqs, one.clone(), None),
            None,
            &no_progress,
        )
        .unwrap();
        for size in [2, 3, 4] {
            let (rom, codes) = on_ranks(
                &model,
                size,
                &one,
                |_| true,
                |body, sweep, cluster| {
                    linefit::reduce(
                        body,
                        &scene,
                        &fixed_opts(&freqs, sweep, cluster),
                        None,
                        &no_progress,
                    )
                },
            );
            let rom = rom.unwrap();
            let d = rom_difference(&rom, &reference);
            println!(
                "{method:?}, {size} ranks: max relative difference of Mr, Kr, Dr, Br, Cr {d:.1e}"
            );
            assert!(d <= tol, "{method:?}, {size} ranks: {d:.2e}");
            assert_eq!(codes, vec![0; size - 1]);
            // the solves of every rank are reported, not only rank 0's
            assert_eq!(rom.fit().unwrap().solves.frequencies, freqs.len());
            assert_eq!(rom.fit().unwrap().rows, reference.fit().unwrap().rows);
        }
    }
}

#[test]
fn sampling_loop_over_ranks_meets_its_tolerance() {
    let (model, scene) = paper_bar();
    let tol = 1e-3;
    let one = SweepOptions {
        threads: 1,
        ..Default::default()
    };
    let (rom, codes) = on_ranks(
        &model,
        2,
        &one,
        |_| true,
        |body, sweep, cluster| {
            let mut o = LineFitOptions::new(
                Interface::OutputsPlus(5),
                References::Tolerance(SamplingOptions::new(tol)),
            );
            o.sweep = sweep;
            o.cluster = cluster;
            linefit::reduce(body, &scene, &o, None, &no_progress)
        },
    );
    let rom = rom.unwrap();
    let s = rom.sampling().unwrap();
    let verified = s.verified.expect("verification ran");
    println!(
        "2 ranks, tol {tol:.0e}: {:?}, error {:.2e}, verified {:.2e} on {} points, order {}, {}",
        s.outcome,
        s.error,
        verified.error,
        verified.points,
        rom.order(),
        s.cost()
    );
    assert!(s.outcome.reached(), "{:?}", s.outcome);
    assert!(s.error <= tol && verified.error <= tol);
    // the loop grew the interface from the snapshots kept on both ranks
    assert!(
        rom.order() > scene.outputs.len() + 5,
        "order {}",
        rom.order()
    );
    // every solve of both ranks (loop + verification) is counted
    assert_eq!(
        rom.fit().unwrap().solves.frequencies,
        s.solves + verified.points
    );
    assert_eq!(codes, vec![0]);
}

#[test]
fn qdeim_growth_over_ranks_is_refused_up_front() {
    let (model, scene) = paper_bar();
    let (r, _) = on_all(&model, 2, |body, sweep, cluster| {
        let mut s = SamplingOptions::new(1e-3);
        s.growth = Growth::QDeim;
        let mut o = LineFitOptions::new(Interface::OutputsPlus(5), References::Tolerance(s));
        o.sweep = sweep;
        o.cluster = cluster;
        linefit::reduce(body, &scene, &o, None, &no_progress)
    });
    match r {
        Err(Error::InvalidSetting(m)) => assert!(m.contains("growth residual"), "{m}"),
        other => panic!("expected a refusal, got {:?}", other.map(|r| r.order())),
    }
}

/// Three undamped springs, the first with K₀₀ = (2π·1 Hz)² M₀₀: A(i·2π·1 Hz) has an exactly
/// zero diagonal entry.
fn singular_at_1_hz() -> (Model, Scene) {
    let w2 = (2.0 * std::f64::consts::PI) * (2.0 * std::f64::consts::PI);
    let k = faer::Mat::from_fn(3, 3, |i, j| {
        if i == j {
            [w2, 2.0 * w2 + 1.0, 3.0 * w2 + 2.0][i]
        } else {
            0.0
        }
    });
    let m = faer::Mat::<f64>::identity(3, 3);
    let model = Model::new(
        "springs".into(),
        sparse(&m),
        sparse(&k),
        Damping::None,
        None,
        3,
    )
    .unwrap()
    .0;
    let scene = Scene {
        inputs: vec![0, 1],
        outputs: vec![0, 2],
        band_hz: [0.1, 2.0],
    };
    (model, scene)
}

#[test]
fn a_failing_rank_fails_the_run_with_its_error() {
    let (model, scene) = singular_at_1_hz();
    // frequency k goes to rank k mod ranks: 1 Hz (index 1) to rank 1
    let (r, codes) = on_all(&model, 2, |body, sweep, cluster| {
        transfer_function(
            body,
            &scene,
            &[0.5, 1.0],
            Part::Total,
            &sweep,
            cluster,
            &no_progress,
        )
    });
    match r {
        Err(Error::Remote { rank, message }) => {
            println!("rank {rank}: {message}");
            assert_eq!(rank, 1);
            assert!(
                message.contains("at 1 Hz is numerically singular"),
                "{message}"
            );
        }
        other => panic!(
            "expected rank 1's error, got {:?}",
            other.map(|f| f.h.len())
        ),
    }
    assert_eq!(
        codes,
        vec![1],
        "the serving rank exits with rank 0's status"
    );
    // rank 0's own failure is its own error; rank 1 and 2 took the other frequencies
    let (r, codes) = on_all(&model, 3, |body, sweep, cluster| {
        transfer_function(
            body,
            &scene,
            &[1.0, 0.5, 0.7],
            Part::Total,
            &sweep,
            cluster,
            &no_progress,
        )
    });
    assert!(matches!(r, Err(Error::Singular { freq_hz, .. }) if freq_hz == 1.0));
    assert_eq!(codes, vec![1, 1]);
}

#[test]
fn a_rank_that_cannot_read_the_model_is_named() {
    let (model, scene) = paper_bar();
    let (r, codes) = on_ranks(
        &model,
        3,
        &SweepOptions::default(),
        |r| r != 2,
        |body, sweep, cluster| {
            transfer_function(
                body,
                &scene,
                &[10.0, 20.0, 30.0],
                Part::Elastic,
                &sweep,
                cluster,
                &no_progress,
            )
        },
    );
    match r {
        Err(e @ Error::Remote { rank: 2, .. }) => {
            assert_eq!(e.to_string(), "rank 2: model.toml: no such file")
        }
        other => panic!(
            "expected rank 2's error, got {:?}",
            other.map(|f| f.h.len())
        ),
    }
    assert_eq!(codes, vec![1, 1]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// Each frequency is solved by the same code on whichever rank: the transfer functions
    /// over 2–4 ranks equal the one-process ones bit for bit, for fewer frequencies than
    /// ranks too, and so do the per-frequency statistics' frequencies.
    #[test]
    fn transfer_functions_over_ranks_are_bitwise_the_same(
        seed in 0u64..1000,
        size in 2usize..=4,
        z in 1usize..7,
        damped in any::<bool>(),
    ) {
        let damping = if damped { Damping::Rayleigh { alpha: 0.0, beta: 1e-4 } } else { Damping::None };
        let model = random_model(24, 3, seed, damping);
        let scene = random_scene(24);
        let freqs = random_freqs(z, 1.0, 500.0, seed);
        let opts = SweepOptions { threads: 1, method: SolveMethod::Factored, ..Default::default() };
        let body = Body::new(&model).unwrap();
        let one = transfer_function(&body, &scene, &freqs, Part::Total, &opts, None, &no_progress);
        let (many, _) = on_ranks(&model, size, &opts, |_| true, |body, sweep, cluster| {
            transfer_function(body, &scene, &freqs, Part::Total, &sweep, cluster, &no_progress)
        });
        match (one, many) {
            (Ok(a), Ok(b)) => {
                prop_assert_eq!(&a.h, &b.h);
                let fa: Vec<f64> = a.freq_stats.iter().map(|s| s.freq_hz).collect();
                let fb: Vec<f64> = b.freq_stats.iter().map(|s| s.freq_hz).collect();
                prop_assert_eq!(fa, fb);
            }
            // a (near-)resonance refused in one process is refused over ranks too
            (Err(a), Err(b)) => prop_assert!(b.to_string().ends_with(&a.to_string()), "{} / {}", a, b),
            (a, b) => prop_assert!(false, "one process {:?}, ranks {:?}", a.is_ok(), b.is_ok()),
        }
    }
}
