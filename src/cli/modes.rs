//! `sparsemor modes`: eigenfrequencies counted exactly up to a bound, or the lowest c.

use super::args::{hz, parse_band};
use super::progress::with_slice_progress;
use sparsemor::eigen::{eigenpairs_with_progress, EigenOptions, Modes, Request};
use sparsemor::io::{atomic, model_dir};
use sparsemor::Result;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct ModesArgs {
    /// Model directory.
    model: PathBuf,
    /// Only the modes with LO <= f <= HI (counted exactly by inertia at both ends; LO <= 0
    /// includes the rigid modes).
    #[arg(long, conflicts_with = "count")]
    band: Option<String>,
    /// The C lowest modes, rigid ones included.
    #[arg(long)]
    count: Option<usize>,
    /// CSV: index,f_hz,kind,lambda (rigid modes at 0 Hz with their computed lambda).
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Target modes per spectrum slice.
    #[arg(long, default_value_t = EigenOptions::default().slice_size)]
    slice_size: usize,
    /// Block size of the Krylov–Schur iteration (vectors solved at once).
    #[arg(long, default_value_t = EigenOptions::default().block)]
    block: usize,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Memory budget of the run in GB: a shift's real factor that does not fit what the run
    /// has not used of it is kept on disk, in the temporary directory, and slices run at once
    /// as far as their bases fit half of what the run has not used when the slicing starts
    /// (default: half of what is available).
    #[arg(long, value_parser = super::args::gigabytes)]
    memory_gb: Option<usize>,
}

pub fn modes(a: &ModesArgs) -> Result<()> {
    let (body, scene) = model_dir::read_body(&a.model)?;
    let body = body.with_memory_budget(a.memory_gb);
    let req = match (&a.band, a.count) {
        (Some(b), _) => {
            let b = parse_band(b)?;
            Request::Band(b[0], b[1])
        }
        (None, Some(c)) => Request::Lowest(c),
        (None, None) => Request::UpTo(scene.band_hz[1]),
    };
    let opts = EigenOptions {
        slice_size: a.slice_size,
        block: a.block,
        threads: a.threads,
        ..EigenOptions::for_band(scene.band_hz[1])
    };
    let t = Instant::now();
    let m = with_slice_progress(|cb| eigenpairs_with_progress(&body, req, &opts, cb))?;
    let secs = t.elapsed().as_secs_f64();
    print_modes(&m);
    let st = &m.stats;
    println!(
        "{} modes ({} rigid) in {secs:.3} s: {} slices, {} factorizations; inertia counts {:.3} s, factor {:.3} s, Krylov {:.3} s \
         (summed over slices; {} solves, {} restarts, dim <= {}; largest relative Ritz residual {:.1e})",
        m.lambdas.len(),
        m.rigid,
        st.slices.len(),
        st.factorizations,
        st.count_s,
        st.factor_s,
        st.iterate_s,
        st.solves,
        st.restarts,
        st.krylov_dim,
        st.residual
    );
    let refined: Vec<_> = st.slices.iter().filter(|s| s.refinements > 0).collect();
    if !refined.is_empty() {
        println!(
            "{} of {} slice shifts needed iterative refinement of their LBLᵀ solves ({} steps)",
            refined.len(),
            st.slices.len(),
            refined.iter().map(|s| s.refinements).sum::<usize>()
        );
    }
    let moved: usize = st.slices.iter().map(|s| s.shift_moves).sum();
    if moved > 0 {
        println!(
            "{moved} slice shifts moved off a factor whose pivots grew (largest |l_ij| above 1000; docs/design.md §3.6)"
        );
    }
    if st.repaired_bounds > 0 {
        println!(
            "{} slice bounds needed a Rayleigh–Ritz step to make the vectors M-orthonormal across them",
            st.repaired_bounds
        );
    }
    if let Some(path) = &a.csv {
        let mut s = String::from("index,f_hz,kind,lambda\n");
        for (k, f) in m.freqs_hz().iter().enumerate() {
            s.push_str(&format!(
                "{},{:?},{},{:?}\n",
                m.stats.modes_below + k + 1,
                f,
                if k < m.rigid { "rigid" } else { "elastic" },
                m.lambdas[k]
            ));
        }
        atomic::write_bytes(path, s)?;
    }
    Ok(())
}

fn print_modes(m: &Modes) {
    for (k, f) in m.freqs_hz().iter().enumerate() {
        println!(
            "{:>4} {:>12} Hz  {:<8} backward error {:.1e}{}",
            m.stats.modes_below + k + 1,
            hz(*f, 4),
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
