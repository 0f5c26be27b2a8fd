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
//! # structural_damping = "K4.mtx"  # optional structural damping matrix K4
//! [structural]              # optional loss factor: A(iω) = (1 + i eta)K + iK4 − ω²M + iωD
//! eta = 0.02
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
//! Instead of `mass`/`stiffness`, a model may point at the files its FE code wrote, read by
//! [`crate::io::import`] at every load (a big model need not be converted):
//!
//! ```toml
//! name = "rotor"
//! [import]
//! format = "ansys-full"     # checked against what the files are (io::import::Format::name)
//! files = ["rotor.full"]    # relative to the directory; K=/M= prefixes as for `import`
//! scale_stiffness = 1e-2    # optional
//! length_unit = "mm"        # optional: "m" (default, kept) or "mm" (mm-t-s-N -> m-kg-s-N)
//! [scene]
//! inputs = ["17:x", "17:y"] # DoFs by index or NODE:DIR
//! outputs = ["17:x"]
//! band_hz = [0.0, 1000.0]
//! ```
//!
//! DoFs (in `[scene]` and on the command line) are 0-based indices or `NODE:DIR` names
//! ([`DofNames`]): through the DoF map of an imported model, else node i = row i of
//! `nodes.csv` (0-based) owning DoFs `dofs_per_node·i + k` in the directions x, y, z (, rx, ry,
//! rz).
//!
//! Paths are relative to the directory. Unknown keys are errors (a typo must not silently
//! drop a setting). [`read`] validates the whole model ([`Model::new`]); [`write()`] writes a
//! directory atomically ([`atomic::write_dir`]: a temporary sibling renamed at the end), so an
//! interrupted write never leaves a directory that looks complete.

use crate::body::Body;
use crate::coupled::{self, Coordinate, Functional, Joints};
use crate::coupling::Kind;
use crate::io::file::read_regular_text;
use crate::io::import::{self, Direction, Dof};
use crate::io::joints::{self, RemotePointToml};
use crate::io::{atomic, matrix_market};
use crate::model::{Damping, Model, Structural, ValidationReport};
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
    /// Mass matrix file (absent with `[import]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<String>,
    /// Stiffness matrix file (absent with `[import]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<String>,
    /// Optional damping matrix file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<String>,
    /// Optional node coordinates file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<String>,
    /// DoFs per node (3 or 6; default 3; an `[import]` model takes it from its files).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dofs_per_node: Option<usize>,
    /// Rayleigh coefficients (used when there is no damping file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rayleigh: Option<Rayleigh>,
    /// Optional structural damping matrix file K₄ (A(iω) = K + i(ηK + K₄) − ω²M + iωD).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structural_damping: Option<String>,
    /// `[structural]`: a uniform loss factor η.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structural: Option<StructuralToml>,
    /// The default scene.
    pub scene: SceneToml,
    /// Where an imported model came from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<SourceToml>,
    /// Read the FE code's own files instead of `mass`/`stiffness`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub import: Option<ImportToml>,
    /// Remote points (`[[remote_points]]`, docs/design.md §3.11).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub remote_points: Vec<RemotePointToml>,
}

/// `[import]`: the files an FE code wrote, read by [`crate::io::import::read`] at every load.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportToml {
    /// The format the files must be ([`crate::io::import::Format::name`]).
    pub format: String,
    /// The files, relative to the directory (`K=`/`M=` prefixes allowed).
    pub files: Vec<String>,
    /// Multiply K by this factor.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale_stiffness: Option<f64>,
    /// `m` (kept, the default) or `mm` (mm-t-s-N converted to m-kg-s-N).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length_unit: Option<String>,
}

/// A DoF in `[scene]`: a 0-based index or a `NODE:DIR` name ([`DofNames`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum DofRef {
    /// 0-based index.
    Index(u64),
    /// `NODE:DIR`, e.g. `17:x`.
    Name(String),
}

/// How the DoFs of a model are named: `NODE:DIR` through an imported model's DoF map, else
/// node i (0-based) owning DoFs `dofs_per_node·i + k` in the directions x, y, z (, rx, ry, rz).
#[derive(Clone, Debug)]
pub enum DofNames {
    /// The DoF map of an imported model (node numbers as the FE code numbers them).
    Map(std::collections::HashMap<Dof, usize>),
    /// A model without a DoF map: N DoFs, `dofs_per_node` per node.
    PerNode {
        /// N.
        n: usize,
        /// 3 or 6.
        dofs_per_node: usize,
    },
    /// A coupled model (docs/design.md §3.11): each DoF's name (`NODE:DIR` of the original
    /// DoF, `POINT:DIR`, or a scene matrix's row) and index.
    Coupled(std::collections::HashMap<String, usize>),
}

