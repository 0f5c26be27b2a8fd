//! `sparsemor modes`: eigenfrequencies counted exactly up to a bound, or the lowest c.

use super::args::parse_band;
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Modes, Request};
use sparsemor::io::{atomic, model_dir};
use sparsemor::Result;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct ModesArgs {
    /// Model directory.
    model: PathBuf,
    /// All modes with f <= HI (counted exactly); LO only filters the printout.
    #[arg(long, conflicts_with = "count")]
    band: Option<String>,
    /// The C lowest modes, rigid ones included.
    #[arg(long)]
    count: Option<usize>,
    /// CSV: index,f_hz,kind,lambda (rigid modes at 0 Hz with their computed lambda).
    #[arg(long)]
    csv: Option<PathBuf>,
}

pub fn modes(a: &ModesArgs) -> Result<()> {
    let (model, scene, _) = model_dir::read(&a.model)?;
    let body = Body::new(&model)?;
    let (req, lo) = match (&a.band, a.count) {
        (Some(b), _) => {
            let b = parse_band(b)?;
            (Request::UpTo(b[1]), b[0])
        }
        (None, Some(c)) => (Request::Lowest(c), f64::NEG_INFINITY),
        (None, None) => (Request::UpTo(scene.band_hz[1]), f64::NEG_INFINITY),
    };
    let t = Instant::now();
    let m = eigenpairs(&body, req, &EigenOptions::for_band(scene.band_hz[1]))?;
    let secs = t.elapsed().as_secs_f64();
    print_modes(&m, lo);
    println!(
        "{} modes ({} rigid) in {secs:.3} s: Cholesky {:.3} s, inertia count {:.3} s, Krylov {:.3} s ({} solves, {} restarts, dim {})",
        m.lambdas.len(),
        m.rigid,
        m.stats.factor_s,
        m.stats.count_s,
        m.stats.iterate_s,
        m.stats.solves,
        m.stats.restarts,
        m.stats.krylov_dim
    );
    if let Some(path) = &a.csv {
        let mut s = String::from("index,f_hz,kind,lambda\n");
        for (k, f) in m.freqs_hz().iter().enumerate() {
            s.push_str(&format!(
                "{},{:?},{},{:?}\n",
                k + 1,
                f,
                if k < m.rigid { "rigid" } else { "elastic" },
                m.lambdas[k]
            ));
        }
        atomic::write_bytes(path, s)?;
    }
    Ok(())
}

fn print_modes(m: &Modes, lo: f64) {
    for (k, f) in m.freqs_hz().iter().enumerate() {
        if *f >= lo || k < m.rigid {
            println!(
                "{:>4} {:>12.4} Hz  {:<8} backward error {:.1e}{}",
                k + 1,
                f,
                if k < m.rigid { "rigid" } else { "elastic" },
                m.residuals[k],
                if k < m.rigid {
                    format!("  (computed lambda {:.2e})", m.lambdas[k])
                } else {
                    String::new()
                }
            );
        }
    }
}
