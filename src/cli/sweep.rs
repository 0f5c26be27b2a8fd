//! `sparsemor sweep`: H, H1 or H0 on a band or a frequency list, written as CSV.

use super::args::{human_bytes, parse_band, parse_list};
use super::progress::{rank0_share, with_progress};
use sparsemor::engine::Cluster;
use sparsemor::frf::{transfer_function, Part};
use sparsemor::grid::linspace;
use sparsemor::io::{atomic, model_dir};
use sparsemor::sweep::{FreqStats, SweepOptions};
use sparsemor::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(clap::Args)]
pub struct SweepArgs {
    /// Model directory.
    model: PathBuf,
    /// Band LO:HI in Hz (with --points).
    #[arg(long, conflicts_with = "freqs")]
    band: Option<String>,
    /// Number of linearly spaced points in the band, both ends included.
    #[arg(long, default_value_t = 500)]
    points: usize,
    /// Explicit frequencies F1,F2,... in Hz.
    #[arg(long)]
    freqs: Option<String>,
    /// total (H, eq. 14), elastic (H1, eq. 17) or rigid (H0, eq. 16).
    #[arg(long, default_value = "total")]
    part: String,
    /// Largest accepted relative error of a factorization's probe solve (after refinement);
    /// above it a frequency is refused as numerically singular.
    #[arg(long, default_value_t = sparsemor::sweep::DEFAULT_PROBE_TOL)]
    probe_tol: f64,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Factorization backend: auto, ldlt, faer-lblt, faer-lu, umfpack, mumps (under mpirun:
    /// every rank holds a part of each factorization).
    #[arg(long, default_value = "auto")]
    backend: String,
    /// Memory budget for concurrent factorizations in GB (default: half of available).
    #[arg(long, value_parser = super::args::gigabytes)]
    memory_gb: Option<usize>,
    /// Keep each factorization's factors in this directory instead of memory (backend mumps;
    /// every frequency is then factored); its files are deleted when the sweep ends.
    #[arg(long)]
    out_of_core: Option<PathBuf>,
    /// How responses are computed: auto (one Krylov space for every frequency, each response
    /// certified by its residual: shifted for proportional damping and dampers, linearized
    /// for any other; docs/design.md §3.10–§3.13) or factor (factor A(iω) at every
    /// frequency).
    #[arg(long, default_value = "auto")]
    solve: String,
    /// Output CSV: f_hz,output,input,re,im.
    #[arg(long)]
    out: PathBuf,
    /// Also write each frequency's solve statistics as CSV: f_hz, factor_s, solve_s,
    /// probe_error, backward_error, refinement_steps, pivot_ratio, pivoted, krylov_dim,
    /// relative_residual, normwise_backward_error (a response from the shifted Krylov space
    /// has krylov_dim > 0, no factorization and no probe: factor_s 0, probe_error and
    /// pivot_ratio NaN; the last two are NaN for a factored one).
    #[arg(long)]
    stats: Option<PathBuf>,
}

/// The library's messages name the value; say which flag it came from.
fn flag(flag: &str, e: Error) -> Error {
    match e {
        Error::InvalidSetting(m) => Error::InvalidSetting(format!("--{flag}: {m}")),
        e => e,
    }
}

impl SweepArgs {
    /// The model directory and the sweep options (the same on every rank of a distributed
    /// run).
    pub fn sweep_setup(&self) -> Result<(&Path, SweepOptions)> {
        let opts = SweepOptions {
            threads: self.threads,
            backend: self.backend.parse().map_err(|e| flag("backend", e))?,
            memory_budget: self.memory_gb,
            probe_tol: self.probe_tol,
            method: self.solve.parse().map_err(|e| flag("solve", e))?,
            out_of_core: self.out_of_core.clone(),
        };
        Ok((&self.model, opts))
    }
}

/// `cluster`: the ranks the frequencies are spread over (rank 0 runs this).
pub fn sweep(a: &SweepArgs, verbose: bool, cluster: Option<Arc<dyn Cluster>>) -> Result<()> {
    let (body, scene) = model_dir::read_body(&a.model)?;
    let freqs = match (&a.freqs, &a.band) {
        (Some(f), _) => parse_list::<f64>(f, "--freqs")?,
        (None, Some(b)) => linspace(parse_band(b)?, a.points),
        (None, None) => {
            return Err(Error::InvalidSetting(
                "sweep needs --band LO:HI (with --points) or --freqs F1,F2,...".into(),
            ))
        }
    };
    if freqs.is_empty() || a.points == 0 {
        return Err(Error::InvalidSetting(
            "sweep: no frequencies (--points must be >= 1)".into(),
        ));
    }
    let part: Part = a.part.parse().map_err(|e| flag("part", e))?;
    let share = rank0_share(freqs.len(), cluster.as_ref());
    let opts = a.sweep_setup()?.1;
    let frf = with_progress(share, "sweep", |cb| {
        transfer_function(&body, &scene, &freqs, part, &opts, cluster, cb)
    })?;
    write_frf_csv(&a.out, &frf.freqs_hz, &frf.h, &scene.outputs, &scene.inputs)?;
    if let Some(path) = &a.stats {
        write_stats_csv(path, &frf.freq_stats)?;
    }
    eprintln!(
        "{} frequencies in {:.2} s -> {}",
        freqs.len(),
        frf.seconds,
        a.out.display()
    );
    if verbose {
        if let (Some(s), Some(sch)) = (&frf.symbolic, &frf.schedule) {
            let fs = &frf.freq_stats;
            let worst = fs.iter().map(|s| s.probe_error).fold(0.0, f64::max);
            let worst_backward = fs.iter().map(|s| s.backward_error).fold(0.0, f64::max);
            let mean_factor = fs.iter().map(|s| s.factor_s).sum::<f64>() / fs.len().max(1) as f64;
            let (min_factor, max_factor) =
                fs.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), s| {
                    (lo.min(s.factor_s), hi.max(s.factor_s))
                });
            let mean_solve = fs.iter().map(|s| s.solve_s).sum::<f64>() / fs.len().max(1) as f64;
            let refined = fs.iter().filter(|s| s.refinement_steps > 0).count();
            let steps: usize = fs.iter().map(|s| s.refinement_steps).sum();
            let pivoted = fs.iter().filter(|s| s.pivoted).count();
            eprintln!(
                "backend {} ({}), symbolic {:.3} s, factor nnz {}, {} per factorization{}, {:?}, factor min/mean/max {:.4}/{:.4}/{:.4} s, mean solve {:.4} s, worst probe error {:.1e}, \
                 worst backward error {worst_backward:.1e}, refined {refined} of {} frequencies ({steps} steps), {pivoted} handed to the pivoting LBLᵀ",
                s.backend,
                match (s.real, s.out_of_core) {
                    (true, false) => "real",
                    (false, false) => "complex",
                    (true, true) => "real, factors out of core",
                    (false, true) => "complex, factors out of core",
                },
                s.seconds,
                s.factor_nnz,
                human_bytes(s.bytes_per_factor as f64),
                match s.ranks {
                    1 => String::new(),
                    r => format!(" on the rank that needs most of {r} sharing it"),
                },
                sch,
                min_factor,
                mean_factor,
                max_factor,
                mean_solve,
                worst,
                fs.len()
            );
        }
    }
    Ok(())
}

