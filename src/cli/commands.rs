//! `generate`, `info`, `sweep`.

use super::progress::with_progress;
use sparsemor::factor::{Analysis, Backend};
use sparsemor::fe::bracket::{bracket_model, BracketSpec};
use sparsemor::fe::BoxSpec;
use sparsemor::io::{atomic, model_dir};
use sparsemor::pencil::Pencil;
use sparsemor::rigid::RigidBody;
use sparsemor::sweep::{transfer_function, Part, SweepOptions};
use sparsemor::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Parses `AxBxC` into three values.
pub fn parse_triple<T: std::str::FromStr>(s: &str, what: &str) -> Result<[T; 3]> {
    let parts: Vec<&str> = s.split(['x', 'X']).collect();
    let bad = || Error::InvalidSetting(format!("{what} '{s}': expected three values like 2x3x45"));
    if parts.len() != 3 {
        return Err(bad());
    }
    let v: Vec<T> = parts
        .iter()
        .map(|p| p.trim().parse::<T>().map_err(|_| bad()))
        .collect::<Result<_>>()?;
    let mut it = v.into_iter();
    Ok([
        it.next().ok_or_else(bad)?,
        it.next().ok_or_else(bad)?,
        it.next().ok_or_else(bad)?,
    ])
}

/// Parses `LO:HI` (Hz).
pub fn parse_band(s: &str) -> Result<[f64; 2]> {
    let bad = || Error::InvalidSetting(format!("--band '{s}': expected LO:HI in Hz, e.g. 1:1000"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let band: [f64; 2] = [
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    ];
    if !(band[0] >= 0.0 && band[1] > band[0] && band[1].is_finite()) {
        return Err(Error::InvalidSetting(format!(
            "--band '{s}': need 0 <= LO < HI (empty band)"
        )));
    }
    Ok(band)
}

/// Parses a comma-separated list of numbers.
pub fn parse_list<T: std::str::FromStr>(s: &str, what: &str) -> Result<Vec<T>> {
    s.split(',')
        .map(|p| {
            p.trim().parse::<T>().map_err(|_| {
                Error::InvalidSetting(format!("{what}: '{}' is not a valid value", p.trim()))
            })
        })
        .collect()
}

/// `points` linearly spaced frequencies including both ends of `band`.
pub fn linspace(band: [f64; 2], points: usize) -> Vec<f64> {
    if points == 1 {
        return vec![band[0]];
    }
    (0..points)
        .map(|k| band[0] + (band[1] - band[0]) * k as f64 / (points - 1) as f64)
        .collect()
}

pub fn generate(
    kind: &str,
    elements: Option<&str>,
    size: Option<&str>,
    cell: Option<f64>,
    out: &Path,
) -> Result<()> {
    let t = Instant::now();
    let (model, scene) = match kind {
        "bar" => {
            let mut spec = BoxSpec::paper_bar();
            if let Some(e) = elements {
                spec.elements = parse_triple(e, "--elements")?;
            }
            if let Some(s) = size {
                spec.size_m = parse_triple(s, "--size")?;
            }
            (
                sparsemor::fe::bar_model(&spec)?,
                sparsemor::fe::paper_scene(&spec),
            )
        }
        "bracket" => {
            let mut spec = BracketSpec::steel();
            if let Some(h) = cell {
                spec.cell_m = h;
            }
            bracket_model(&spec)?
        }
        _ => {
            return Err(Error::InvalidSetting(format!(
                "generate '{kind}': the built-in models are `bar` and `bracket`"
            )))
        }
    };
    let t_asm = t.elapsed().as_secs_f64();
    let t = Instant::now();
    model_dir::write(out, &model, &scene)?;
    eprintln!(
        "wrote {} (N = {}, nnz(M)+nnz(K) = {}; assembled in {:.2} s, written in {:.2} s)",
        out.display(),
        model.n(),
        model.nnz(),
        t_asm,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

pub fn info(dir: &Path) -> Result<()> {
    let t = Instant::now();
    let (model, scene, report) = model_dir::read(dir)?;
    let t_read = t.elapsed().as_secs_f64();
    println!("model            {} ({})", model.name, dir.display());
    println!("N                {}", model.n());
    println!(
        "nnz              M {}  K {}  (full storage)",
        model.mass.compute_nnz(),
        model.stiffness.compute_nnz()
    );
    println!(
        "symmetry         |M-Mᵀ|/|M| = {:.1e}  |K-Kᵀ|/|K| = {:.1e}  (tolerance {:.0e})",
        report.mass_asymmetry,
        report.stiffness_asymmetry,
        sparsemor::model::SYMMETRY_RTOL
    );
    println!(
        "diag(M)          min {:.3e}  max {:.3e}",
        report.mass_diagonal[0], report.mass_diagonal[1]
    );
    println!("dofs per node    {}", model.dofs_per_node);
    println!("damping          {}", describe_damping(&model.damping));
    match &model.nodes {
        None => println!(
            "nodes            none (rigid part cannot be separated; fine for constrained bodies)"
        ),
        Some(nodes) => {
            println!("nodes            {}", nodes.len());
            let rb = RigidBody::from_nodes(&model, nodes)?;
            let free = rb.stiffness_residual <= sparsemor::rigid::FREE_BODY_RTOL;
            println!(
                "rigid modes      {} (|K V0| / |K||V0| = {:.1e})",
                if free {
                    "6: free body, elastic part separated by inertia relief"
                } else {
                    "none: constrained body"
                },
                rb.stiffness_residual
            );
        }
    }
    println!(
        "scene            {} inputs, {} outputs, band {:?} Hz",
        scene.inputs.len(),
        scene.outputs.len(),
        scene.band_hz
    );
    let pencil = Pencil::new(&model);
    let chol = sparsemor::factor::symbolic_cholesky(&pencil)?;
    // what `sweep`, `reduce` and `evaluate` will do: the same decision (Backend::resolved)
    let backend = Backend::Auto.resolved(model.n());
    let an = Analysis::new(&pencil, backend, scene.inputs.len() + 1)?;
    let s = an.stats();
    let path = match (s.backend, s.real) {
        (Backend::FaerLblt, true) => "faer LBLᵀ of the real N×N pencil (D = 0)",
        (Backend::FaerLblt, false) => {
            "faer LBLᵀ of the complex pencil as its interleaved 2N×2N real form"
        }
        (Backend::FaerLu, true) => "faer LU (COLAMD) of the real pencil (D = 0)",
        (Backend::FaerLu, false) => "faer LU (COLAMD) of the complex pencil",
        (_, true) => "UMFPACK, real",
        (_, false) => "UMFPACK, complex",
    };
    println!(
        "factorization    {} (backend auto → {}, N {} {}); real Cholesky fill nnz(L) = {}; factor {}, ~{} per factorization",
        path,
        s.backend,
        if model.n() <= sparsemor::factor::LU_MAX_N { "<=" } else { ">" },
        sparsemor::factor::LU_MAX_N,
        chol.len_val(),
        if s.factor_nnz > 0 {
            format!("{} entries", s.factor_nnz)
        } else {
            "entries known after the first numeric factorization".to_string()
        },
        human_bytes(s.bytes_per_factor as f64)
    );
    println!(
        "read in          {t_read:.2} s; symbolic analysis {:.2} s",
        s.seconds
    );
    Ok(())
}

fn describe_damping(d: &sparsemor::model::Damping) -> String {
    match d {
        sparsemor::model::Damping::None => "none (real pencil)".into(),
        sparsemor::model::Damping::Rayleigh { alpha, beta } => {
            format!("Rayleigh alpha = {alpha:e}, beta = {beta:e}")
        }
        sparsemor::model::Damping::Matrix(m) => format!("explicit D ({} entries)", m.compute_nnz()),
    }
}

/// 1234567 → "1.2 MB".
pub fn human_bytes(b: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB"];
    let mut v = b;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < units.len() {
        v /= 1000.0;
        u += 1;
    }
    format!("{v:.1} {}", units[u])
}

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
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Factorization backend: auto, faer-lblt, faer-lu, umfpack.
    #[arg(long, default_value = "auto")]
    backend: String,
    /// Memory budget for concurrent factorizations in GB (default: half of available).
    #[arg(long)]
    memory_gb: Option<f64>,
    /// Output CSV: f_hz,output,input,re,im.
    #[arg(long)]
    out: PathBuf,
}

pub fn sweep(a: &SweepArgs, verbose: bool) -> Result<()> {
    let (model, scene, _) = model_dir::read(&a.model)?;
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
    // The library's messages name the value; say which flag it came from.
    let flag = |flag: &str, e: Error| match e {
        Error::InvalidSetting(m) => Error::InvalidSetting(format!("--{flag}: {m}")),
        e => e,
    };
    let part: Part = a.part.parse().map_err(|e| flag("part", e))?;
    let opts = SweepOptions {
        threads: a.threads,
        backend: a.backend.parse().map_err(|e| flag("backend", e))?,
        memory_budget: a.memory_gb.map(|g| (g * 1e9) as usize),
        ..Default::default()
    };
    let body = sparsemor::body::Body::new(&model)?;
    let frf = with_progress(freqs.len(), "sweep", |cb| {
        transfer_function(&body, &scene, &freqs, part, false, &opts, cb)
    })?;
    write_frf_csv(&a.out, &frf.freqs_hz, &frf.h, &scene.outputs, &scene.inputs)?;
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
            let mean_factor = fs.iter().map(|s| s.factor_s).sum::<f64>() / fs.len().max(1) as f64;
            eprintln!(
                "backend {} ({}), symbolic {:.3} s, factor nnz {}, {:?}, mean factor {:.4} s, worst probe error {:.1e}",
                s.backend,
                if s.real { "real" } else { "complex" },
                s.seconds,
                s.factor_nnz,
                sch,
                mean_factor,
                worst
            );
        }
    }
    Ok(())
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
