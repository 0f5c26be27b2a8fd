//! Reading models written by FE codes (docs/design.md §4, "Importers"): one entry, [`read`], that
//! tells the format of each file and hands the set to the reader of that format.
//!
//! | what | files | reader |
//! |---|---|---|
//! | ANSYS binary full file | `Jobname.full` (+ optional node table) | [`crate::io::ansys::read_full`] |
//! | ANSYS APDL Math export | K, M (`*EXPORT,…,MMF` or `HBMAT`), the DoF mapping vector, a node table | [`crate::io::ansys::read_apdl_math`] |
//! | Abaqus `*MATRIX OUTPUT` | `*_STIF*.mtx`, `*_MASS*.mtx` (+ the `.inp` deck) | [`crate::io::abaqus::read`] |
//! | Nastran OUTPUT4 (OP4), ASCII or binary | one or more `.op4` files holding `KAA`/`MAA` (or `KGG`, `KLL`, `KHH` / `MGG`, `MLL`, `MHH`) (+ a DoF map) | [`crate::io::nastran`] |
//!
//! # How a file is recognized
//! From its first bytes, never from its name alone:
//! * the 32-bit word 100 at byte 0, in either byte order: an ANSYS binary file (its standard
//!   header is a 100-word record; ANSYS Programmer's Reference, "Standard ANSYS file header");
//! * the 32-bit word 24 at bytes 0 and 28, in either byte order (a 24-byte Fortran record: the
//!   OUTPUT4 matrix header), or a first line `NCOL NROW NF NTYPE` in 4 fields of 8, an 8-column
//!   name and a Fortran format such as `1P,3E23.16`: a Nastran OP4 file;
//! * `%%MatrixMarket`: a Matrix Market file — `array integer` is the DoF mapping vector,
//!   `coordinate` a matrix;
//! * a line 2 of 4–5 whole numbers and a line 3 starting with a 3-letter type (`RSA`, `RUA`)
//!   and 3–4 whole numbers: a Harwell–Boeing matrix ([`crate::io::harwell_boeing`]), which
//!   stands wherever a Matrix Market K or M of an APDL Math export does;
//! * a first non-blank line starting with `*` (`*Heading`, `*Node`): an Abaqus input deck;
//! * a first line of 3 numbers `row col value` or 5 comma-separated `node, dof, node, dof,
//!   value`: an Abaqus matrix;
//! * a first data row of two integers `node component`, the component 1–6: a DoF map for OP4
//!   files ([`crate::io::nastran::read_dof_map`]);
//! * anything else with a first data row `node x y z`: a node coordinate table
//!   ([`read_node_table`]).
//!
//! Which matrix is the stiffness and which the mass comes from the file name (`STIF`/`stiff`/`K`
//! vs `MASS`/`mass`/`M`, case-insensitive, as ANSYS's and Abaqus's own names have it) or from
//! an explicit `K=path` / `M=path` prefix; in OP4 files first from the matrix names.
//!
//! # What comes back
//! [`Imported`]: full-storage M and K in the order of the DoF map, the DoF map itself (node
//! number and direction per DoF, written `17:x`), node coordinates when every node carries the
//! same DoFs, the producer and the units as the files record them (nothing is guessed), and the
//! constrained DoFs that were removed. [`Imported::into_model`] validates it as a
//! [`Model`].

use crate::io::text::{first_fields, par_lines, parse_u64, show};
use crate::io::{abaqus, ansys, nastran};
use crate::model::{Damping, Model, ValidationReport};
use crate::scene::Scene;
use crate::sparse::Csc;
use crate::{Error, Result};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// A nodal degree-of-freedom direction: translations x, y, z and rotations rx, ry, rz.
///
/// ANSYS numbers them UX=1, UY=2, UZ=3, ROTX=4, ROTY=5, ROTZ=6 (the DoF keys of the full file's
/// DoF set); Abaqus uses the same numbers 1–6 for its DoFs (Abaqus Analysis User's Guide,
/// "Conventions": 1–3 displacements, 4–6 rotations).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Direction {
    /// Translation along x (key 1).
    X,
    /// Translation along y (key 2).
    Y,
    /// Translation along z (key 3).
    Z,
    /// Rotation about x (key 4).
    Rx,
    /// Rotation about y (key 5).
    Ry,
    /// Rotation about z (key 6).
    Rz,
}

