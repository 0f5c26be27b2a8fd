//! `sparsemor bench sweep`: the performance table of docs/design.md §8 for the sweep phases.
//!
//! For each model (the bar at growing N, a chunky cube) and backend: symbolic time, numeric
//! factorization time per frequency (complex = damped, on 1 and 2 threads; real = undamped
//! path; timed refactorizations, after a first one), solve time, factor fill, peak memory of
//! the phase and of the numeric factorization alone, the reference real Cholesky time
//! of K + σM on the same pattern and the ratio complex ÷ Cholesky, MKL PARDISO's factor time of
//! the same complex-symmetric A(iω) (matrix type 6, `benches/pardiso_reference.py`, when
//! `pypardiso` is installed) and the ratio to it, and a 4-frequency sweep on 1 vs 2 threads.
//! Timings are single runs: quote ratios from one table.

use super::args::human_bytes;
use faer::{c64, Mat};
use sparsemor::body::Body;
use sparsemor::factor::{reference_cholesky, Analysis, Backend};
use sparsemor::fe::{paper_scene, BoxSpec};
use sparsemor::frf::{transfer_function, Part};
use sparsemor::model::{Damping, Model};
use sparsemor::pencil::Pencil;
use sparsemor::scene::Scene;
use sparsemor::sweep::{no_progress, SweepOptions};
use sparsemor::{memory, Error, Result};
use std::time::Instant;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// What to measure: `sweep` (factorization phases), `reduce` (line-fitting phases),
    /// `modes` (the eigensolver against SciPy's eigsh) or `real` (the real factor in memory
    /// against on disk).
    what: String,
    /// Largest N to include (the 10⁶ bar takes minutes and ~10 GB).
    #[arg(long, default_value_t = 1_100_000)]
    max_n: usize,
    /// Backends, comma-separated (ldlt, faer-lblt, faer-lu, umfpack); default: all in this build.
    #[arg(long)]
    backends: Option<String>,
    /// Largest N for faer LU (its COLAMD fill explodes on 3-D pencils).
    #[arg(long, default_value_t = 20_000)]
    lu_max_n: usize,
    /// `modes`: largest N for the SciPy reference (its SuperLU fill grows fast).
    #[arg(long, default_value_t = 50_000)]
    scipy_max_n: usize,
    /// `modes`, `real`: model directories measured after the generated bodies,
    /// comma-separated (the tet10 parts of `python3 benches/parts.py all --out-root DIR`).
    #[arg(long, value_delimiter = ',')]
    models: Vec<std::path::PathBuf>,
}

struct Case {
    name: &'static str,
    elements: [usize; 3],
    size_m: [f64; 3],
}

const CASES: [Case; 5] = [
    Case {
        name: "bar 2x3x45",
        elements: [2, 3, 45],
        size_m: [0.006, 0.008, 0.3],
    },
    Case {
        name: "bar 3x4x200",
        elements: [3, 4, 200],
        size_m: [0.006, 0.008, 0.3],
    },
    Case {
        name: "bar 4x6x950",
        elements: [4, 6, 950],
        size_m: [0.006, 0.008, 0.3],
    },
    Case {
        name: "cube 32^3",
        elements: [32, 32, 32],
        size_m: [0.1, 0.1, 0.1],
    },
    Case {
        name: "bar 4x6x9520",
        elements: [4, 6, 9520],
        size_m: [0.006, 0.008, 3.0],
    },
];

