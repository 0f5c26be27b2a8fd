//! Streamed QR (docs/design.md §3.3) vs dense least squares of the stacked system.
//!
//! n = 14 interface unknowns, 2p = 18 rows per frequency, z = 20 frequencies (360 rows),
//! m = 10⁴, 10⁵ (both methods) and 10⁶ (streamed only: the stacked T_nᵀ would be 2.9 GB).
//! Streamed: `StreamedQr::new` + 20 absorbs + `finish` (W and residuals). Dense: faer
//! Householder QR of the stacked T_oᵀ and `solve_lstsq_in_place` on a copy of the stacked
//! T_nᵀ (the copy is not timed). For m = 10⁶ the 20 absorbs cycle 4 distinct F blocks.

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, SamplingMode};
use faer::prelude::*;
use faer::Mat;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use sparsemor::lsq::{LsqOptions, StreamedQr};
use std::time::Duration;

fn uniform(rng: &mut StdRng, r: usize, c: usize) -> Mat<f64> {
    Mat::from_fn(r, c, |_, _| rng.gen_range(-1.0..1.0))
}

fn lsq(c: &mut Criterion) {
    let (n, q, z) = (14usize, 18usize, 20usize);
    let rows = q * z;
    let mut group = c.benchmark_group("lsq");
    group.sample_size(10);
    // Iterations take 10 ms … 5 s: equal iteration counts per sample, bounded run time.
    group.sampling_mode(SamplingMode::Flat);
    group.warm_up_time(Duration::from_secs(2));
    group.measurement_time(Duration::from_secs(15));
    for m in [10_000usize, 100_000, 1_000_000] {
        let dense = m <= 100_000;
        let mut rng = StdRng::seed_from_u64(m as u64);
        let gs: Vec<Mat<f64>> = (0..z).map(|_| uniform(&mut rng, q, n)).collect();
        let nf = if dense { z } else { 4 };
        let fs: Vec<Mat<f64>> = (0..nf).map(|_| uniform(&mut rng, q, m)).collect();

        group.bench_with_input(BenchmarkId::new("streamed", m), &m, |b, &m| {
            b.iter(|| {
                let mut st = StreamedQr::new(n, m);
                for k in 0..z {
                    st.absorb(gs[k].as_ref(), fs[k % nf].as_ref()).unwrap();
                }
                st.finish(&LsqOptions::default()).unwrap()
            })
        });

        if dense {
            let mut a = Mat::<f64>::zeros(rows, n);
            let mut bm = Mat::<f64>::zeros(rows, m);
            for k in 0..z {
                a.as_mut().subrows_mut(k * q, q).copy_from(&gs[k]);
                bm.as_mut().subrows_mut(k * q, q).copy_from(&fs[k]);
            }
            group.bench_with_input(BenchmarkId::new("dense", m), &m, |b, _| {
                b.iter_batched(
                    || bm.clone(),
                    |mut rhs| {
                        a.qr().solve_lstsq_in_place(rhs.as_mut());
                        rhs
                    },
                    BatchSize::LargeInput,
                )
            });
        }
    }
    group.finish();
}

criterion_group!(benches, lsq);
criterion_main!(benches);