impl Direction {
    /// All six, in key order.
    pub const ALL: [Direction; 6] = [
        Direction::X,
        Direction::Y,
        Direction::Z,
        Direction::Rx,
        Direction::Ry,
        Direction::Rz,
    ];

    /// The direction of the ANSYS/Abaqus DoF key 1–6; `None` for any other key (temperature,
    /// pressure, warping, ...), which sparsemor does not model.
    pub fn from_key(key: i64) -> Option<Direction> {
        usize::try_from(key - 1)
            .ok()
            .and_then(|k| Self::ALL.get(k).copied())
    }

    /// The label used in DoF names: `x`, `y`, `z`, `rx`, `ry`, `rz`.
    pub fn label(self) -> &'static str {
        ["x", "y", "z", "rx", "ry", "rz"][self as usize]
    }
}

impl fmt::Display for Direction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.label())
    }
}

impl FromStr for Direction {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|d| d.label().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                Error::InvalidSetting(format!(
                    "unknown DoF direction '{s}': use x, y, z, rx, ry or rz"
                ))
            })
    }
}

/// One DoF of an imported model: the FE code's node number and the direction, `17:x`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Dof {
    /// Node number as the FE code numbers it.
    pub node: u64,
    /// Direction.
    pub dir: Direction,
}

impl fmt::Display for Dof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.node, self.dir)
    }
}

impl FromStr for Dof {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        let (n, d) = s.split_once(':').ok_or_else(|| {
            Error::InvalidSetting(format!("DoF '{s}': expected NODE:DIR, e.g. 17:x"))
        })?;
        let node = n
            .trim()
            .parse()
            .map_err(|_| Error::InvalidSetting(format!("DoF '{s}': '{n}' is not a node number")))?;
        Ok(Dof {
            node,
            dir: d.parse()?,
        })
    }
}

/// The source format of an import.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// ANSYS binary `.full` file.
    AnsysFull,
    /// ANSYS APDL Math export (Matrix Market or Harwell–Boeing K and M) with its DoF mapping
    /// vector.
    AnsysApdlMath,
    /// Abaqus `*MATRIX OUTPUT, FORMAT=COORDINATE` (`row col value`).
    AbaqusCoordinate,
    /// Abaqus `*MATRIX OUTPUT` default format (`node, dof, node, dof, value`).
    AbaqusNodeDof,
    /// Nastran OUTPUT4 matrices (ASCII or binary), see [`crate::io::nastran`].
    NastranOp4,
}

impl Format {
    /// The name written to `model.toml` (`[source] format`).
    pub fn name(self) -> &'static str {
        match self {
            Format::AnsysFull => "ansys-full",
            Format::AnsysApdlMath => "ansys-apdl-math",
            Format::AbaqusCoordinate => "abaqus-coordinate",
            Format::AbaqusNodeDof => "abaqus-node-dof",
            Format::NastranOp4 => "nastran-op4",
        }
    }
}

/// A model as an FE code wrote it, in sparsemor's storage.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The format read.
    pub format: Format,
    /// The files read, in the order given.
    pub files: Vec<PathBuf>,
    /// Who wrote the files, as they say (e.g. `ANSYS 15.0, LINUX x64, jobname file`).
    pub producer: String,
    /// The units as the files record them (nothing is guessed).
    pub units: String,
    /// Mass matrix, full storage, in DoF-map order.
    pub mass: Csc,
    /// Stiffness matrix, full storage, in DoF-map order.
    pub stiffness: Csc,
    /// Node and direction of every DoF (row/column order of M and K).
    pub dofs: Vec<Dof>,
    /// Node coordinates in DoF-map node order, when a node table was read and every node
    /// carries the same `dofs_per_node` DoFs in the same directions.
    pub nodes: Option<Vec<[f64; 3]>>,
    /// 3 or 6: DoFs per node.
    pub dofs_per_node: usize,
    /// Constrained DoFs that the source stored and the import removed.
    pub removed: Vec<Dof>,
    /// What the reader noticed (lumped mass, nodes without coordinates, ...), for the user.
    pub notes: Vec<String>,
}

