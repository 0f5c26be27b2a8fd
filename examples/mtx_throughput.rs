//! Matrix Market read throughput: sparsemor's reader vs sprs on a ~1e7-entry coordinate file.
//!
//! Run with `cargo run --release --example mtx_throughput [-- GRID]`; the file is a 3-D
//! 27-point stencil on a GRID^3 grid (default 72: (3*72-2)^3 = 9.8e6 entries) with random
//! full-precision values, written once into the temp directory and removed at the end
//! (`-- GRID PATH` writes it to PATH instead and keeps it).

use std::path::Path;
use std::time::Instant;

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

/// CPU time (user + system) of this process so far, in seconds, from `/proc/self/stat`
/// (Linux); `None` elsewhere.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Times `f`: (wall seconds, CPU seconds of the whole process).
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
    let c0 = cpu_seconds().unwrap_or(0.0);
    let t = Instant::now();
    let out = f();
    let wall = t.elapsed().as_secs_f64();
    let cpu = cpu_seconds().unwrap_or(0.0) - c0;
    (out, wall, cpu)
}

fn mb_s(bytes: u64, secs: f64) -> f64 {
    bytes as f64 / 1e6 / secs
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(72);
    let keep = std::env::args().nth(2).map(std::path::PathBuf::from);
    let path = keep.clone().unwrap_or_else(|| {
        std::env::temp_dir().join(format!(
            "sparsemor_mtx_throughput_{}.mtx",
            std::process::id()
        ))
    });
    let a = stencil(n);
    let ((), write_s, write_cpu) =
        timed(|| matrix_market::write_coordinate(&path, a.as_ref(), false).expect("write"));
    let bytes = std::fs::metadata(&path).expect("stat").len();
    let nnz = a.compute_nnz();
    println!(
        "file: {} entries, {:.1} MB (27-point stencil, {n}^3 grid)",
        nnz,
        bytes as f64 / 1e6,
    );
    report("sparsemor write_coordinate", bytes, write_s, write_cpu);
    drop(a);
    run(&path, bytes, nnz);
    if keep.is_none() {
        std::fs::remove_file(&path).ok();
    }
}

fn report(what: &str, bytes: u64, wall: f64, cpu: f64) {
    println!(
        "{what:<44} wall {wall:6.2} s = {:5.0} MB/s   (CPU {cpu:5.2} s = {:5.0} MB/s per CPU-second)",
        mb_s(bytes, wall),
        mb_s(bytes, cpu),
    );
}

fn run(path: &Path, bytes: u64, nnz: usize) {
    // Warm the page cache so that every reader sees the same conditions.
    let _ = std::fs::read(path).expect("read");

    let threads = rayon::current_num_threads();
    let (m, wall, cpu) = timed(|| matrix_market::read_sparse(path).expect("sparsemor read"));
    assert_eq!(m.compute_nnz(), nnz);
    report(
        &format!("sparsemor read_sparse ({threads} threads)"),
        bytes,
        wall,
        cpu,
    );
    drop(m);

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let (m, wall, cpu) =
        timed(|| pool.install(|| matrix_market::read_sparse(path).expect("sparsemor read")));
    report("sparsemor read_sparse (1 thread)", bytes, wall, cpu);
    drop(m);

    let (tri, wall, cpu) =
        timed(|| sprs::io::read_matrix_market::<f64, usize, _>(path).expect("sprs read"));
    assert_eq!(tri.nnz(), nnz);
    report("sprs read_matrix_market (triplets only)", bytes, wall, cpu);
    let (csc, wall2, cpu2) = timed(|| -> sprs::CsMat<f64> { tri.to_csc() });
    report(
        "sprs read_matrix_market + to_csc",
        bytes,
        wall + wall2,
        cpu + cpu2,
    );
    drop(csc);
}