pub fn run(a: &BenchArgs) -> Result<()> {
    match a.what.as_str() {
        "sweep" => {}
        "reduce" => return reduce_table(a),
        "real" => return real_table(a),
        "modes" => {
            return super::bench_modes::run(a.max_n, a.scipy_max_n, &a.models, &[1, 2]);
        }
        w => {
            return Err(Error::InvalidSetting(format!(
                "bench '{w}': available: sweep, reduce, modes, real"
            )))
        }
    }
    let backends: Vec<Backend> = match &a.backends {
        None if cfg!(feature = "umfpack") => {
            vec![
                Backend::Ldlt,
                Backend::FaerLblt,
                Backend::FaerLu,
                Backend::Umfpack,
            ]
        }
        None => vec![Backend::Ldlt, Backend::FaerLblt, Backend::FaerLu],
        Some(list) => list
            .split(',')
            .map(|b| b.trim().parse())
            .collect::<Result<_>>()?,
    };
    if backends.contains(&Backend::Umfpack) && !cfg!(feature = "umfpack") {
        return Err(Error::InvalidSetting(
            "--backends umfpack: this build has no UMFPACK; rebuild with \
             `cargo build --release --features umfpack` (needs libsuitesparse-dev)"
                .into(),
        ));
    }
    let pardiso_dir =
        std::env::temp_dir().join(format!("sparsemor-bench-sweep-{}", std::process::id()));
    let mut pardiso_note = None;
    println!("| model | N | backend | symbolic s | factor s (complex) | factor s, 2 thr | factor s (real) | solve s | nnz(factor) | peak mem | numeric mem | chol(K) s | real LDLᵀ s | complex ÷ chol | PARDISO factor s (1 / 2 thr) | ÷ PARDISO (1 / 2 thr) | sweep 1 thr s | sweep 2 thr s | speed-up |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for case in &CASES {
        let spec = BoxSpec {
            elements: case.elements,
            size_m: case.size_m,
            ..BoxSpec::paper_bar()
        };
        if spec.n_dofs() > a.max_n {
            continue;
        }
        let model = sparsemor::fe::bar_model(&spec)?;
        let scene = paper_scene(&spec);
        let pardiso = match pardiso_reference(&pardiso_dir, &model, &scene) {
            Ok(p) => Some(p),
            Err(e) => {
                pardiso_note = Some(e.to_string());
                None
            }
        };
        for &backend in &backends {
            if backend == Backend::FaerLu && model.n() > a.lu_max_n {
                continue;
            }
            // UMFPACK with Debian's reference BLAS needs minutes per factorization on the cube
            // (measured 143 s with METIS, 861 s with AMD at 10⁵ DoF) and tens of GB at 10⁶
            if backend == Backend::Umfpack && (model.n() > 200_000 || case.name.starts_with("cube"))
            {
                continue;
            }
            let row = measure(&model, &scene, backend)?;
            let (pardiso_s, ratio) = match &pardiso {
                Some([p1, p2]) => (
                    format!("{p1:.3} / {p2:.3}"),
                    format!(
                        "{:.2} / {:.2}",
                        row.factor_complex_s / p1,
                        row.factor_complex2_s / p2
                    ),
                ),
                None => ("—".into(), "—".into()),
            };
            println!(
                "| {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.4} | {} | {} | {} | {:.3} | {:.3} | {:.2} | {pardiso_s} | {ratio} | {:.2} | {:.2} | {:.2} |",
                case.name,
                model.n(),
                backend,
                row.symbolic_s,
                row.factor_complex_s,
                row.factor_complex2_s,
                row.factor_real_s,
                row.solve_s,
                if row.nnz > 0 {
                    row.nnz.to_string()
                } else {
                    "— (a)".to_string()
                },
                human_bytes(row.peak as f64),
                human_bytes(row.numeric_peak as f64),
                row.chol_s,
                row.ldlt_real_s,
                row.factor_complex_s / row.chol_s,
                row.sweep1_s,
                row.sweep2_s,
                row.sweep1_s / row.sweep2_s
            );
        }
    }
    let _ = std::fs::remove_dir_all(&pardiso_dir);
    println!();
    println!("(a) faer LU and UMFPACK size their factors during the numeric factorization; their symbolic analysis reports no fill.");
    if let Some(note) = pardiso_note {
        println!("PARDISO columns empty: {note}");
    }
    Ok(())
}

/// MKL PARDISO's factor time (phase 22, matrix type 6) of the same A(iω) at 300 Hz with 1 and
/// 2 threads, by `benches/pardiso_reference.py` on the model written to `dir`.
fn pardiso_reference(dir: &std::path::Path, model: &Model, scene: &Scene) -> Result<[f64; 2]> {
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/pardiso_reference.py");
    let _ = std::fs::remove_dir_all(dir);
    sparsemor::io::model_dir::write(dir, model, scene)?;
    let mut seconds = [0.0; 2];
    for (t, s) in seconds.iter_mut().enumerate() {
        let run = std::process::Command::new("python3")
            .arg(&script)
            .arg(dir)
            .args([
                "300",
                &(scene.inputs.len() + 1).to_string(),
                &(t + 1).to_string(),
            ])
            .output()
            .map_err(|e| Error::io(&script, e))?;
        let stdout = String::from_utf8_lossy(&run.stdout);
        *s = super::bench_modes::json_number(&stdout, "factor_s")
            .filter(|_| run.status.success())
            .ok_or_else(|| {
                Error::InvalidSetting(format!(
                    "{}: {}",
                    script.display(),
                    String::from_utf8_lossy(&run.stderr).trim()
                ))
            })?;
    }
    Ok(seconds)
}