impl Imported {
    /// Number of DoFs N.
    pub fn n(&self) -> usize {
        self.dofs.len()
    }

    /// Multiplies K by `s` (e.g. EXUDYN's 1e-2 for the Abaqus rotor, see the data README).
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] unless `s` is finite and > 0.
    pub fn scale_stiffness(&mut self, s: f64) -> Result<()> {
        if !(s.is_finite() && s > 0.0) {
            return Err(Error::InvalidSetting(format!(
                "stiffness scale {s}: need a finite value > 0"
            )));
        }
        self.stiffness.val_mut().iter_mut().for_each(|v| *v *= s);
        self.units.push_str(&format!("; stiffness scaled by {s}"));
        Ok(())
    }

    /// Converts a model in the consistent mm–t–s–N system to m–kg–s–N: coordinates × 1e-3,
    /// M × 1e3 (t → kg), K × 1e3 (N/mm → N/m). Eigenfrequencies are unchanged (K/M is).
    pub fn mm_to_m(&mut self) {
        self.mass.val_mut().iter_mut().for_each(|v| *v *= 1e3);
        self.stiffness.val_mut().iter_mut().for_each(|v| *v *= 1e3);
        if let Some(nodes) = &mut self.nodes {
            nodes.iter_mut().flatten().for_each(|c| *c *= 1e-3);
        }
        self.units
            .push_str("; converted from mm-t-s-N to m-kg-s-N (K, M x 1e3, coordinates x 1e-3)");
    }

    /// Converts to m-kg-s-N from the source's length unit: `m` (kept) or `mm` ([`Self::mm_to_m`]).
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] for any other unit.
    pub fn convert_length_unit(&mut self, unit: &str) -> Result<()> {
        match unit {
            "m" => Ok(()),
            "mm" => {
                self.mm_to_m();
                Ok(())
            }
            u => Err(Error::InvalidSetting(format!(
                "length unit '{u}': use m (m-kg-s-N) or mm (mm-t-s-N)"
            ))),
        }
    }

    /// The default scene of an imported model: inputs = outputs = the three translations of
    /// the first node that has all three (else DoF 0), band `band_hz`. The band cannot come
    /// from the files (no eigenfrequency is known at import time), so the caller chooses it.
    pub fn default_scene(&self, band_hz: [f64; 2]) -> Scene {
        let first = self.dofs.first().map(|d| d.node);
        let dofs: Vec<usize> = self
            .dofs
            .iter()
            .enumerate()
            .filter(|(_, d)| Some(d.node) == first && d.dir <= Direction::Z)
            .map(|(i, _)| i)
            .collect();
        let dofs = if dofs.len() == 3 { dofs } else { vec![0] };
        Scene {
            inputs: dofs.clone(),
            outputs: dofs,
            band_hz,
        }
    }

    /// Validates the import as an undamped [`Model`] named `name`.
    ///
    /// # Errors
    /// [`Model::new`]'s errors (asymmetric, non-positive mass diagonal, ...).
    pub fn into_model(self, name: String) -> Result<(Model, ValidationReport)> {
        Model::new(
            name,
            self.mass,
            self.stiffness,
            Damping::None,
            self.nodes,
            self.dofs_per_node,
        )
    }
}

/// What a file is, from its first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    AnsysBinary,
    MatrixMarketMatrix,
    MatrixMarketMapping,
    HarwellBoeing,
    AbaqusMatrix,
    AbaqusDeck,
    NastranOp4,
    DofMap,
    NodeTable,
}

/// The role a matrix plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    Stiffness,
    Mass,
}

