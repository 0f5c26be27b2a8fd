//! The model directory (docs/design.md §4): `model.toml` + Matrix Market matrices + `nodes.csv`.
//!
//! ```toml
//! name = "bar"
//! mass = "M.mtx"            # Matrix Market coordinate real, symmetric or general; .gz ok
//! stiffness = "K.mtx"
//! # damping = "D.mtx"       # optional explicit damping; else [rayleigh]
//! nodes = "nodes.csv"       # optional, header x,y,z; node i owns DoFs dofs_per_node·i ..
//! dofs_per_node = 3
//! [rayleigh]                # D = alpha*M + beta*K when no damping file
//! alpha = 0.0
//! beta = 1e-5
//! [scene]                   # CLI flags override
//! inputs = [0, 1, 2]
//! outputs = [0, 1, 2]
//! band_hz = [0.0, 1000.0]
//! [source]                  # optional: written by `sparsemor import`
//! format = "ansys-full"     # io::import::Format::name
//! producer = "ANSYS 15.0 (LINUX x64), jobname file"
//! units = "..."             # as the source records them
//! files = ["file.full"]
//! dof_map = "dofs.csv"      # header node,dir; one row per DoF (node number, x..rz)
//! removed = "removed.csv"   # optional: the constrained DoFs the import removed
//! ```
//!
//! Paths are relative to the directory. Unknown keys are errors (a typo must not silently
//! drop a setting). [`read`] validates the whole model ([`Model::new`]); [`write()`] writes a
//! directory atomically ([`atomic::write_dir`]: a temporary sibling renamed at the end), so an
//! interrupted write never leaves a directory that looks complete.

use crate::io::import::Dof;
use crate::io::{atomic, matrix_market};
use crate::model::{Damping, Model, ValidationReport};
use crate::scene::Scene;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// The manifest file name.
pub const MANIFEST: &str = "model.toml";

/// `model.toml` as written on disk.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Model name.
    pub name: String,
    /// Mass matrix file.
    pub mass: String,
    /// Stiffness matrix file.
    pub stiffness: String,
    /// Optional damping matrix file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<String>,
    /// Optional node coordinates file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<String>,
    /// DoFs per node (3 or 6).
    #[serde(default = "three")]
    pub dofs_per_node: usize,
    /// Rayleigh coefficients (used when there is no damping file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rayleigh: Option<Rayleigh>,
    /// The default scene.
    pub scene: SceneToml,
    /// Where an imported model came from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<SourceToml>,
}

fn three() -> usize {
    3
}

/// `[rayleigh]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rayleigh {
    /// α (1/s).
    #[serde(default)]
    pub alpha: f64,
    /// β (s).
    #[serde(default)]
    pub beta: f64,
}

/// `[scene]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneToml {
    /// Input DoFs (0-based).
    pub inputs: Vec<usize>,
    /// Output DoFs (0-based).
    pub outputs: Vec<usize>,
    /// Band [f_lo, f_hi] in Hz.
    pub band_hz: [f64; 2],
}

/// `[source]`: the provenance of an imported model ([`crate::io::import`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceToml {
    /// The format read (`ansys-full`, `ansys-apdl-math`, `abaqus-coordinate`, ...).
    pub format: String,
    /// Who wrote the files, as they say.
    pub producer: String,
    /// The units as the source records them.
    pub units: String,
    /// The files read.
    pub files: Vec<String>,
    /// CSV file (`node,dir`) naming every DoF in matrix order.
    pub dof_map: String,
    /// CSV file (`node,dir`) of the constrained DoFs that were removed, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub removed: Option<String>,
}

/// An imported model's provenance for [`write_with_source`]: the `[source]` table (its
/// `dof_map` and `removed` names are set by the writer) and the DoF lists written next to it.
#[derive(Clone, Debug)]
pub struct Source<'a> {
    /// The table.
    pub toml: SourceToml,
    /// The DoF of every row/column, written to `dofs.csv`.
    pub dofs: &'a [Dof],
    /// The constrained DoFs removed, written to `removed.csv` when not empty.
    pub removed: &'a [Dof],
}

