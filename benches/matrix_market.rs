//! Matrix Market read throughput: `read_sparse` vs `sprs::io::read_matrix_market`.
//!
//! Generates, in a temp dir, coordinate files of a 3-D 27-point stencil with random
//! full-precision values (about 1e6 and 1e7 entries) and reports MB/s of file size.
//! Run with `cargo bench --bench matrix_market`. Note that sprs returns triplets only, while
//! `read_sparse` also builds the CSC matrix.

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use rand::{Rng, SeedableRng};
use sparsemor::io::matrix_market;

/// The 27-point stencil matrix on an `n^3` grid ((3n-2)^3 entries), random values, built
/// directly in canonical CSC order.
fn stencil(n: usize) -> SparseColMat<usize, f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    let nn = n * n * n;
    let mut col_ptr = Vec::with_capacity(nn + 1);
    let mut row_idx = Vec::with_capacity(27 * nn);
    let mut val = Vec::with_capacity(27 * nn);
    col_ptr.push(0);
    let near = |c: usize| c.saturating_sub(1)..(c + 2).min(n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                for zz in near(z) {
                    for yy in near(y) {
                        for xx in near(x) {
                            row_idx.push((zz * n + yy) * n + xx);
                            val.push(rng.gen_range(-1.0..1.0) * 1e6);
                        }
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
    }
    SparseColMat::new(
        SymbolicSparseColMat::new_checked(nn, nn, col_ptr, None, row_idx),
        val,
    )
}

fn bench_file(c: &mut Criterion, dir: &Path, label: &str, grid: usize) {
    let path = dir.join(format!("stencil_{grid}.mtx"));
    let a = stencil(grid);
    let nnz = a.compute_nnz();
    matrix_market::write_coordinate(&path, a.as_ref(), false).expect("write the bench file");
    drop(a);
    let bytes = std::fs::metadata(&path).expect("stat").len();
    let mut group = c.benchmark_group(format!("mtx_read_{label}"));
    group.sample_size(10);
    group.throughput(Throughput::Bytes(bytes));
    eprintln!("{label}: {nnz} entries, {:.1} MB", bytes as f64 / 1e6);
    group.bench_function("sparsemor_read_sparse", |b| {
        b.iter(|| black_box(matrix_market::read_sparse(&path).expect("read")))
    });
    group.bench_function("sprs_read_matrix_market", |b| {
        b.iter(|| {
            black_box(sprs::io::read_matrix_market::<f64, usize, _>(&path).expect("sprs read"))
        })
    });
    group.finish();
    std::fs::remove_file(&path).ok();
}

fn benches(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temp dir");
    bench_file(c, dir.path(), "1e6", 34); // 100^3 = 1.0e6 entries, ~32 MB
    bench_file(c, dir.path(), "1e7", 72); // 214^3 = 9.8e6 entries, ~314 MB
}

criterion_group!(matrix_market_benches, benches);
criterion_main!(matrix_market_benches);