/// Reads a model from the files an FE code wrote (see the [module documentation](self)).
///
/// # Errors
/// [`Error::Io`]; [`Error::Parse`] naming the file and the line or byte offset; an
/// [`Error::InvalidSetting`] when the set of files is incomplete or ambiguous (which file is
/// missing, how to name it).
pub fn read(paths: &[PathBuf]) -> Result<Imported> {
    let mut files = Vec::new();
    for p in paths {
        let (role, path) = explicit_role(p);
        files.push((sniff(&path)?, role, path));
    }
    let of = |k: Kind| -> Vec<&(Kind, Option<Role>, PathBuf)> {
        files.iter().filter(|f| f.0 == k).collect()
    };
    let one = |k: Kind, what: &str| -> Result<Option<PathBuf>> {
        match of(k).as_slice() {
            [] => Ok(None),
            [f] => Ok(Some(f.2.clone())),
            many => Err(Error::InvalidSetting(format!(
                "{} files look like {what}: {}; give one",
                many.len(),
                list(many.iter().map(|f| &f.2))
            ))),
        }
    };
    let table = one(Kind::NodeTable, "a node coordinate table")?;
    if let Some(full) = one(Kind::AnsysBinary, "an ANSYS binary file")? {
        only(
            &files,
            &[Kind::AnsysBinary, Kind::NodeTable],
            "an ANSYS .full file",
        )?;
        return ansys::read_full(&full, table.as_deref());
    }
    let deck = one(Kind::AbaqusDeck, "an Abaqus input deck")?;
    let abq = of(Kind::AbaqusMatrix);
    if !abq.is_empty() {
        only(
            &files,
            &[Kind::AbaqusMatrix, Kind::AbaqusDeck],
            "Abaqus matrices",
        )?;
        let (k, m) = stiffness_and_mass(&abq)?;
        return abaqus::read(&k, &m, deck.as_deref());
    }
    let op4 = of(Kind::NastranOp4);
    if !op4.is_empty() {
        only(
            &files,
            &[Kind::NastranOp4, Kind::DofMap],
            "Nastran OP4 files",
        )?;
        let map = one(Kind::DofMap, "a DoF map")?;
        let sources: Vec<(Option<Role>, PathBuf)> =
            op4.iter().map(|f| (f.1, f.2.clone())).collect();
        return nastran::read_model(&sources, map.as_deref());
    }
    let mut mm = of(Kind::MatrixMarketMatrix);
    mm.extend(of(Kind::HarwellBoeing));
    if !mm.is_empty() {
        only(
            &files,
            &[
                Kind::MatrixMarketMatrix,
                Kind::HarwellBoeing,
                Kind::MatrixMarketMapping,
                Kind::NodeTable,
            ],
            "an APDL Math export",
        )?;
        let (k, m) = stiffness_and_mass(&mm)?;
        let map = one(Kind::MatrixMarketMapping, "a DoF mapping vector")?.ok_or_else(|| {
            Error::InvalidSetting(
                "an APDL Math export needs its DoF mapping vector (a Matrix Market `array \
                 integer` file with the node number of each equation block) besides K and M"
                    .into(),
            )
        })?;
        return ansys::read_apdl_math(&k, &m, &map, table.as_deref());
    }
    Err(Error::InvalidSetting(format!(
        "no stiffness or mass matrix among {}: give an ANSYS .full file, an APDL Math export \
         (K, M as Matrix Market or Harwell-Boeing, mapping vector, node table), Abaqus *MATRIX \
         OUTPUT files or Nastran OP4 files",
        list(paths)
    )))
}

