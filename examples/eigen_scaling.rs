//! Time and peak memory of `eigenpairs` on the built-in bar at N ≈ 1.2·10⁴, 10⁵ and 10⁶ DoF,
//! Krylov (always) and ARPACK (with `--features arpack`); prints a markdown table.
//!
//! ```text
//! cargo run --release --example eigen_scaling                     # all cases
//! cargo run --release --features arpack --example eigen_scaling   # + ARPACK
//! cargo run --release --example eigen_scaling -- 0 1              # only cases 0 and 1
//! ```
//!
//! Every (case, backend) runs in a child process of its own, so its peak resident memory
//! (VmHWM, reset after the model is assembled) is not inflated by an earlier run. The table
//! gives the model's resident memory before the eigensolve and the peak during it (model
//! included).

use sparsemor::eigen::{eigenpairs, EigenBackend, EigenOptions, Request, RIGID_RTOL};
use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::memory::{peak_rss_bytes, reset_peak_rss, rss_bytes};
use std::process::Command;
use std::time::Instant;

/// (elements, length along z in m, request). Cross-section 6 × 8 mm and density of the
/// paper bar.
const CASES: [([usize; 3], f64, Request); 3] = [
    ([3, 4, 200], 0.3, Request::UpTo(1000.0)),
    ([4, 6, 950], 0.3, Request::UpTo(1000.0)),
    ([4, 6, 9520], 3.0, Request::Lowest(20)),
];

fn spec(case: usize) -> BoxSpec {
    let (elements, len, _) = CASES[case];
    let paper = BoxSpec::paper_bar();
    let size_m = [paper.size_m[0], paper.size_m[1], len];
    BoxSpec {
        elements,
        size_m,
        mass_kg: paper.density() * size_m.iter().product::<f64>(),
        ..paper
    }
}

fn gib(b: Option<usize>) -> String {
    b.map_or("n/a".into(), |b| {
        format!("{:.2}", b as f64 / (1u64 << 30) as f64)
    })
}

/// One measurement in the child: prints one `|`-separated table row.
fn child(case: usize, backend: EigenBackend) -> Result<(), String> {
    let model = bar_model(&spec(case)).map_err(|e| e.to_string())?;
    let req = CASES[case].2;
    let rss_model = rss_bytes();
    reset_peak_rss();
    let t = Instant::now();
    let body = sparsemor::body::Body::new(&model).map_err(|e| e.to_string())?;
    let modes = eigenpairs(
        &body,
        req,
        &EigenOptions {
            backend,
            ..EigenOptions::for_band(sparsemor::fe::PAPER_BAND_HZ[1])
        },
    )
    .map_err(|e| e.to_string())?;
    let secs = t.elapsed().as_secs_f64();
    let peak = peak_rss_bytes();
    let s = &modes.stats;
    // what the former rigid rule |λ| ≤ RIGID_RTOL·max K_ii/M_ii would have counted
    let diag = |a: &sparsemor::sparse::Csc, i: usize| {
        let rows = a.symbolic().row_idx_of_col_raw(i);
        rows.binary_search(&i)
            .map(|p| a.val_of_col(i)[p])
            .unwrap_or(0.0)
    };
    let scale = (0..model.n())
        .map(|i| diag(&model.stiffness, i) / diag(&model.mass, i))
        .fold(0.0, f64::max);
    let old_rigid = modes
        .lambdas
        .iter()
        .filter(|l| l.abs() <= RIGID_RTOL * scale)
        .count();
    let f = modes.freqs_hz();
    let worst_res = modes.residuals.iter().copied().fold(0.0, f64::max);
    let req_s = match req {
        Request::UpTo(f) => format!("≤ {f} Hz"),
        Request::Lowest(c) => format!("lowest {c}"),
        Request::Band(lo, hi) => format!("{lo}–{hi} Hz"),
    };
    println!(
        "ROW|{}|{:?}|{req_s}|{backend}|{}|{} ({old_rigid})|{:.1}–{:.1}|{secs:.2}|{:.2}|{:.2}|{:.2}|{}|{}|{:.1}|{:.0e}|{}|{}",
        model.n(),
        CASES[case].0,
        modes.lambdas.len(),
        modes.rigid,
        f[modes.rigid.min(f.len() - 1)],
        f[f.len() - 1],
        s.factor_s,
        s.count_s,
        s.iterate_s,
        s.solves,
        s.restarts,
        s.factor_nnz as f64 / 1e6,
        worst_res,
        gib(rss_model),
        gib(peak),
    );
    Ok(())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--child") {
        let case: usize = args[1].parse().expect("case");
        let backend = if args[2] == "arpack" {
            EigenBackend::Arpack
        } else {
            EigenBackend::Krylov
        };
        if let Err(e) = child(case, backend) {
            println!("ERR|{e}");
            std::process::exit(1);
        }
        return;
    }
    let cases: Vec<usize> = if args.is_empty() {
        (0..CASES.len()).collect()
    } else {
        args.iter()
            .map(|a| a.parse().expect("case numbers 0..3"))
            .collect()
    };
    let mut backends = vec!["krylov"];
    if cfg!(feature = "arpack") {
        backends.push("arpack");
    }
    let exe = std::env::current_exe().expect("own path");
    println!("| N | elements | request | backend | modes | rigid (old rule) | elastic f (Hz) | total s | Cholesky s | inertia s | iterate s | solves | restarts | nnz(L) 1e6 | max backward err | model RSS GiB | peak RSS GiB |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for &case in &cases {
        for b in &backends {
            let out = Command::new(&exe)
                .args(["--child", &case.to_string(), b])
                .output()
                .expect("run child");
            let text = String::from_utf8_lossy(&out.stdout);
            match text
                .lines()
                .find(|l| l.starts_with("ROW|") || l.starts_with("ERR|"))
            {
                Some(l) if l.starts_with("ROW|") => println!("| {} |", l[4..].replace('|', " | ")),
                Some(l) => println!("| case {case} | {b} | error: {} |", &l[4..]),
                None => println!(
                    "| case {case} | {b} | child failed: {} |",
                    String::from_utf8_lossy(&out.stderr)
                        .lines()
                        .last()
                        .unwrap_or("")
                ),
            }
        }
    }
}
