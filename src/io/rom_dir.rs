//! The ROM directory (DESIGN.md §4): `rom.toml` (method, order, DoFs, reference frequencies,
//! fit numerics, definiteness, timings, version) and `Mr.mtx Dr.mtx Kr.mtx Br.mtx Cr.mtx`
//! (Matrix Market `array real general`, full double precision), optional `V.mtx`.
//! Written atomically ([`atomic::write_dir`]).

use crate::io::model_dir::toml_error;
use crate::io::{atomic, matrix_market};
use crate::reduce::{Definiteness, FitReport, Method, Rom, Timing};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `rom.toml`.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Manifest {
    sparsemor_version: String,
    method: String,
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
    #[serde(default)]
    serep_cond: Option<f64>,
}

/// Writes `rom` into a new directory.
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty; I/O errors.
pub fn write(dir: &Path, rom: &Rom) -> Result<()> {
    atomic::write_dir(dir, |tmp| {
        for (name, m) in [
            ("Mr", &rom.mr),
            ("Dr", &rom.dr),
            ("Kr", &rom.kr),
            ("Br", &rom.br),
            ("Cr", &rom.cr),
        ] {
            matrix_market::write_array(&tmp.join(format!("{name}.mtx")), m.as_ref())?;
        }
        if let Some(v) = &rom.basis {
            matrix_market::write_array(&tmp.join("V.mtx"), v.as_ref())?;
        }
        let man = Manifest {
            sparsemor_version: env!("CARGO_PKG_VERSION").into(),
            method: rom.method.to_string(),
            order: rom.order(),
            dofs: rom.dofs.clone(),
            inputs: rom.inputs.clone(),
            outputs: rom.outputs.clone(),
            ref_freqs_hz: rom.ref_freqs_hz.clone(),
            modes: rom.modes.clone(),
            mass_positive_definite: rom.mass_definiteness.positive_definite,
            stiffness_positive_definite: rom.stiffness_definiteness.positive_definite,
            mass_eig_range: [rom.mass_definiteness.min_eig, rom.mass_definiteness.max_eig],
            stiffness_eig_range: [
                rom.stiffness_definiteness.min_eig,
                rom.stiffness_definiteness.max_eig,
            ],
            fit: rom.fit.clone(),
            warnings: rom.warnings.clone(),
            timings_s: rom
                .timings
                .iter()
                .map(|t| (t.phase.clone(), t.seconds))
                .collect(),
            has_basis: rom.basis.is_some(),
            serep_cond: rom.serep_cond,
        };
        let text = toml::to_string(&man)
            .map_err(|e| Error::InvalidSetting(format!("cannot serialize rom.toml: {e}")))?;
        atomic::write_bytes(&tmp.join("rom.toml"), text)
    })
}

/// Reads a ROM directory written by [`write`].
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
    let method = match man.method.as_str() {
        "linefit" => Method::LineFit,
        "serep" => Method::Serep,
        m => return Err(Error::parse(&path, 0, format!("unknown method '{m}'"))),
    };
    let basis = if man.has_basis { Some(rd("V")?) } else { None };
    Ok(Rom {
        method,
        mass_definiteness: Definiteness::of(mr.as_ref()),
        stiffness_definiteness: Definiteness::of(kr.as_ref()),
        mr,
        dr,
        kr,
        br,
        cr,
        dofs: man.dofs,
        inputs: man.inputs,
        outputs: man.outputs,
        ref_freqs_hz: man.ref_freqs_hz,
        modes: man.modes,
        fit: man.fit,
        timings: man
            .timings_s
            .into_iter()
            .map(|(phase, seconds)| Timing { phase, seconds })
            .collect(),
        warnings: man.warnings,
        basis,
        serep_cond: man.serep_cond,
    })
}