fn list<'a>(paths: impl IntoIterator<Item = &'a PathBuf>) -> String {
    paths
        .into_iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Rejects files that do not belong with the detected format.
fn only(files: &[(Kind, Option<Role>, PathBuf)], allowed: &[Kind], what: &str) -> Result<()> {
    match files.iter().find(|f| !allowed.contains(&f.0)) {
        Some(f) => Err(Error::InvalidSetting(format!(
            "{} ({:?}) does not belong with {what}",
            f.2.display(),
            f.0
        ))),
        None => Ok(()),
    }
}

/// `K=path` / `M=path` (when no file of that literal name exists).
fn explicit_role(p: &Path) -> (Option<Role>, PathBuf) {
    let s = p.to_string_lossy();
    for (prefix, role) in [("K=", Role::Stiffness), ("M=", Role::Mass)] {
        if let Some(rest) = s.strip_prefix(prefix) {
            if !p.exists() {
                return (Some(role), PathBuf::from(rest));
            }
        }
    }
    (None, p.to_path_buf())
}

/// The role of a matrix file from its name: `STIF`/`stiff`/`K` or `MASS`/`M`.
pub(crate) fn role_from_name(path: &Path) -> Option<Role> {
    let stem = path.file_stem()?.to_string_lossy().to_ascii_lowercase();
    if stem.contains("stif") || stem == "k" {
        Some(Role::Stiffness)
    } else if stem.contains("mass") || stem == "m" {
        Some(Role::Mass)
    } else {
        None
    }
}

/// Exactly one stiffness and one mass file among `files`.
fn stiffness_and_mass(files: &[&(Kind, Option<Role>, PathBuf)]) -> Result<(PathBuf, PathBuf)> {
    let pick = |role: Role, name: &str| -> Result<PathBuf> {
        let hits: Vec<&PathBuf> = files
            .iter()
            .filter(|f| f.1.or_else(|| role_from_name(&f.2)) == Some(role))
            .map(|f| &f.2)
            .collect();
        match hits.as_slice() {
            [p] => Ok((*p).clone()),
            _ => Err(Error::InvalidSetting(format!(
                "cannot tell the {name} matrix among {} ({} candidates): name it with `STIF`/`MASS` \
                 in the file name or prefix it, e.g. K=stiffness.mtx M=mass.mtx",
                list(files.iter().map(|f| &f.2)),
                hits.len()
            ))),
        }
    };
    Ok((
        pick(Role::Stiffness, "stiffness")?,
        pick(Role::Mass, "mass")?,
    ))
}

/// Tells what a file is from its first 4 KiB.
fn sniff(path: &Path) -> Result<Kind> {
    let head = crate::io::head(path)?;
    if head.len() >= 4 {
        let w = [head[0], head[1], head[2], head[3]];
        if u32::from_le_bytes(w) == 100 || u32::from_be_bytes(w) == 100 {
            return Ok(Kind::AnsysBinary);
        }
    }
    if nastran::looks_like_op4(&head) {
        return Ok(Kind::NastranOp4);
    }
    if head.starts_with(b"%%MatrixMarket") {
        let banner = String::from_utf8_lossy(head.split(|&b| b == b'\n').next().unwrap_or(&[]))
            .to_ascii_lowercase();
        return Ok(if banner.contains("array") && banner.contains("integer") {
            Kind::MatrixMarketMapping
        } else {
            Kind::MatrixMarketMatrix
        });
    }
    if crate::io::harwell_boeing::looks_like(&head) {
        return Ok(Kind::HarwellBoeing);
    }
    let text = String::from_utf8_lossy(&head);
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("");
    if first.starts_with('*') {
        return Ok(Kind::AbaqusDeck);
    }
    let numbers = |sep: &dyn Fn(char) -> bool| -> Option<usize> {
        let t: Vec<&str> = first.split(sep).filter(|t| !t.is_empty()).collect();
        t.iter()
            .all(|t| t.parse::<f64>().is_ok())
            .then_some(t.len())
    };
    let by_comma = numbers(&|c: char| c == ',' || c.is_whitespace());
    let by_space = numbers(&|c: char| c.is_whitespace());
    if by_space == Some(3) || (first.contains(',') && by_comma == Some(5)) {
        return Ok(Kind::AbaqusMatrix);
    }
    if nastran::looks_like_dof_map(&head) {
        return Ok(Kind::DofMap);
    }
    if !first.is_empty() {
        return Ok(Kind::NodeTable);
    }
    Err(Error::parse(
        path,
        1,
        "cannot tell the format: expected an ANSYS .full file, a Matrix Market or Harwell-Boeing \
         file, an Abaqus matrix or input deck, a Nastran OP4 file, a DoF map or a node coordinate \
         table",
    ))
}

/// A node coordinate table: node number and coordinates per row, plus what its header says
/// about the length unit.
#[derive(Clone, Debug, Default)]
pub struct NodeTable {
    /// (node number, [x, y, z]) in file order.
    pub rows: Vec<(u64, [f64; 3])>,
    /// The length unit named in the header (`X-Position (m)` → `m`), if any.
    pub length_unit: Option<String>,
}

impl NodeTable {
    /// Coordinates in the order of `order` (node numbers).
    ///
    /// # Errors
    /// [`Error::InvalidModel`] naming the first node without coordinates or given twice.
    pub fn coordinates(&self, order: &[u64], path: &Path) -> Result<Vec<[f64; 3]>> {
        let mut map = std::collections::HashMap::with_capacity(self.rows.len());
        for &(n, xyz) in &self.rows {
            if map.insert(n, xyz).is_some() {
                return Err(Error::InvalidModel(format!(
                    "{}: node {n} appears twice",
                    path.display()
                )));
            }
        }
        order
            .iter()
            .map(|n| {
                map.get(n).copied().ok_or_else(|| {
                    Error::InvalidModel(format!(
                        "{}: node {n} of the matrices has no coordinates in the table",
                        path.display()
                    ))
                })
            })
            .collect()
    }
}

/// Reads a node coordinate table: rows `node x y z` (further columns ignored) separated by
/// tabs, semicolons or spaces, or by commas when a row has none of those; numbers with a
/// decimal point or a decimal comma (`0,15`, `1,e-001`, `5,e-002` as the German-locale ANSYS
/// export of `ansys_rotor_exudyn/` writes them). Leading lines whose first field is not a
/// number are headers; a header field like `X-Position (m)` names the length unit.
///
/// # Errors
/// [`Error::Parse`] with the line: fewer than 4 fields, a number that is neither (`1.000,5`,
/// `1,2,3` in one field), a node number that is not a positive integer.
pub fn read_node_table(path: &Path) -> Result<NodeTable> {
    /// A line of the table, parsed on its own ([`par_lines`]): whether it is a header line
    /// depends on the lines before it, so a line whose first field is no number carries both
    /// readings — the unit a header line may name, and the error it is as a data line.
    enum Line {
        Row(u64, [f64; 3]),
        Text(Option<String>, Error),
    }
    let parse = |line: usize, bytes: &[u8]| -> Result<Option<Line>> {
        let (f, count) = first_fields::<4>(table_fields(bytes));
        if count == 0 {
            return Ok(None);
        }
        let as_data = || -> Result<Line> {
            if count < 4 {
                return Err(Error::parse(
                    path,
                    line,
                    format!(
                        "expected `node x y z`, found {count} field(s) (separators: tab, semicolon, space or comma)"
                    ),
                ));
            }
            let node = parse_u64(f[0], path, line, "node number")?;
            let mut xyz = [0.0; 3];
            for (c, f) in xyz.iter_mut().zip(&f[1..4]) {
                *c = parse_locale_number(f).ok_or_else(|| {
                    Error::parse(
                        path,
                        line,
                        format!(
                            "coordinate '{}' is not a number with a decimal point or a decimal comma",
                            show(f)
                        ),
                    )
                })?;
            }
            Ok(Line::Row(node, xyz))
        };
        if std::str::from_utf8(f[0]).is_ok_and(|t| t.parse::<u64>().is_ok()) {
            return as_data().map(Some);
        }
        let unit = table_fields(bytes).find_map(|f| {
            let f = String::from_utf8_lossy(f);
            let (_, rest) = f.split_once('(')?;
            Some(rest.split_once(')')?.0.trim().to_string())
        });
        let error = as_data()
            .err()
            .unwrap_or_else(|| Error::parse(path, line, "not a node line"));
        Ok(Some(Line::Text(unit, error)))
    };
    let mut table = NodeTable::default();
    let mut in_header = true;
    par_lines(path, parse, |_, l| {
        match l {
            Line::Row(node, xyz) => {
                in_header = false;
                table.rows.push((node, xyz));
            }
            Line::Text(_, error) if !in_header => return Err(error),
            Line::Text(unit, _) => {
                if table.length_unit.is_none() {
                    table.length_unit = unit;
                }
            }
        }
        Ok(())
    })?;
    Ok(table)
}

/// The fields of a node-table line: split at tabs and semicolons when the line has one, else
/// at blanks when the trimmed line has some, else at commas; trimmed, empty ones dropped.
fn table_fields(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    let sep: fn(&u8) -> bool = if line.iter().any(|&b| b == b'\t' || b == b';') {
        |&b| b == b'\t' || b == b';'
    } else if line.trim_ascii().iter().any(u8::is_ascii_whitespace) {
        u8::is_ascii_whitespace
    } else {
        |&b| b == b','
    };
    line.split(sep)
        .map(<[u8]>::trim_ascii)
        .filter(|f| !f.is_empty())
}

/// A number with a decimal point or one decimal comma (`0,15` → 0.15; `1,e-001` → 0.1);
/// `None` for anything else (`1.000,5`, `1,2,3`, non-finite).
fn parse_locale_number(s: &[u8]) -> Option<f64> {
    let mut buf = [0u8; 64];
    let s = match (s.iter().filter(|&&b| b == b',').count(), s.contains(&b'.')) {
        (0, _) => s,
        (1, false) if s.len() <= buf.len() => {
            let buf = &mut buf[..s.len()];
            buf.copy_from_slice(s);
            buf.iter_mut()
                .filter(|b| **b == b',')
                .for_each(|b| *b = b'.');
            buf
        }
        _ => return None,
    };
    fast_float2::parse::<f64, _>(s)
        .ok()
        .filter(|v| v.is_finite())
}

/// Node coordinates in DoF-map order when every node keeps all `dofs_per_node` DoFs, the
/// same directions in the same order, and a table was given; otherwise `None` and a note.
pub(crate) fn uniform_nodes(
    dofs: &[Dof],
    dofs_per_node: usize,
    table: Option<&NodeTable>,
    table_path: Option<&Path>,
    notes: &mut Vec<String>,
) -> Result<Option<Vec<[f64; 3]>>> {
    let (Some(table), Some(path)) = (table, table_path) else {
        notes.push(
            "no node coordinates given: rigid-body modes will come from the eigenpairs".into(),
        );
        return Ok(None);
    };
    let uniform = dofs.len() % dofs_per_node == 0
        && dofs.chunks(dofs_per_node).all(|c| {
            c.iter()
                .zip(Direction::ALL)
                .all(|(d, dir)| d.node == c[0].node && d.dir == dir)
        });
    if !uniform {
        notes.push(format!(
            "the DoFs are not {dofs_per_node} per node in x, y, z order (some were constrained): node coordinates not attached"
        ));
        return Ok(None);
    }
    let order: Vec<u64> = dofs.iter().step_by(dofs_per_node).map(|d| d.node).collect();
    table.coordinates(&order, path).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dof_names_round_trip() {
        for d in Direction::ALL {
            let dof = Dof { node: 17, dir: d };
            assert_eq!(dof.to_string().parse::<Dof>().unwrap(), dof);
        }
        assert!("17:q".parse::<Dof>().is_err());
        assert!("x:17".parse::<Dof>().is_err());
        assert_eq!(Direction::from_key(4), Some(Direction::Rx));
        assert_eq!(Direction::from_key(7), None);
        assert_eq!(Direction::from_key(0), None);
    }

    #[test]
    fn locale_numbers() {
        let p = |s: &str| parse_locale_number(s.as_bytes());
        assert_eq!(p("0,15"), Some(0.15));
        assert_eq!(p("1,e-001"), Some(0.1));
        assert_eq!(p("-5,e-002"), Some(-0.05));
        assert_eq!(p("0,"), Some(0.0));
        assert_eq!(p("2.5e3"), Some(2500.0));
        assert_eq!(p("1.000,5"), None);
        assert_eq!(p("1,2,3"), None);
        assert_eq!(p("inf"), None);
    }
}
