//! The ROM directory (docs/design.md §4): `rom.toml` (method, order, DoFs, reference frequencies,
//! fit numerics, definiteness, timings, version; for a tolerance-driven ROM a `[sampling]`
//! table with the tolerance, the error reached, its kind and the loop's status) and `Mr.mtx Dr.mtx Kr.mtx Br.mtx Cr.mtx`
//! (Matrix Market `array real general`, full double precision), optional `V.mtx`, and the
//! same ROM for Python users as `rom.npz` ([`npz`]). Written atomically ([`atomic::write_dir`]).

use crate::body::Body;
use crate::io::model_dir::toml_error;
use crate::io::{atomic, matrix_market, npz};
use crate::metrics::rom_eigenfrequencies;
use crate::reduce::linefit::{Outcome, SamplingReport, Verified};
use crate::reduce::{CraigBamptonReport, Definiteness, FitReport, Provenance, Rom, Timing};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `rom.toml`.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Manifest {
    sparsemor_version: String,
    method: String,
    /// N of the full model (absent in ROM directories written before it was recorded).
    #[serde(default)]
    full_n: Option<usize>,
    order: usize,
    dofs: Vec<usize>,
    inputs: Vec<usize>,
    outputs: Vec<usize>,
    #[serde(default)]
    ref_freqs_hz: Vec<f64>,
    #[serde(default)]
    modes: Vec<usize>,
    mass_positive_definite: bool,
    stiffness_positive_definite: bool,
    mass_eig_range: [f64; 2],
    stiffness_eig_range: [f64; 2],
    #[serde(default)]
    fit: Option<FitReport>,
    #[serde(default)]
    warnings: Vec<String>,
    #[serde(default)]
    timings_s: Vec<(String, f64)>,
    has_basis: bool,
    /// K4r.mtx holds the structural damping K₄r (docs/design.md §3.12).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    structural_damping: bool,
    #[serde(default)]
    serep_cond: Option<f64>,
    /// Craig–Bampton numerics (absent for other methods and older directories).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    craig_bampton: Option<CraigBamptonReport>,
    /// The request of a tolerance-driven line-fitting ROM and what was reached.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    sampling: Option<SamplingToml>,
}

/// `[sampling]` of `rom.toml`: the tolerance asked for, the error reached (and what kind of
/// number it is), how the loop ended.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct SamplingToml {
    tol: f64,
    status: String,
    error: f64,
    error_kind: String,
    /// Full solves of the loop (an older file without them: its factorizations, which it
    /// counted one per solve).
    #[serde(default)]
    solves: Option<usize>,
    factorizations: usize,
    /// Every factorization of the run, the verification's too (an older file without them:
    /// the loop's).
    #[serde(default)]
    factorizations_in_all: Option<usize>,
    suggested_dof: usize,
    /// Max ε of the ROM over `verified_points` full solves spread over the band.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    verified_error: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    verified_points: Option<usize>,
}

fn outcome_name(o: &Outcome) -> &'static str {
    match o {
        Outcome::Converged => "converged",
        Outcome::Confirmed => "confirmed by verification",
        Outcome::Budget => "budget spent",
        Outcome::Stagnated => "stagnated",
    }
}

/// Writes `rom` into a new directory (`rom.npz` without node data; see [`write_for_body`]).
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty; I/O errors.
pub fn write(dir: &Path, rom: &Rom) -> Result<()> {
    write_dir(dir, rom, None)
}

/// [`write()`], with the node data of the body's model in `rom.npz`: `nodes` (coordinates, one
/// row per node) and `dof_node`, `dof_dir` (node and direction of each ROM coordinate's DoF).
///
/// # Errors
/// As [`write()`].
pub fn write_for_body(dir: &Path, rom: &Rom, body: &Body) -> Result<()> {
    write_dir(dir, rom, Some(body))
}

