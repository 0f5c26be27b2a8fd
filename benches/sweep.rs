//! Criterion benches of the sweep phases (docs/design.md §8): symbolic analysis, numeric
//! factorization (complex 2N LBLᵀ, real LBLᵀ, faer LU, reference Cholesky) and a
//! 4-frequency sweep on 1 vs 2 threads, for the bar at N = 1656 and ≈ 1.2·10⁴.
//! Larger N are in `sparsemor bench sweep` (single runs, peak memory).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use sparsemor::body::Body;
use sparsemor::factor::{reference_cholesky, Analysis, Backend};
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::frf::{transfer_function, Part};
use sparsemor::model::{Damping, Model};
use sparsemor::pencil::Pencil;
use sparsemor::scene::Scene;
use sparsemor::sweep::{no_progress, SweepOptions};

const SIZES: [[usize; 3]; 2] = [[2, 3, 45], [3, 4, 200]];

fn spec(elements: [usize; 3]) -> BoxSpec {
    BoxSpec {
        elements,
        ..BoxSpec::paper_bar()
    }
}

fn models() -> Vec<Model> {
    SIZES
        .iter()
        .map(|&e| bar_model(&spec(e)).expect("bar"))
        .collect()
}

fn bench(c: &mut Criterion) {
    let omega = 2.0 * std::f64::consts::PI * 300.0;
    let mut g = c.benchmark_group("symbolic");
    g.sample_size(10);
    for m in models() {
        let pencil = Pencil::new(&m);
        g.bench_with_input(BenchmarkId::new("faer-lblt", m.n()), &pencil, |b, p| {
            b.iter(|| Analysis::new(p, Backend::FaerLblt, 10).unwrap())
        });
    }
    g.finish();

    let mut g = c.benchmark_group("numeric_factor");
    g.sample_size(10);
    for m in models() {
        let undamped = Model {
            damping: Damping::None,
            ..m.clone()
        };
        for (label, model, backend) in [
            ("lblt-complex", &m, Backend::FaerLblt),
            ("lblt-real", &undamped, Backend::FaerLblt),
            ("lu-complex", &m, Backend::FaerLu),
        ] {
            let pencil = Pencil::new(model);
            let an = Analysis::new(&pencil, backend, 10).unwrap();
            let mut num = an.numeric(&pencil).unwrap();
            g.bench_function(BenchmarkId::new(label, m.n()), |b| {
                b.iter(|| num.factor(&pencil, omega, faer::Par::Seq).unwrap())
            });
        }
        let pencil = Pencil::new(&m);
        g.bench_function(BenchmarkId::new("cholesky-reference", m.n()), |b| {
            b.iter(|| reference_cholesky(&pencil).unwrap())
        });
    }
    g.finish();

    let mut g = c.benchmark_group("sweep_4_freqs");
    g.sample_size(10);
    for (m, e) in models().into_iter().zip(SIZES) {
        let body = Body::new(&m).unwrap();
        let scene: Scene = paper_scene(&spec(e));
        for threads in [1, 2] {
            let opts = SweepOptions {
                threads,
                backend: Backend::FaerLblt,
                ..Default::default()
            };
            g.bench_function(BenchmarkId::new(format!("{threads}-threads"), m.n()), |b| {
                b.iter(|| {
                    transfer_function(
                        &body,
                        &scene,
                        &[150.0, 350.0, 550.0, 750.0],
                        Part::Elastic,
                        &opts,
                        None,
                        &no_progress,
                    )
                    .unwrap()
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
