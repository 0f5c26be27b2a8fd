//! `sparsemor evaluate`: ε(f) of a ROM against its model, the ROM's eigenfrequencies, the
//! one-to-one MAC pairing and stability.

use super::args::{hz, hz_list, parse_band};
use super::progress::{rank0_share, with_progress, with_slice_progress};
use sparsemor::eigen::{eigenpairs_with_progress, EigenOptions, Request};
use sparsemor::engine::Cluster;
use sparsemor::factor::{count_eigenvalues_below_with, Storage};
use sparsemor::grid::linspace;
use sparsemor::io::{atomic, model_dir, rom_dir};
use sparsemor::metrics::{
    modal_comparison, rom_spectrum, ErrorCurve, ModalComparison, Reference, Stability,
};
use sparsemor::reduce::Rom;
use sparsemor::scene::{positive_band, Scene};
use sparsemor::sweep::SweepOptions;
use sparsemor::units::hz_to_lambda;
use sparsemor::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(clap::Args)]
pub struct EvaluateArgs {
    /// Model directory.
    model: PathBuf,
    /// ROM directory.
    rom: PathBuf,
    /// Band LO:HI in Hz (default: the model's band, starting at 1 Hz on a free body if it starts at 0).
    #[arg(long)]
    band: Option<String>,
    /// Grid points, both ends included.
    #[arg(long, default_value_t = 500)]
    points: usize,
    /// Write ε(f) as CSV: f_hz,eps_elastic,eps_total.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Largest accepted relative error of a factorization's probe solve (after refinement);
    /// above it a frequency is refused as numerically singular.
    #[arg(long, default_value_t = sparsemor::sweep::DEFAULT_PROBE_TOL)]
    probe_tol: f64,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Only the transfer-function error: no eigenpairs of the model, no modal table.
    #[arg(long)]
    no_modes: bool,
    /// Skip the modal table (with a line saying so) when the band holds more modes than this
    /// (counted by inertia, one factorization).
    #[arg(long, default_value_t = 300)]
    max_modes: usize,
}

/// The requested (or the scene's) band, starting above 0 Hz ([`positive_band`]).
pub(super) fn evaluation_band(scene: &Scene, band: Option<&str>) -> Result<[f64; 2]> {
    Ok(positive_band(match band {
        Some(s) => parse_band(s)?,
        None => scene.band_hz,
    }))
}

impl EvaluateArgs {
    /// The model directory and the sweep options of the full-model solves (the same on every
    /// rank of a distributed run).
    pub fn sweep_setup(&self) -> (&Path, SweepOptions) {
        let opts = SweepOptions {
            threads: self.threads,
            probe_tol: self.probe_tol,
            ..Default::default()
        };
        (&self.model, opts)
    }
}

/// `cluster`: the ranks the full-model solves are spread over (rank 0 runs this).
pub fn evaluate(a: &EvaluateArgs, cluster: Option<Arc<dyn Cluster>>) -> Result<()> {
    let (body, scene) = model_dir::read_body(&a.model)?;
    let rom = rom_dir::read(&a.rom)?;
    rom.check_model(body.n())
        .map_err(|e| Error::InvalidSetting(format!("{}: {e}", a.rom.display())))?;
    let band = evaluation_band(&scene, a.band.as_deref())?;
    let rom_scene = Scene {
        inputs: rom.inputs.clone(),
        outputs: rom.outputs.clone(),
        band_hz: band,
    };
    if a.points < 2 {
        return Err(Error::InvalidSetting("--points must be >= 2".into()));
    }
    let freqs = linspace(band, a.points);
    let share = rank0_share(freqs.len(), cluster.as_ref());
    let opts = a.sweep_setup().1;
    let curve = with_progress(share, "evaluate", |cb| {
        Reference::compute(&body, &rom_scene, &freqs, &opts, cluster, cb)?.error(&rom)
    })?;
    print_errors(&rom, &curve)?;
    if band[1] > scene.band_hz[1] * (1.0 + 1e-12) {
        println!(
            "note             the evaluation band ends at {} Hz, {:.1}x the model's band end {} Hz that reductions \
             target: errors above it measure extrapolation",
            band[1],
            band[1] / scene.band_hz[1],
            scene.band_hz[1]
        );
    }
    if a.no_modes {
        println!("modes            not computed (--no-modes)");
    } else {
        let in_band = count_eigenvalues_below_with(
            &body.symbolic()?,
            body.pencil(),
            hz_to_lambda(band[1]),
            Storage::available(),
        )?;
        if in_band > a.max_modes {
            println!(
                "modes            not computed: {in_band} modes up to {} Hz exceed --max-modes {}",
                band[1], a.max_modes
            );
        } else {
            let full = with_slice_progress(|cb| {
                eigenpairs_with_progress(
                    &body,
                    Request::UpTo(band[1]),
                    &EigenOptions::default(),
                    cb,
                )
            })?;
            let modal = modal_comparison(&rom, &full, rom.basis.as_ref().map(|v| v.as_ref()))?;
            print_modal(&rom, &modal);
        }
    }
    if let Some(path) = &a.csv {
        write_eps_csv(path, &curve)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn print_errors(rom: &Rom, curve: &ErrorCurve) -> Result<()> {
    let (emax, emean) = ErrorCurve::max_mean(&curve.eps_elastic);
    let (tmax, tmean) = ErrorCurve::max_mean(&curve.eps_total);
    println!(
        "eps elastic      max {:.3e}  mean {:.3e}   ({} points in [{}, {}] Hz)",
        emax,
        emean,
        curve.freqs_hz.len(),
        curve.freqs_hz[0],
        curve.freqs_hz[curve.freqs_hz.len() - 1]
    );
    println!("eps total        max {tmax:.3e}  mean {tmean:.3e}");
    let f = rom_spectrum(rom)?.freqs_hz;
    println!("ROM eigenfreqs   {}", hz_list(&f, 1, " "));
    println!(
        "largest          {} Hz",
        hz(f.last().copied().unwrap_or(f64::NAN), 1)
    );
    println!("stability        {}", Stability::of(rom));
    Ok(())
}

fn print_modal(rom: &Rom, modal: &ModalComparison) {
    println!(
        "modes in band    (MAC {})",
        if modal.expanded {
            "of expanded modes V·phi"
        } else {
            "on the ROM DoFs; --keep-basis gives expanded MAC"
        }
    );
    for p in &modal.pairs {
        println!(
            "  full {:>3} {:>9.2} Hz   rom {:>3} {:>9.2} Hz   rel err {:.2e}   MAC {:.5}",
            p.full_mode, p.full_hz, p.rom_mode, p.rom_hz, p.rel_freq_error, p.mac
        );
    }
    for (k, f) in &modal.unpaired {
        println!(
            "  full {k:>3} {f:>9.2} Hz   unpaired: beyond the ROM's {} modes",
            rom.order()
        );
    }
}

fn write_eps_csv(path: &Path, c: &ErrorCurve) -> Result<()> {
    let mut s = String::from("f_hz,eps_elastic,eps_total\n");
    for k in 0..c.freqs_hz.len() {
        s.push_str(&format!(
            "{:?},{:?},{:?}\n",
            c.freqs_hz[k], c.eps_elastic[k], c.eps_total[k]
        ));
    }
    atomic::write_bytes(path, s)
}