/// `rom.npz`: the matrices exactly as in the `.mtx` files, `V` when kept, the DoF lists,
/// reference frequencies, SEREP modes, the ROM's eigenfrequencies (when Mr is positive
/// definite), node data of the body's model, and `rom.toml`'s text as `metadata`.
fn write_npz(path: &Path, rom: &Rom, body: Option<&Body>, manifest: &str) -> Result<()> {
    npz::write(path, |z| {
        for (name, m) in rom.matrices() {
            z.matrix(name, m.as_ref())?;
        }
        if let Some(v) = &rom.basis {
            z.matrix("V", v.as_ref())?;
        }
        z.indices("dofs", &rom.dofs)?;
        z.indices("inputs", &rom.inputs)?;
        z.indices("outputs", &rom.outputs)?;
        z.vector("ref_freqs_hz", rom.ref_freqs_hz())?;
        z.indices("modes", rom.modes())?;
        if let Ok(f) = rom_eigenfrequencies(rom) {
            z.vector("eigenfrequencies_hz", &f)?;
        }
        if let Some((body, nodes)) = body.and_then(|b| b.nodes().map(|n| (b, n))) {
            z.rows("nodes", nodes.as_flattened(), 3)?;
            let dpn = body.dofs_per_node();
            let (node, dir): (Vec<usize>, Vec<usize>) =
                rom.dofs.iter().map(|&d| (d / dpn, d % dpn)).unzip();
            z.indices("dof_node", &node)?;
            z.indices("dof_dir", &dir)?;
        }
        z.text("metadata", manifest)
    })
}

fn write_dir(dir: &Path, rom: &Rom, body: Option<&Body>) -> Result<()> {
    atomic::write_dir(dir, |tmp| {
        for (name, m) in rom.matrices() {
            matrix_market::write_array(&tmp.join(format!("{name}.mtx")), m.as_ref())?;
        }
        if let Some(v) = &rom.basis {
            matrix_market::write_array(&tmp.join("V.mtx"), v.as_ref())?;
        }
        let man = Manifest {
            sparsemor_version: env!("CARGO_PKG_VERSION").into(),
            method: rom.method().to_string(),
            full_n: Some(rom.full_n),
            order: rom.order(),
            dofs: rom.dofs.clone(),
            inputs: rom.inputs.clone(),
            outputs: rom.outputs.clone(),
            ref_freqs_hz: rom.ref_freqs_hz().to_vec(),
            modes: rom.modes().to_vec(),
            mass_positive_definite: rom.mass_definiteness.positive_definite,
            stiffness_positive_definite: rom.stiffness_definiteness.positive_definite,
            mass_eig_range: [rom.mass_definiteness.min_eig, rom.mass_definiteness.max_eig],
            stiffness_eig_range: [
                rom.stiffness_definiteness.min_eig,
                rom.stiffness_definiteness.max_eig,
            ],
            fit: rom.fit().cloned(),
            warnings: rom.warnings.clone(),
            timings_s: rom
                .timings
                .iter()
                .map(|t| (t.phase.clone(), t.seconds))
                .collect(),
            has_basis: rom.basis.is_some(),
            structural_damping: rom.k4r.is_some(),
            serep_cond: rom.serep_cond(),
            craig_bampton: rom.craig_bampton().cloned(),
            sampling: rom.sampling().map(|r| SamplingToml {
                tol: r.tol,
                status: outcome_name(&r.outcome).into(),
                error: r.error,
                error_kind: SamplingReport::ERROR_KIND.into(),
                solves: Some(r.solves),
                factorizations: r.factorizations,
                factorizations_in_all: Some(r.factorizations_in_all),
                suggested_dof: r.suggested_dof,
                verified_error: r.verified.map(|v| v.error),
                verified_points: r.verified.map(|v| v.points),
            }),
        };
        let text = toml::to_string(&man)
            .map_err(|e| Error::InvalidSetting(format!("cannot serialize rom.toml: {e}")))?;
        write_npz(&tmp.join("rom.npz"), rom, body, &text)?;
        atomic::write_bytes(&tmp.join("rom.toml"), text)
    })
}

/// The sampling report of a `[sampling]` table (the per-step log is not stored).
fn sampling_report(path: &Path, t: SamplingToml) -> Result<SamplingReport> {
    let outcome = [
        Outcome::Converged,
        Outcome::Confirmed,
        Outcome::Budget,
        Outcome::Stagnated,
    ]
        .into_iter()
        .find(|o| outcome_name(o) == t.status)
        .ok_or_else(|| {
            Error::parse(
                path,
                0,
                format!(
                    "[sampling] status '{}': expected converged, confirmed by verification, budget spent or stagnated",
                    t.status
                ),
            )
        })?;
    Ok(SamplingReport {
        tol: t.tol,
        steps: Vec::new(),
        outcome,
        error: t.error,
        suggested_dof: t.suggested_dof,
        verified: t
            .verified_points
            .zip(t.verified_error)
            .map(|(points, error)| Verified { points, error }),
        solves: t.solves.unwrap_or(t.factorizations),
        factorizations: t.factorizations,
        factorizations_in_all: t.factorizations_in_all.unwrap_or(t.factorizations),
        modes_in_band: None,
        spilled: false,
        spill_room: None,
    })
}