impl DofNames {
    /// The names of an imported model's DoFs, in matrix order.
    pub fn from_map(dofs: &[Dof]) -> Self {
        DofNames::Map(dofs.iter().enumerate().map(|(i, &d)| (d, i)).collect())
    }

    /// The index of `token`: a 0-based index (< N) or `NODE:DIR`.
    ///
    /// # Errors
    /// [`Error::DofOutOfRange`] for an index ≥ N; [`Error::InvalidSetting`] naming `what` and
    /// the token when the model has no such DoF or the token is neither form.
    pub fn index(&self, token: &str, what: &str) -> Result<usize> {
        let token = token.trim();
        if let Ok(i) = token.parse::<usize>() {
            return self.checked(i, what);
        }
        if let Some(i) = self.point_name(token) {
            return Ok(i);
        }
        let n = match self {
            DofNames::Map(m) => m.len(),
            DofNames::PerNode { n, .. } => *n,
            DofNames::Coupled(m) => m.len(),
        };
        let dof: Dof = token
            .parse()
            .map_err(|e| Error::InvalidSetting(format!("{what}: {e}, or a 0-based index")))?;
        let found = match self {
            DofNames::Map(m) => m.get(&dof).copied(),
            DofNames::PerNode { dofs_per_node, .. } => {
                let k = dof.dir as usize;
                usize::try_from(dof.node)
                    .ok()
                    .and_then(|node| node.checked_mul(*dofs_per_node))
                    .and_then(|first| first.checked_add(k))
                    .filter(|&i| k < *dofs_per_node && i < n)
            }
            DofNames::Coupled(m) => m.get(&dof.to_string()).copied(),
        };
        found.ok_or_else(|| {
            let why = match self {
                DofNames::Map(_) => "not in its DoF map: constrained, or not in the files".into(),
                DofNames::PerNode { dofs_per_node, .. } => format!(
                    "{} nodes numbered from 0, {dofs_per_node} DoFs each ({})",
                    n / dofs_per_node,
                    Direction::ALL[..*dofs_per_node]
                        .iter()
                        .map(|d| d.label())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                DofNames::Coupled(_) => "a DoF rigidly coupled to a remote point, or a \
                    functional's pivot, is no longer one of its DoFs: name the point's \
                    POINT:DIR"
                    .into(),
            };
            Error::InvalidSetting(format!("{what}: the model has no DoF {dof} ({why})"))
        })
    }

    /// A coupled model's DoF named other than `NODE:DIR`: a point's `POINT:DIR` (direction in
    /// any case) or a scene matrix's row, verbatim.
    fn point_name(&self, token: &str) -> Option<usize> {
        let DofNames::Coupled(m) = self else {
            return None;
        };
        let key = match token.split_once(':') {
            Some((a, d)) if a.trim().parse::<u64>().is_err() => match d.parse::<Direction>() {
                Ok(dir) => format!("{}:{dir}", a.trim()),
                Err(_) => token.to_string(),
            },
            _ => token.to_string(),
        };
        m.get(&key).copied()
    }

    /// The name of every DoF, in order (`NODE:DIR`; a coupled model's own names).
    pub fn names(&self) -> Vec<String> {
        match self {
            DofNames::Map(m) => by_index(m.iter().map(|(d, &i)| (d.to_string(), i)), m.len()),
            DofNames::PerNode { n, dofs_per_node } => (0..*n)
                .map(|i| {
                    format!(
                        "{}:{}",
                        i / dofs_per_node,
                        Direction::ALL[i % dofs_per_node]
                    )
                })
                .collect(),
            DofNames::Coupled(m) => by_index(m.iter().map(|(s, &i)| (s.clone(), i)), m.len()),
        }
    }

    /// `i` when it is a DoF of the model (< N).
    fn checked(&self, i: usize, what: &str) -> Result<usize> {
        let n = match self {
            DofNames::Map(m) => m.len(),
            DofNames::PerNode { n, .. } => *n,
            DofNames::Coupled(m) => m.len(),
        };
        if i < n {
            Ok(i)
        } else {
            Err(Error::DofOutOfRange {
                what: what.to_string(),
                dof: i,
                n,
            })
        }
    }

    /// The indices of a comma-separated list of DoFs ([`Self::index`]).
    ///
    /// # Errors
    /// As [`Self::index`], for the first bad token.
    pub fn indices(&self, list: &str, what: &str) -> Result<Vec<usize>> {
        list.split(',').map(|t| self.index(t, what)).collect()
    }

    fn resolve(&self, refs: &[DofRef], what: &str) -> Result<Vec<usize>> {
        refs.iter()
            .map(|r| match r {
                DofRef::Index(i) => self.checked(usize::try_from(*i).unwrap_or(usize::MAX), what),
                DofRef::Name(s) => self.index(s, what),
            })
            .collect()
    }
}

/// Names placed at their indices 0..n.
fn by_index(named: impl Iterator<Item = (String, usize)>, n: usize) -> Vec<String> {
    let mut v = vec![String::new(); n];
    for (s, i) in named {
        v[i] = s;
    }
    v
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

/// `[structural]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StructuralToml {
    /// The loss factor η ≥ 0 on K (e.g. 0.02; twice the modal damping ratio at resonance).
    pub eta: f64,
}

/// `[scene]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneToml {
    /// Input DoFs (0-based indices, `NODE:DIR` or a remote point's `POINT:DIR`).
    #[serde(default)]
    pub inputs: Vec<DofRef>,
    /// Output DoFs (as `inputs`).
    #[serde(default)]
    pub outputs: Vec<DofRef>,
    /// Band [f_lo, f_hi] in Hz.
    pub band_hz: [f64; 2],
    /// More inputs: the columns of B (N × p, Matrix Market), after `inputs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input_matrix: Option<String>,
    /// More outputs: the rows of C (q × N, Matrix Market), after `outputs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_matrix: Option<String>,
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
    read_manifest(dir)?
        .source
        .map(|src| read_dofs(&dir.join(&src.dof_map)))
        .transpose()
}