/// The DoF map of an imported model directory (`[source] dof_map`), `None` for a directory
/// without `[source]`.
///
/// # Errors
/// [`Error::Io`]; [`Error::Parse`] with the line of a row that is not `node,dir`.
pub fn read_dof_map(dir: &Path) -> Result<Option<Vec<Dof>>> {
    let Some(src) = read_manifest(dir)?.source else {
        return Ok(None);
    };
    let path = dir.join(&src.dof_map);
    let text = super::read_regular_text(&path)?;
    text.lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            l.replacen(',', ":", 1)
                .parse::<Dof>()
                .map_err(|e| Error::parse(&path, i + 1, e.to_string()))
        })
        .collect::<Result<Vec<_>>>()
        .map(Some)
}

fn write_dofs(path: &Path, dofs: &[Dof]) -> Result<()> {
    let mut s = String::with_capacity(16 * dofs.len() + 9);
    s.push_str("node,dir\n");
    for d in dofs {
        let _ = writeln!(s, "{},{}", d.node, d.dir);
    }
    std::fs::write(path, s).map_err(|e| Error::io(path, e))
}

/// Reads only the manifest.
///
/// # Errors
/// [`Error::Io`] or [`Error::Parse`] with the line of the TOML error.
pub fn read_manifest(dir: &Path) -> Result<Manifest> {
    let path = dir.join(MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    toml::from_str(&text).map_err(|e| toml_error(&path, &text, &e))
}

/// A TOML error as [`Error::Parse`] at the 1-based line where its span starts (0 without a
/// span). The line is the number of newlines before the span plus one, so a span at the very
/// start of a line (an unknown key) is reported on that line, not the one before.
pub(crate) fn toml_error(path: &Path, text: &str, e: &toml::de::Error) -> Error {
    let line = e
        .span()
        .map(|s| {
            text.as_bytes()[..s.start.min(text.len())]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
                + 1
        })
        .unwrap_or(0);
    Error::parse(path, line, e.message().to_string())
}

/// Reads and validates a model directory: the model, its default scene (`[scene]`) and what
/// the validation measured.
///
/// # Errors
/// Any file error names the file (and line); validation errors name the field.
pub fn read(dir: &Path) -> Result<(Model, Scene, ValidationReport)> {
    let man = read_manifest(dir)?;
    let mass = matrix_market::read_sparse(&dir.join(&man.mass))?;
    let stiffness = matrix_market::read_sparse(&dir.join(&man.stiffness))?;
    let damping = match (&man.damping, &man.rayleigh) {
        (Some(d), _) => Damping::Matrix(matrix_market::read_sparse(&dir.join(d))?),
        (None, Some(r)) => Damping::Rayleigh {
            alpha: r.alpha,
            beta: r.beta,
        },
        (None, None) => Damping::None,
    };
    let nodes = man
        .nodes
        .as_ref()
        .map(|f| read_nodes(&dir.join(f)))
        .transpose()?;
    let scene = Scene {
        inputs: man.scene.inputs,
        outputs: man.scene.outputs,
        band_hz: man.scene.band_hz,
    };
    let named = |e| match e {
        Error::InvalidModel(m) => {
            Error::InvalidModel(format!("{}: {m}", dir.join(MANIFEST).display()))
        }
        Error::InvalidSetting(m) => {
            Error::InvalidSetting(format!("{}: {m}", dir.join(MANIFEST).display()))
        }
        Error::DofOutOfRange { what, dof, n } => Error::DofOutOfRange {
            what: format!("{}: {what}", dir.join(MANIFEST).display()),
            dof,
            n,
        },
        e => e,
    };
    let (model, report) =
        Model::new(man.name, mass, stiffness, damping, nodes, man.dofs_per_node).map_err(named)?;
    scene.validate(model.n(), "scene").map_err(named)?;
    Ok((model, scene, report))
}

/// Reads `nodes.csv`: header `x,y,z`, then one node per line.
///
/// # Errors
/// [`Error::Parse`] naming the line for a bad header, a wrong column count or a bad number.
pub fn read_nodes(path: &Path) -> Result<Vec<[f64; 3]>> {
    let text = super::read_regular_text(path)?;
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.split(',').map(str::trim).eq(["x", "y", "z"]) => {}
        _ => return Err(Error::parse(path, 1, "expected the header `x,y,z`")),
    }
    let mut nodes = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let mut xyz = [0.0; 3];
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != 3 {
            return Err(Error::parse(
                path,
                i + 1,
                format!("expected 3 comma-separated values, found {}", fields.len()),
            ));
        }
        for (c, f) in xyz.iter_mut().zip(&fields) {
            *c = f
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::parse(
                        path,
                        i + 1,
                        format!("'{}' is not a finite number", f.trim()),
                    )
                })?;
        }
        nodes.push(xyz);
    }
    Ok(nodes)
}

