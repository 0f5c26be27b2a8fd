//! Streamed QR (docs/design.md §3.3) vs dense least squares of the stacked system: time and memory
//! against m, printed as a markdown table.
//!
//! `cargo run --release --example lsq_scaling`
//!
//! Problem: n = 14 interface unknowns, 2p = 18 rows per frequency, z = 20 frequencies
//! (rows = 360), m = 10⁴, 10⁵, 10⁶ right-hand-side columns, entries uniform in [−1, 1].
//! Memory is measured with a counting global allocator: "streamed peak" is the largest
//! allocation above the inputs during `new` + the absorbs (state + transient), "state" the
//! `R, Y, e` of a new state (8·(n² + n·m + m)), `memory_bytes()` the state after the absorbs
//! (including the chunk buffers it keeps for reuse), "finish" the extra peak of `finish`
//! (mostly the m × n result W, which the dense solve produces too). Times are wall clock and
//! process CPU time (both threads), since the machine may be shared.
//! The dense solve (faer Householder QR of the stacked T_oᵀ, applied to the stacked T_nᵀ in
//! place) runs only where the stacked system 8·rows·(n + m) is ≤ 2 GB; its time excludes
//! stacking the blocks. For m = 10⁶ the streamed run cycles 4 distinct F blocks (the data do
//! not change the work) to keep the generated input at 0.6 GB.

use faer::prelude::*;
use faer::Mat;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use sparsemor::lsq::{LsqOptions, StreamedQr};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

struct Counting;
static CURRENT: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn add(n: usize) {
    let now = CURRENT.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        let p = System.alloc(l);
        if !p.is_null() {
            add(l.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        let p = System.alloc_zeroed(l);
        if !p.is_null() {
            add(l.size());
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        System.dealloc(p, l);
        CURRENT.fetch_sub(l.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        let q = System.realloc(p, l, new);
        if !q.is_null() {
            CURRENT.fetch_sub(l.size(), Ordering::Relaxed);
            add(new);
        }
        q
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Starts a measurement; returns the baseline.
fn mark() -> usize {
    let now = CURRENT.load(Ordering::Relaxed);
    PEAK.store(now, Ordering::Relaxed);
    now
}

fn peak_since(base: usize) -> usize {
    PEAK.load(Ordering::Relaxed) - base
}

/// CPU seconds of this process (all threads; Linux), NaN elsewhere. Reported next to the wall
/// time because the machine may be shared.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return f64::NAN;
    };
    let fields: Vec<&str> = stat
        .rsplit(')')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect();
    let tick = |i: usize| fields.get(i).and_then(|x| x.parse::<f64>().ok());
    match (tick(11), tick(12)) {
        (Some(u), Some(s)) => (u + s) / 100.0, // USER_HZ = 100
        _ => f64::NAN,
    }
}

fn uniform(rng: &mut StdRng, r: usize, c: usize) -> Mat<f64> {
    Mat::from_fn(r, c, |_, _| rng.gen_range(-1.0..1.0))
}

fn mib(b: usize) -> String {
    format!("{:.1} MiB", b as f64 / (1u64 << 20) as f64)
}

fn main() {
    let (n, q, z) = (14usize, 18usize, 20usize);
    let rows = q * z;
    let threads = rayon::current_num_threads();
    println!(
        "n = {n}, 2p = {q}, z = {z} (rows = {rows}), rayon threads = {threads}, \
         entries uniform in [-1, 1]\n"
    );
    println!(
        "| m | streamed wall / CPU | streamed peak extra (state + absorb transient) | state \
         R, Y, e | memory_bytes() after | finish extra (W, residuals) | dense wall / CPU | dense \
         memory 8·rows·(n+m) | dense measured peak | ‖W−W_dense‖/‖W_dense‖ |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    // Warm-up: the first gemm call per thread allocates its persistent packing buffers; keep
    // that one-time cost out of the measurements.
    {
        let mut rng = StdRng::seed_from_u64(0);
        let mut st = StreamedQr::new(n, 20_000);
        st.absorb(
            uniform(&mut rng, rows, n).as_ref(),
            uniform(&mut rng, rows, 20_000).as_ref(),
        )
        .unwrap();
        st.finish(&LsqOptions::default()).unwrap();
        let a = uniform(&mut rng, rows, n);
        let mut b = uniform(&mut rng, rows, 20_000);
        a.qr().solve_lstsq_in_place(b.as_mut());
    }
    for m in [10_000usize, 100_000, 1_000_000] {
        let dense_bytes = 8 * rows * (n + m);
        let run_dense = dense_bytes <= 2_000_000_000;
        let mut rng = StdRng::seed_from_u64(m as u64);
        let gs: Vec<Mat<f64>> = (0..z).map(|_| uniform(&mut rng, q, n)).collect();
        let nf = if run_dense { z } else { 4 };
        let fs: Vec<Mat<f64>> = (0..nf).map(|_| uniform(&mut rng, q, m)).collect();

        // Streamed.
        let base = mark();
        let t0 = Instant::now();
        let c0 = cpu_seconds();
        let mut st = StreamedQr::new(n, m);
        let core = st.memory_bytes();
        for k in 0..z {
            st.absorb(gs[k].as_ref(), fs[k % nf].as_ref()).unwrap();
        }
        let peak_absorb = peak_since(base);
        let state = st.memory_bytes();
        let base2 = mark();
        let sol = st.finish(&LsqOptions::default()).unwrap();
        let t_streamed = t0.elapsed().as_secs_f64();
        let c_streamed = cpu_seconds() - c0;
        let peak_finish = peak_since(base2);
        drop(st);

        let (t_dense, peak_dense, diff) = if run_dense {
            let mut a = Mat::<f64>::zeros(rows, n);
            let mut b = Mat::<f64>::zeros(rows, m);
            for k in 0..z {
                a.as_mut().subrows_mut(k * q, q).copy_from(&gs[k]);
                b.as_mut().subrows_mut(k * q, q).copy_from(&fs[k]);
            }
            let base = mark();
            let t0 = Instant::now();
            let c0 = cpu_seconds();
            a.qr().solve_lstsq_in_place(b.as_mut());
            let t = t0.elapsed().as_secs_f64();
            let c = cpu_seconds() - c0;
            let peak = peak_since(base) + 8 * rows * (n + m);
            let wt = b.as_ref().subrows(0, n);
            let mut num = 0.0f64;
            let mut den = 0.0f64;
            for j in 0..m {
                for i in 0..n {
                    num += (sol.w[(j, i)] - wt[(i, j)]).powi(2);
                    den += wt[(i, j)].powi(2);
                }
            }
            (
                format!("{t:.3} s / {c:.2} s"),
                mib(peak),
                format!("{:.1e}", (num / den).sqrt()),
            )
        } else {
            ("— (> 2 GB)".into(), "—".into(), "—".into())
        };
        println!(
            "| {m} | {t_streamed:.3} s / {c_streamed:.2} s | {} | {} | {} | {} | {t_dense} | {} | \
             {peak_dense} | {diff} |",
            mib(peak_absorb),
            mib(core),
            mib(state),
            mib(peak_finish),
            mib(dense_bytes),
        );
    }
}
