//! The vocabulary of the importers (docs/design.md §4, "Importers"): a DoF's [`Direction`]
//! and the [`Dof`] itself (`17:x`), the source [`Format`], the [`Imported`] model every reader
//! returns, the [`NodeTable`] of node coordinates and how coordinates attach to a DoF map
//! ([`uniform_nodes`]), and the [`Role`] of a matrix file. The readers and the dispatcher
//! import this file; it imports none of them.

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
    /// Nastran OUTPUT4 matrices (ASCII or binary), see [`super::nastran`].
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

/// The role a matrix plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    Stiffness,
    Mass,
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
}