/// Writes `model` with its default `scene` into a new directory `dir` (M.mtx, K.mtx, [D.mtx],
/// [nodes.csv], model.toml), atomically.
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty; I/O errors.
pub fn write(dir: &Path, model: &Model, scene: &Scene) -> Result<()> {
    write_with_source(dir, model, scene, None)
}

/// [`write()`] plus, for an imported model, the `[source]` table with `dofs.csv` (and
/// `removed.csv` when DoFs were removed).
///
/// # Errors
/// As [`write()`].
pub fn write_with_source(
    dir: &Path,
    model: &Model,
    scene: &Scene,
    source: Option<&Source<'_>>,
) -> Result<()> {
    atomic::write_dir(dir, |tmp| {
        matrix_market::write_coordinate(&tmp.join("M.mtx"), model.mass.as_ref(), true)?;
        matrix_market::write_coordinate(&tmp.join("K.mtx"), model.stiffness.as_ref(), true)?;
        let (damping, rayleigh) = match &model.damping {
            Damping::None => (None, None),
            Damping::Rayleigh { alpha, beta } => (
                None,
                Some(Rayleigh {
                    alpha: *alpha,
                    beta: *beta,
                }),
            ),
            Damping::Matrix(d) => {
                matrix_market::write_coordinate(&tmp.join("D.mtx"), d.as_ref(), true)?;
                (Some("D.mtx".to_string()), None)
            }
        };
        if let Some(nodes) = &model.nodes {
            let mut s = String::with_capacity(nodes.len() * 40);
            s.push_str("x,y,z\n");
            for p in nodes {
                let _ = writeln!(s, "{:?},{:?},{:?}", p[0], p[1], p[2]);
            }
            atomic::write_bytes(&tmp.join("nodes.csv"), s)?;
        }
        let man = Manifest {
            name: model.name.clone(),
            mass: "M.mtx".into(),
            stiffness: "K.mtx".into(),
            damping,
            nodes: model.nodes.as_ref().map(|_| "nodes.csv".into()),
            dofs_per_node: model.dofs_per_node,
            rayleigh,
            scene: SceneToml {
                inputs: scene.inputs.clone(),
                outputs: scene.outputs.clone(),
                band_hz: scene.band_hz,
            },
            source: source
                .map(|src| -> Result<SourceToml> {
                    write_dofs(&tmp.join("dofs.csv"), src.dofs)?;
                    let removed = if src.removed.is_empty() {
                        None
                    } else {
                        write_dofs(&tmp.join("removed.csv"), src.removed)?;
                        Some("removed.csv".to_string())
                    };
                    Ok(SourceToml {
                        dof_map: "dofs.csv".into(),
                        removed,
                        ..src.toml.clone()
                    })
                })
                .transpose()?,
        };
        let text = toml::to_string(&man)
            .map_err(|e| Error::InvalidModel(format!("cannot serialize manifest: {e}")))?;
        atomic::write_bytes(&tmp.join(MANIFEST), text)
    })
}