fn read_dofs(path: &Path) -> Result<Vec<Dof>> {
    let text = read_regular_text(path)?;
    text.lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            l.replacen(',', ":", 1)
                .parse::<Dof>()
                .map_err(|e| Error::parse(path, i + 1, e.to_string()))
        })
        .collect()
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
/// the validation measured ([`load`] without the DoF names).
///
/// # Errors
/// As [`load`].
pub fn read(dir: &Path) -> Result<(Model, Scene, ValidationReport)> {
    let l = load(dir)?;
    Ok((l.model, l.scene, l.report))
}

/// [`read`], prepared for computation: the [`Body`] and the default scene. The full-storage
/// model is dropped once the body is built, which holds the matrices once (its pencil's lower
/// triangles; docs/design.md §2).
///
/// # Errors
/// As [`load`] and [`Body::new`].
pub fn read_body(dir: &Path) -> Result<(Body, Scene)> {
    let l = load(dir)?;
    Ok((Body::new(&l.model)?, l.scene))
}

/// A model directory as [`load`] returns it.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The validated model.
    pub model: Model,
    /// Its default scene (`[scene]`).
    pub scene: Scene,
    /// What the validation measured.
    pub report: ValidationReport,
    /// How its DoFs are named (`NODE:DIR`).
    pub names: DofNames,
    /// What the importer noticed, for an `[import]` model (lumped mass, ...).
    pub notes: Vec<String>,
}

/// Reads and validates a model directory: from `mass`/`stiffness` Matrix Market files, or from
/// the FE code's own files named by `[import]`.
///
/// # Errors
/// Any file error names the file (and line); validation errors name `model.toml` and the
/// field.
pub fn load(dir: &Path) -> Result<Loaded> {
    load_with_joints(dir).map(|(loaded, _)| loaded)
}

