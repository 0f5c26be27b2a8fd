//! Assembles a ≈10⁶-DoF bar with the built-in hex8 generator and prints its size, the
//! assembly time and the peak resident memory.
//!
//! ```text
//! cargo run --release --example gen_big_bar            # 8×10×4000 elements
//! cargo run --release --example gen_big_bar -- 4 6 9520
//! RAYON_NUM_THREADS=1 cargo run --release --example gen_big_bar
//! ```

use sparsemor::fe::{assemble, BoxSpec};
use std::time::Instant;

/// Peak resident set size (VmHWM) of this process in MiB, if /proc is available.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("usage: gen_big_bar [nx ny nz]"))
        .collect();
    let elements = match args.as_slice() {
        [] => [8, 10, 4000],
        [nx, ny, nz] => [*nx, *ny, *nz],
        _ => panic!("usage: gen_big_bar [nx ny nz]"),
    };
    // 1 mm cubes of the paper bar's material (ρ = 0.1 kg / 14.4 cm³, E = 2e10 Pa).
    let paper = BoxSpec::paper_bar();
    let size_m = elements.map(|n| n as f64 * 1e-3);
    let spec = BoxSpec {
        elements,
        size_m,
        mass_kg: paper.density() * size_m.iter().product::<f64>(),
        ..paper
    };
    println!(
        "elements {:?}, N = {} DoFs, estimated result size {:.2} GiB, {} rayon threads",
        spec.elements,
        spec.n_dofs(),
        spec.memory_estimate_bytes().unwrap_or(u64::MAX) as f64 / (1u64 << 30) as f64,
        rayon::current_num_threads()
    );
    let t = Instant::now();
    let body = match assemble(&spec) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let secs = t.elapsed().as_secs_f64();
    println!("N          = {}", body.stiffness.nrows());
    println!("nnz(K)     = {}", body.stiffness.compute_nnz());
    println!("nnz(M)     = {}", body.mass.compute_nnz());
    println!("assembly   = {secs:.3} s");
    match peak_rss_mib() {
        Some(m) => println!("peak RSS   = {m:.0} MiB (VmHWM)"),
        None => println!("peak RSS   = unavailable (no /proc/self/status)"),
    }
}