struct Row {
    symbolic_s: f64,
    factor_complex_s: f64,
    factor_complex2_s: f64,
    factor_real_s: f64,
    solve_s: f64,
    nnz: usize,
    peak: usize,
    numeric_peak: usize,
    chol_s: f64,
    ldlt_real_s: f64,
    sweep1_s: f64,
    sweep2_s: f64,
}

fn measure(model: &Model, scene: &Scene, backend: Backend) -> Result<Row> {
    let omega = 2.0 * std::f64::consts::PI * 300.0;
    let p = scene.inputs.len();
    memory::reset_peak_rss();
    let base = memory::rss_bytes().unwrap_or(0);
    let pencil = Pencil::new(model);
    let an = Analysis::new(&pencil, backend, p + 1)?;
    let body = Body::new(model)?;
    let load = body.unit_load(&scene.inputs);
    let mut rhs = Mat::<c64>::from_fn(load.nrows(), load.ncols(), |i, j| load[(i, j)].into());
    // the numeric factorization's own memory (values of A, L and D, work buffers): its peak
    // RSS above what the pencil and the analysis hold
    let symbolic_peak = memory::peak_rss_bytes().unwrap_or(0);
    let held = memory::rss_bytes().unwrap_or(0);
    memory::reset_peak_rss();
    let mut num = an.numeric(&pencil)?;
    // timed: refactorizations into memory the first one touched, as a sweep worker's every
    // frequency after its first (PARDISO's phase 22 is timed the same way)
    num.factor(&pencil, omega, faer::Par::Seq)?;
    let t = Instant::now();
    num.factor(&pencil, omega, faer::Par::Seq)?;
    let factor_complex_s = t.elapsed().as_secs_f64();
    // the second thread's buffers are allocated by the first two-thread factorization
    let mut two =
        || sparsemor::pool::with_pool(2, || num.factor(&pencil, omega, faer::Par::rayon(2)));
    two()??;
    let t = Instant::now();
    two()??;
    let factor_complex2_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    num.solve(rhs.as_mut(), faer::Par::Seq);
    let solve_s = t.elapsed().as_secs_f64();
    let numeric_peak = memory::peak_rss_bytes().unwrap_or(0);
    let peak = numeric_peak.max(symbolic_peak).saturating_sub(base);
    let numeric_peak = numeric_peak.saturating_sub(held);
    let nnz = an.stats().factor_nnz;
    let symbolic_s = an.stats().seconds;
    drop(num);
    drop(an);
    // real path: the same model without damping
    let undamped = Model {
        damping: Damping::None,
        structural: Default::default(),
        ..model.clone()
    };
    let pencil_r = Pencil::new(&undamped);
    let an_r = Analysis::new(&pencil_r, backend, p + 1)?;
    let mut num_r = an_r.numeric(&pencil_r)?;
    let t = Instant::now();
    num_r.factor(&pencil_r, omega, faer::Par::Seq)?;
    let factor_real_s = t.elapsed().as_secs_f64();
    drop(num_r);
    drop(an_r);
    let (_, chol_s, ldlt_real_s) = reference_cholesky(&pencil)?;
    // 4 frequencies (2 above 5·10⁴ DoF, where one factorization takes tens of seconds)
    let freqs: &[f64] = if model.n() > 50_000 {
        &[350.0, 750.0]
    } else {
        &[150.0, 350.0, 550.0, 750.0]
    };
    let sweep = |threads| -> Result<f64> {
        let opts = SweepOptions {
            threads,
            backend,
            ..Default::default()
        };
        let t = Instant::now();
        transfer_function(
            &body,
            scene,
            freqs,
            Part::Elastic,
            &opts,
            None,
            &no_progress,
        )?;
        Ok(t.elapsed().as_secs_f64())
    };
    let sweep1_s = sweep(1)?;
    let sweep2_s = sweep(2)?;
    Ok(Row {
        symbolic_s,
        factor_complex_s,
        factor_complex2_s,
        factor_real_s,
        solve_s,
        nnz,
        peak,
        numeric_peak,
        chol_s,
        ldlt_real_s,
        sweep1_s,
        sweep2_s,
    })
}