/// Reads a ROM directory written by [`write()`].
///
/// # Errors
/// File errors name the file; inconsistent shapes are [`Error::Parse`] on `rom.toml`.
pub fn read(dir: &Path) -> Result<Rom> {
    let path = dir.join("rom.toml");
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    let man: Manifest = toml::from_str(&text).map_err(|e| toml_error(&path, &text, &e))?;
    let rd = |name: &str| matrix_market::read_dense(&dir.join(format!("{name}.mtx")));
    let (mr, dr, kr, br, cr) = (rd("Mr")?, rd("Dr")?, rd("Kr")?, rd("Br")?, rd("Cr")?);
    let n = man.order;
    let shapes_ok = [&mr, &dr, &kr]
        .iter()
        .all(|m| m.nrows() == n && m.ncols() == n)
        && br.nrows() == n
        && br.ncols() == man.inputs.len()
        && cr.nrows() == man.outputs.len()
        && cr.ncols() == n;
    if !shapes_ok {
        return Err(Error::parse(
            &path,
            0,
            format!("matrix shapes do not match order = {n} and the input/output lists"),
        ));
    }
    let provenance = match (man.method.as_str(), man.fit, man.serep_cond) {
        ("linefit", Some(fit), _) => Provenance::LineFit {
            ref_freqs_hz: man.ref_freqs_hz,
            fit,
            sampling: man
                .sampling
                .map(|t| sampling_report(&path, t))
                .transpose()?,
        },
        ("serep", _, Some(cond)) => Provenance::Serep {
            modes: man.modes,
            cond,
        },
        ("linefit", None, _) => {
            return Err(Error::parse(
                &path,
                0,
                "method linefit without a [fit] table",
            ))
        }
        ("serep", _, None) => {
            return Err(Error::parse(&path, 0, "method serep without serep_cond"))
        }
        ("craig-bampton", _, _) => match man.craig_bampton {
            Some(r) => Provenance::CraigBampton(r),
            None => {
                return Err(Error::parse(
                    &path,
                    0,
                    "method craig-bampton without a [craig_bampton] table",
                ))
            }
        },
        (m, _, _) => return Err(Error::parse(&path, 0, format!("unknown method '{m}'"))),
    };
    // one full-model DoF per physical ROM coordinate (a shorter list made `dofs[i]` readers
    // index out of range; found by the `rom_dir` fuzz target); Craig–Bampton's modal
    // amplitudes follow its boundary DoFs
    let modal = match &provenance {
        Provenance::CraigBampton(r) => r.fixed_interface_hz.len() + r.residual_vectors,
        _ => 0,
    };
    if man.dofs.len() + modal != n {
        return Err(Error::parse(
            &path,
            0,
            format!(
                "`dofs` lists {} DoFs and the ROM has {modal} modal coordinates but order = {n}: a ROM has one \
                 full-model DoF per physical coordinate",
                man.dofs.len()
            ),
        ));
    }
    let basis = if man.has_basis { Some(rd("V")?) } else { None };
    let k4r = if man.structural_damping {
        let k4r = rd("K4r")?;
        if k4r.nrows() != n || k4r.ncols() != n {
            return Err(Error::parse(
                &path,
                0,
                format!(
                    "K4r.mtx is {}x{}, not order x order = {n}x{n}",
                    k4r.nrows(),
                    k4r.ncols()
                ),
            ));
        }
        Some(k4r)
    } else {
        None
    };
    if let Some(v) = &basis {
        if v.ncols() != n || man.full_n.is_some_and(|full| v.nrows() != full) {
            return Err(Error::parse(
                &path,
                0,
                format!(
                    "V.mtx is {}x{}, but the basis must be full_n x order = {}x{n}",
                    v.nrows(),
                    v.ncols(),
                    man.full_n.map_or("N".to_string(), |f| f.to_string())
                ),
            ));
        }
    }
    Ok(Rom {
        provenance,
        full_n: man.full_n.unwrap_or(0),
        mass_definiteness: Definiteness::of(mr.as_ref()),
        stiffness_definiteness: Definiteness::of(kr.as_ref()),
        mr,
        dr,
        kr,
        k4r,
        br,
        cr,
        dofs: man.dofs,
        inputs: man.inputs,
        outputs: man.outputs,
        timings: man
            .timings_s
            .into_iter()
            .map(|(phase, seconds)| Timing { phase, seconds })
            .collect(),
        warnings: man.warnings,
        basis,
    })
}