/// Writes the per-frequency solve statistics of a sweep as CSV, one row per frequency, full
/// precision, atomically ([`atomic::write_file`]).
fn write_stats_csv(path: &Path, stats: &[FreqStats]) -> Result<()> {
    atomic::write_file(path, |w| {
        writeln!(
            w,
            "f_hz,factor_s,solve_s,probe_error,backward_error,refinement_steps,pivot_ratio,pivoted,krylov_dim,relative_residual,normwise_backward_error"
        )?;
        for s in stats {
            writeln!(
                w,
                "{:?},{:?},{:?},{:?},{:?},{},{:?},{},{},{:?},{:?}",
                s.freq_hz,
                s.factor_s,
                s.solve_s,
                s.probe_error,
                s.backward_error,
                s.refinement_steps,
                s.pivot_ratio,
                u8::from(s.pivoted),
                s.space_dim,
                s.relative_residual,
                s.normwise_backward_error
            )?;
        }
        Ok(())
    })
}

/// Writes `f_hz,output,input,re,im`, one row per frequency × output × input (DoF indices),
/// full precision, atomically ([`atomic::write_file`]).
pub fn write_frf_csv(
    path: &Path,
    freqs: &[f64],
    h: &[faer::Mat<faer::c64>],
    outputs: &[usize],
    inputs: &[usize],
) -> Result<()> {
    atomic::write_file(path, |w| {
        writeln!(w, "f_hz,output,input,re,im")?;
        for (f, hk) in freqs.iter().zip(h) {
            for (o, &od) in outputs.iter().enumerate() {
                for (i, &id) in inputs.iter().enumerate() {
                    let z = hk[(o, i)];
                    writeln!(w, "{f:?},{od},{id},{:?},{:?}", z.re, z.im)?;
                }
            }
        }
        Ok(())
    })
}