/// [`load`], and for a coupled model (docs/design.md §3.11) its [`Joints`]: the model before
/// coupling and the change of variables, which the exports with remote points as interface
/// nodes need (§3.9).
///
/// # Errors
/// As [`load`].
pub fn load_with_joints(dir: &Path) -> Result<(Loaded, Option<Joints>)> {
    let man = read_manifest(dir)?;
    let manifest = dir.join(MANIFEST);
    let named = |e| match e {
        Error::InvalidModel(m) => Error::InvalidModel(format!("{}: {m}", manifest.display())),
        Error::InvalidSetting(m) => Error::InvalidSetting(format!("{}: {m}", manifest.display())),
        Error::DofOutOfRange { what, dof, n } => Error::DofOutOfRange {
            what: format!("{}: {what}", manifest.display()),
            dof,
            n,
        },
        e => e,
    };
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
    let (model, report, names, notes) = match (&man.import, &man.mass, &man.stiffness) {
        (None, Some(m), Some(k)) => {
            let mass = matrix_market::read_sparse(&dir.join(m))?;
            let stiffness = matrix_market::read_sparse(&dir.join(k))?;
            let dofs_per_node = man.dofs_per_node.unwrap_or(3);
            let (model, report) = Model::new(
                man.name.clone(),
                mass,
                stiffness,
                damping,
                nodes,
                dofs_per_node,
            )
            .map_err(named)?;
            let names = match &man.source {
                Some(src) => {
                    let path = dir.join(&src.dof_map);
                    let dofs = read_dofs(&path)?;
                    if dofs.len() != model.n() {
                        return Err(Error::parse(
                            &path,
                            0,
                            format!("{} DoFs named for a model of N = {}", dofs.len(), model.n()),
                        ));
                    }
                    DofNames::from_map(&dofs)
                }
                None => DofNames::PerNode {
                    n: model.n(),
                    dofs_per_node,
                },
            };
            (model, report, names, Vec::new())
        }
        (Some(imp), None, None) => {
            let files: Vec<_> = imp.files.iter().map(|f| in_dir(dir, f)).collect();
            let mut im = import::read(&files)?;
            if im.format.name() != imp.format {
                return Err(named(Error::InvalidSetting(format!(
                    "[import] format = \"{}\", but the files are {} ({}): correct the format",
                    imp.format,
                    im.format.name(),
                    im.producer
                ))));
            }
            if let Some(s) = imp.scale_stiffness {
                im.scale_stiffness(s).map_err(named)?;
            }
            im.convert_length_unit(imp.length_unit.as_deref().unwrap_or("m"))
                .map_err(named)?;
            if let Some(d) = man.dofs_per_node.filter(|&d| d != im.dofs_per_node) {
                return Err(named(Error::InvalidSetting(format!(
                    "dofs_per_node = {d}, but the [import] files carry {} per node: remove the key",
                    im.dofs_per_node
                ))));
            }
            let names = DofNames::from_map(&im.dofs);
            let (model, report) = Model::new(
                man.name.clone(),
                im.mass,
                im.stiffness,
                damping,
                nodes.or(im.nodes),
                im.dofs_per_node,
            )
            .map_err(named)?;
            (model, report, names, im.notes)
        }
        _ => {
            return Err(named(Error::InvalidSetting(
                "give either `mass` and `stiffness` (Matrix Market files) or an [import] table \
                 naming the FE code's files, not both and not one of them alone"
                    .into(),
            )))
        }
    };
    let structural = Structural {
        eta: man.structural.as_ref().map_or(0.0, |s| s.eta),
        matrix: man
            .structural_damping
            .as_ref()
            .map(|f| matrix_market::read_sparse(&dir.join(f)))
            .transpose()?,
    };
    let model = model.with_structural(structural).map_err(named)?;
    let joints = !man.remote_points.is_empty()
        || man.scene.input_matrix.is_some()
        || man.scene.output_matrix.is_some();
    let (model, scene, names, notes, joints) = if joints {
        let mut notes = notes;
        let (model, scene, names, joints) =
            with_joints(dir, &man, model, &names, &mut notes).map_err(named)?;
        (model, scene, names, notes, Some(joints))
    } else {
        let scene = Scene {
            inputs: names
                .resolve(&man.scene.inputs, "[scene] inputs")
                .map_err(named)?,
            outputs: names
                .resolve(&man.scene.outputs, "[scene] outputs")
                .map_err(named)?,
            band_hz: man.scene.band_hz,
        };
        (model, scene, names, notes, None)
    };
    scene.validate(model.n(), "scene").map_err(named)?;
    let loaded = Loaded {
        model,
        scene,
        report,
        names,
        notes,
    };
    Ok((loaded, joints))
}