/// `bench reduce`: line-fitting (order 14, 20 reference frequencies in the band) per phase
/// vs N, with the peak RSS of the whole reduction and one factorization's estimated bytes.
/// `bench real`: the in-house real LDLᵀ of K + (2π·1 Hz)²M on 2 threads with L in memory and
/// on disk (docs/design.md §3.1, "Factor out of core"): factorization and one 12-column block
/// solve, the peak RSS of each (the process's, the model's matrices included: `base` is the
/// RSS before either), bytes written and read; then, in memory, the indefinite K − σM at the
/// band's top (σ = (2π f_hi)², its negative pivots ν the modes below). Beside each, MKL
/// PARDISO on the same lower triangle and 2 threads (`benches/pardiso_reference.py --real`,
/// when `pypardiso` is installed): matrix type 2 (Cholesky) on the definite matrix, −2
/// (Bunch–Kaufman LDLᵀ) with its inertia on the indefinite one.
fn real_table(a: &BenchArgs) -> Result<()> {
    use sparsemor::io::model_dir;
    let dir = std::env::temp_dir().join(format!("sparsemor-bench-real-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let mut note = None;
    println!("| model | N | nnz(L) | symbolic s | base RSS | in core: factor s | solve s | peak RSS | on disk: factor s | solve s | peak RSS | written | read | PARDISO 2: factor s | ÷ PARDISO | band's top: factor s | ν | PARDISO −2: factor s | ν (perturbed) | ÷ PARDISO |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for case in &CASES {
        let spec = BoxSpec {
            elements: case.elements,
            size_m: case.size_m,
            ..BoxSpec::paper_bar()
        };
        if spec.n_dofs() <= a.max_n {
            let body = Body::new(&sparsemor::fe::bar_model(&spec)?)?;
            rows.push(real_row(
                case.name,
                &body,
                paper_scene(&spec).band_hz[1],
                &dir,
                &mut note,
            ));
        }
    }
    for path in &a.models {
        let (body, scene) = model_dir::read_body(path)?;
        if body.n() <= a.max_n {
            let name = path.display().to_string();
            rows.push(real_row(&name, &body, scene.band_hz[1], &dir, &mut note));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    rows.into_iter().collect::<Result<Vec<()>>>()?;
    if let Some(note) = note {
        println!("\nPARDISO columns empty: {note}");
    }
    Ok(())
}

/// One row of [`real_table`]; `note` keeps why PARDISO gave no time.
fn real_row(
    name: &str,
    body: &Body,
    band_top_hz: f64,
    dir: &std::path::Path,
    note: &mut Option<String>,
) -> Result<()> {
    use sparsemor::factor::{time_real_factor, Storage};
    let t = Instant::now();
    let sym = body.symbolic()?;
    let symbolic_s = t.elapsed().as_secs_f64();
    let base = memory::rss_bytes().unwrap_or(0);
    let on_disk = Storage {
        dir: None,
        budget: 0,
    };
    let definite = -(2.0 * std::f64::consts::PI).powi(2);
    let top = sparsemor::units::hz_to_lambda(band_top_hz);
    let mut cells = Vec::new();
    for (sigma, storage) in [
        (definite, Storage::IN_CORE),
        (definite, on_disk),
        (top, Storage::IN_CORE),
    ] {
        memory::reset_peak_rss();
        let r = sparsemor::pool::with_pool(2, || {
            time_real_factor(
                body.pencil(),
                sym.clone(),
                sigma,
                storage,
                12,
                faer::Par::rayon(2),
            )
        })??;
        cells.push((r, memory::peak_rss_bytes().unwrap_or(0)));
    }
    let [(core, core_peak), (disk, disk_peak), (indefinite, _)] = [cells[0], cells[1], cells[2]];
    let mut pardiso = |sigma: f64, mtype: i32| match pardiso_real(dir, body, sigma, mtype) {
        Ok(r) => Some(r),
        Err(e) => {
            note.get_or_insert(e.to_string());
            None
        }
    };
    let (spd, ldlt) = (pardiso(definite, 2), pardiso(top, -2));
    let seconds = |r: &Option<PardisoReal>, ours: f64| match r {
        Some(r) => (
            format!("{:.2}", r.factor_s),
            format!("{:.2}", ours / r.factor_s),
        ),
        None => ("—".into(), "—".into()),
    };
    let (spd_s, spd_ratio) = seconds(&spd, core.factor_s);
    let (ldlt_s, ldlt_ratio) = seconds(&ldlt, indefinite.factor_s);
    let ldlt_nu = ldlt.map_or("—".into(), |r| {
        format!("{} ({})", r.negative, r.perturbed)
    });
    let nu = if indefinite.perturbed > 0 {
        format!(
            "{} ({} perturbed)",
            indefinite.negative, indefinite.perturbed
        )
    } else {
        indefinite.negative.to_string()
    };
    println!(
        "| {name} | {} | {} | {symbolic_s:.2} | {} | {:.2} | {:.3} | {} | {:.2} | {:.3} | {} | {} | {} | {spd_s} | {spd_ratio} | {:.2} | {nu} | {ldlt_s} | {ldlt_nu} | {ldlt_ratio} |",
        body.n(),
        core.factor_nnz,
        human_bytes(base as f64),
        core.factor_s,
        core.solve_s,
        human_bytes(core_peak as f64),
        disk.factor_s,
        disk.solve_s,
        human_bytes(disk_peak as f64),
        human_bytes(disk.place.written as f64),
        human_bytes(disk.place.read as f64),
        indefinite.factor_s,
    );
    Ok(())
}

/// MKL PARDISO's real factorization of one matrix ([`pardiso_real`]).
#[derive(Clone, Copy)]
struct PardisoReal {
    factor_s: f64,
    /// Its inertia's negative count (matrix type −2; 0 for type 2).
    negative: usize,
    /// Pivots it perturbed (type −2).
    perturbed: usize,
}

/// PARDISO (matrix type `mtype`, 2 threads, 12 right-hand sides) on the lower triangle of
/// K − σM, written to `dir` for `benches/pardiso_reference.py --real`.
fn pardiso_real(dir: &std::path::Path, body: &Body, sigma: f64, mtype: i32) -> Result<PardisoReal> {
    let p = body.pencil();
    let mut vals = vec![0.0; p.nnz()];
    p.fill_shifted(sigma, &mut vals);
    let a = sparsemor::sparse::from_parts(
        p.n(),
        p.n(),
        p.col_ptr().to_vec(),
        p.row_idx().to_vec(),
        vals,
    );
    let path = dir.join("A.mtx");
    sparsemor::io::matrix_market::write_coordinate(&path, a.as_ref(), true)?;
    drop(a);
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/pardiso_reference.py");
    let run = std::process::Command::new("python3")
        .arg(&script)
        .arg("--real")
        .arg(&path)
        .args([mtype.to_string().as_str(), "12", "2"])
        .output()
        .map_err(|e| Error::io(&script, e))?;
    let _ = std::fs::remove_file(&path);
    let out = String::from_utf8_lossy(&run.stdout);
    let number = |key: &str| super::bench_modes::json_number(&out, key);
    let failed = || {
        Error::InvalidSetting(format!(
            "{}: {}",
            script.display(),
            String::from_utf8_lossy(&run.stderr).trim()
        ))
    };
    let factor_s = number("factor_s")
        .filter(|_| run.status.success())
        .ok_or_else(failed)?;
    Ok(PardisoReal {
        factor_s,
        negative: number("negative").unwrap_or(0.0) as usize,
        perturbed: number("perturbed").unwrap_or(0.0) as usize,
    })
}

fn reduce_table(a: &BenchArgs) -> Result<()> {
    use sparsemor::reduce::interface::Interface;
    use sparsemor::reduce::linefit::{LineFitOptions, References};
    use sparsemor::reduce::{reduce, Context, Reductor};
    println!("| model | N | symbolic s | sweep (factor+solve+absorb) s | absorb s | fit + projection s | total s | peak RSS | one factorization (est.) | streamed QR state |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for case in CASES.iter().filter(|c| c.name.starts_with("bar")) {
        let spec = BoxSpec {
            elements: case.elements,
            size_m: case.size_m,
            ..BoxSpec::paper_bar()
        };
        if spec.n_dofs() > a.max_n {
            continue;
        }
        let model = sparsemor::fe::bar_model(&spec)?;
        // 20 reference frequencies at every size
        let z = 20;
        let freqs: Vec<f64> = (1..=z)
            .map(|k| 1000.0 / z as f64 * k as f64 - 3.0)
            .collect();
        let opts = LineFitOptions::new(Interface::OutputsPlus(5), References::Explicit(freqs));
        let scene = paper_scene(&spec);
        memory::reset_peak_rss();
        let t = Instant::now();
        let body = Body::new(&model)?;
        drop(model); // as `sparsemor reduce`: the body holds the matrices
        let rom = reduce(&body, &scene, &Reductor::LineFit(opts), &Context::default())?;
        let total = t.elapsed().as_secs_f64();
        let peak = memory::peak_rss_bytes().unwrap_or(0);
        let an = Analysis::new(body.pencil(), Backend::Auto, scene.inputs.len() + 1)?;
        let phase = |name: &str| {
            rom.timings
                .iter()
                .find(|t| t.phase.starts_with(name))
                .map(|t| t.seconds)
                .unwrap_or(f64::NAN)
        };
        println!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {} | {} | {} |",
            case.name,
            body.n(),
            phase("symbolic"),
            phase("sweep"),
            phase("absorb"),
            phase("fit"),
            total,
            human_bytes(peak as f64),
            human_bytes(an.stats().bytes_per_factor as f64),
            human_bytes((8 * 14 * (body.n() + 14)) as f64)
        );
    }
    Ok(())
}
