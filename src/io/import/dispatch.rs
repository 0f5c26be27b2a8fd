//! The one import entry, [`read`] (docs/design.md §4, "Importers"): tells the format of each
//! file from its content, asking the readers' own sniffers ([`SNIFFERS`]), and hands the set
//! to the reader of that format.

use super::types::{role_from_name, Imported, Role};
use super::{abaqus, ansys, harwell_boeing, nastran, node_table};
use crate::io::file::head;
use crate::io::op4;
use crate::{Error, Result};
use std::path::{Path, PathBuf};

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

/// Reads a model from the files an FE code wrote, with the reader of their format (the
/// readers: [`super`]).
///
/// # How a file is recognized
/// From its first bytes, never from its name alone; the readers' sniffers are asked in this
/// order (`SNIFFERS`) and the first that recognizes the file decides:
/// * the 32-bit word 100 at byte 0, in either byte order: an ANSYS binary file (its standard
///   header is a 100-word record; ANSYS Programmer's Reference, "Standard ANSYS file header";
///   `ansys::looks_like_full`);
/// * the 32-bit word 24 at bytes 0 and 28, in either byte order (a 24-byte Fortran record: the
///   OUTPUT4 matrix header), or a first line `NCOL NROW NF NTYPE` in 4 fields of 8, an 8-column
///   name and a Fortran format such as `1P,3E23.16`: a Nastran OP4 file
///   (`io::op4::looks_like_op4`);
/// * `%%MatrixMarket`: a Matrix Market file — `array integer` is the DoF mapping vector
///   (`ansys::looks_like_mapping`), anything else a matrix
///   (`ansys::looks_like_matrix_market`);
/// * a line 2 of 4–5 whole numbers and a line 3 starting with a 3-letter type (`RSA`, `RUA`)
///   and 3–4 whole numbers: a Harwell–Boeing matrix (`harwell_boeing::looks_like`), which
///   stands wherever a Matrix Market K or M of an APDL Math export does;
/// * a first non-blank line starting with `*` (`*Heading`, `*Node`): an Abaqus input deck
///   (`abaqus::looks_like_deck`);
/// * a first line of 3 numbers `row col value` or 5 comma-separated `node, dof, node, dof,
///   value`: an Abaqus matrix (`abaqus::looks_like_matrix`);
/// * a first data row of two integers `node component`, the component 1–6: a DoF map for OP4
///   files (`nastran::looks_like_dof_map`, read by [`super::nastran::read_dof_map`]);
/// * anything else with a non-blank line: a node coordinate table (`node_table::looks_like`,
///   read by [`super::read_node_table`]).
///
/// Which matrix is the stiffness and which the mass comes from the file name (`STIF`/`stiff`/`K`
/// vs `MASS`/`mass`/`M`, case-insensitive, as ANSYS's and Abaqus's own names have it,
/// `role_from_name`) or from an explicit `K=path` / `M=path` prefix; in OP4 files first from
/// the matrix names.
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

/// A reader's content sniffing: whether a file's first bytes are of its format.
type LooksLike = fn(&[u8]) -> bool;

/// The content sniffers in the order they are asked, each the reader's own: the first that
/// recognizes a file's first bytes decides its kind.
const SNIFFERS: [(LooksLike, Kind); 9] = [
    (ansys::looks_like_full, Kind::AnsysBinary),
    (op4::looks_like_op4, Kind::NastranOp4),
    (ansys::looks_like_mapping, Kind::MatrixMarketMapping),
    (ansys::looks_like_matrix_market, Kind::MatrixMarketMatrix),
    (harwell_boeing::looks_like, Kind::HarwellBoeing),
    (abaqus::looks_like_deck, Kind::AbaqusDeck),
    (abaqus::looks_like_matrix, Kind::AbaqusMatrix),
    (nastran::looks_like_dof_map, Kind::DofMap),
    (node_table::looks_like, Kind::NodeTable),
];

/// Tells what a file is from its first 4 KiB ([`SNIFFERS`]).
fn sniff(path: &Path) -> Result<Kind> {
    let head = head(path)?;
    SNIFFERS
        .iter()
        .find(|(looks_like, _)| looks_like(&head))
        .map(|&(_, kind)| kind)
        .ok_or_else(|| {
            Error::parse(
                path,
                1,
                "cannot tell the format: expected an ANSYS .full file, a Matrix Market or \
                 Harwell-Boeing file, an Abaqus matrix or input deck, a Nastran OP4 file, a DoF map \
                 or a node coordinate table",
            )
        })
}