/// The coupled model of a directory with `[[remote_points]]` or a scene matrix
/// (docs/design.md §3.11): its scene as DoFs of the coupled model, its DoF names
/// ([`DofNames::Coupled`]) and its [`Joints`] to `model`; what the coupling did is added to
/// `notes`.
///
/// # Errors
/// As [`joints::points`], [`joints::matrix_functionals`] and [`coupled::couple`], and a scene
/// token that names neither a point's DoF nor a model DoF.
fn with_joints(
    dir: &Path,
    man: &Manifest,
    model: Model,
    names: &DofNames,
    notes: &mut Vec<String>,
) -> Result<(Model, Scene, DofNames, Joints)> {
    let points = joints::points(&man.remote_points, model.nodes.as_deref().unwrap_or(&[]))?;
    let functionals = |refs: &[DofRef], matrix: &Option<String>, what: &str| {
        let mut list = refs
            .iter()
            .map(|r| match r {
                DofRef::Name(s) => match joints::point_dof(&points, s)? {
                    Some(f) => Ok(f),
                    None => names.index(s, what).map(Functional::Dof),
                },
                DofRef::Index(_) => names
                    .resolve(std::slice::from_ref(r), what)
                    .map(|d| Functional::Dof(d[0])),
            })
            .collect::<Result<Vec<_>>>()?;
        if let Some(f) = matrix {
            list.extend(joints::matrix_functionals(
                &dir.join(f),
                model.n(),
                what.ends_with("inputs"),
            )?);
        }
        Ok::<_, Error>(list)
    };
    let inputs = functionals(&man.scene.inputs, &man.scene.input_matrix, "[scene] inputs")?;
    let outputs = functionals(
        &man.scene.outputs,
        &man.scene.output_matrix,
        "[scene] outputs",
    )?;
    let cp = coupled::couple(&model, &points, &inputs, &outputs)?;
    for p in &points {
        notes.push(format!(
            "remote point {}: {} over {} nodes at ({:.6e}, {:.6e}, {:.6e})",
            p.name,
            match p.kind {
                Kind::Rigid => "rigid (RBE2)",
                Kind::Distributing => "distributing (RBE3)",
            },
            p.nodes.len(),
            p.position[0],
            p.position[1],
            p.position[2]
        ));
    }
    notes.push(format!(
        "coupled model: N {} -> {}, stored entries of K {} -> {}",
        model.n(),
        cp.n,
        cp.nnz[0],
        cp.nnz[1]
    ));
    let original = names.names();
    let label = |c: &Coordinate| match c {
        Coordinate::Dof(i) => original[*i].clone(),
        Coordinate::Point { point, dir } => {
            format!("{}:{}", points[*point].name, Direction::ALL[*dir].label())
        }
        Coordinate::Row(name) => name.clone(),
    };
    let named = cp
        .coordinates
        .iter()
        .enumerate()
        .map(|(i, c)| (label(c), i));
    let names = DofNames::Coupled(named.collect());
    let scene = Scene {
        inputs: cp.inputs.clone(),
        outputs: cp.outputs.clone(),
        band_hz: man.scene.band_hz,
    };
    let (coupled, joints) = cp.split(model, points);
    Ok((coupled, scene, names, joints))
}

/// A file named in `[import] files`, relative to `dir`, keeping a `K=`/`M=` prefix.
fn in_dir(dir: &Path, file: &str) -> std::path::PathBuf {
    match file.split_once('=') {
        Some((role @ ("K" | "M"), rest)) => format!("{role}={}", dir.join(rest).display()).into(),
        _ => dir.join(file),
    }
}

/// Reads `nodes.csv`: header `x,y,z`, then one node per line.
///
/// # Errors
/// [`Error::Parse`] naming the line for a bad header, a wrong column count or a bad number.
pub fn read_nodes(path: &Path) -> Result<Vec<[f64; 3]>> {
    let text = read_regular_text(path)?;
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
        let structural_damping = match &model.structural.matrix {
            Some(k4) => {
                matrix_market::write_coordinate(&tmp.join("K4.mtx"), k4.as_ref(), true)?;
                Some("K4.mtx".to_string())
            }
            None => None,
        };
        let structural = (model.structural.eta != 0.0).then_some(StructuralToml {
            eta: model.structural.eta,
        });
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
            mass: Some("M.mtx".into()),
            stiffness: Some("K.mtx".into()),
            damping,
            nodes: model.nodes.as_ref().map(|_| "nodes.csv".into()),
            dofs_per_node: Some(model.dofs_per_node),
            rayleigh,
            structural_damping,
            structural,
            scene: SceneToml {
                inputs: scene
                    .inputs
                    .iter()
                    .map(|&i| DofRef::Index(i as u64))
                    .collect(),
                outputs: scene
                    .outputs
                    .iter()
                    .map(|&i| DofRef::Index(i as u64))
                    .collect(),
                band_hz: scene.band_hz,
                input_matrix: None,
                output_matrix: None,
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
            import: None,
            remote_points: Vec::new(),
        };
        let text = toml::to_string(&man)
            .map_err(|e| Error::InvalidModel(format!("cannot serialize manifest: {e}")))?;
        atomic::write_bytes(&tmp.join(MANIFEST), text)
    })
}
