//! The Nastran model import built on the OP4 reader ([`crate::io::op4`]): the stiffness and
//! mass among the matrices, the DoF map, the [`Imported`] model.
//!
//! The import (`read_model`, reached through [`super::read`]) finds the stiffness and the
//! mass among the matrices of one or more OP4 files: by the matrix names `KAA`, `KGG`,
//! `KLL`, `KHH` (stiffness) and `MAA`, `MGG`, `MLL`, `MHH` (mass), or, for a file holding one
//! matrix, by the file's role (`K=file`, `M=file`, or `stif`/`mass` in its name). OP4 files
//! carry no DoF map: a DoF map file ([`read_dof_map`]: one `node component` row per DoF,
//! component 1–6) gives it; without one, N must be a multiple of 6 and the DoFs are assumed
//! to be nodes 1, 2, ... with components 1–6 each (said in the notes).

use super::types::{role_from_name, uniform_nodes, Direction, Dof, Format, Imported, Role};
use crate::io::op4::{read_op4_keeping, Encoding, Location, Op4Matrix};
use crate::io::text::{fields, for_each_line, parse_u64};
use crate::{Error, Result};
use std::fmt;
use std::path::{Path, PathBuf};

/// Matrix names read as the stiffness.
pub const STIFFNESS_NAMES: [&str; 4] = ["KAA", "KGG", "KLL", "KHH"];
/// Matrix names read as the mass.
pub const MASS_NAMES: [&str; 4] = ["MAA", "MGG", "MLL", "MHH"];

/// True when `h` (a file's first bytes) looks like a DoF map: the first line that is not
/// blank, a `#` comment or a header starting with a letter holds exactly two integers, the
/// second 1–6.
pub(crate) fn looks_like_dof_map(h: &[u8]) -> bool {
    let text = String::from_utf8_lossy(h);
    let Some(first) = text.lines().map(str::trim).find(|l| {
        !l.is_empty() && !l.starts_with('#') && !l.starts_with(|c: char| c.is_ascii_alphabetic())
    }) else {
        return false;
    };
    let t: Vec<&[u8]> = fields(first.as_bytes()).collect();
    t.len() == 2
        && std::str::from_utf8(t[0]).is_ok_and(|s| s.parse::<u64>().is_ok())
        && std::str::from_utf8(t[1]).is_ok_and(|s| matches!(s.parse::<u8>(), Ok(1..=6)))
}

/// Reads a DoF map: one `node component` row per DoF in matrix order (separated by spaces,
/// tabs or commas; component 1–6 = x, y, z, rx, ry, rz as in Nastran's component numbers).
/// Blank lines, `#` comments and header lines starting with a letter are skipped.
///
/// # Errors
/// [`Error::Parse`] with the line: not two fields, a node that is not a positive integer, a
/// component outside 1–6, a DoF given twice.
pub fn read_dof_map(path: &Path) -> Result<Vec<Dof>> {
    let mut dofs = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for_each_line(path, |line, bytes| {
        let text = String::from_utf8_lossy(bytes);
        let text = text.trim();
        if text.is_empty()
            || text.starts_with('#')
            || text.starts_with(|c: char| c.is_ascii_alphabetic())
        {
            return Ok(());
        }
        let t: Vec<&[u8]> = fields(text.as_bytes()).collect();
        if t.len() != 2 {
            return Err(Error::parse(
                path,
                line,
                format!(
                    "expected `node component` (2 fields), found {} field(s)",
                    t.len()
                ),
            ));
        }
        let node = parse_u64(t[0], path, line, "node number")?;
        let key = parse_u64(t[1], path, line, "component")?;
        let dir = Direction::from_key(key as i64).ok_or_else(|| {
            Error::parse(
                path,
                line,
                format!("component {key} of node {node}: use 1-6 (x, y, z, rx, ry, rz)"),
            )
        })?;
        let dof = Dof { node, dir };
        if !seen.insert(dof) {
            return Err(Error::parse(
                path,
                line,
                format!("DoF {dof} is given twice"),
            ));
        }
        dofs.push(dof);
        Ok(())
    })?;
    Ok(dofs)
}

/// A matrix found for a role, with its file.
struct Found {
    path: PathBuf,
    m: Op4Matrix,
}

impl Found {
    fn describe(&self) -> String {
        format!(
            "{} in {} ({}, {}x{})",
            self.m.name,
            self.path.display(),
            self.m.at,
            self.m.rows,
            self.m.cols
        )
    }

    fn error(&self, msg: impl fmt::Display) -> Error {
        match self.m.at {
            Location::Line(l) => {
                Error::parse(&self.path, l, format!("matrix {}: {msg}", self.m.name))
            }
            Location::Byte(b) => Error::parse(
                &self.path,
                0,
                format!("byte {b}: matrix {}: {msg}", self.m.name),
            ),
        }
    }
}

/// Reads a model from OP4 files (see the [module documentation](self)); `files` pairs each
/// file with its role when one was given (`K=`/`M=`) or is in its name.
pub(crate) fn read_model(
    files: &[(Option<Role>, PathBuf)],
    dof_map: Option<&Path>,
) -> Result<Imported> {
    let mut stiffness = Vec::new();
    let mut mass = Vec::new();
    let mut others = Vec::new();
    for (role, path) in files {
        let role = role.or_else(|| role_from_name(path));
        let by_name = |n: &str| STIFFNESS_NAMES.contains(&n) || MASS_NAMES.contains(&n);
        let keep = |n: &str| role.is_some() || by_name(&n.to_ascii_uppercase());
        let matrices = read_op4_keeping(path, &keep)?;
        let single = matrices.len() == 1;
        for m in matrices {
            let upper = m.name.to_ascii_uppercase();
            let r = if STIFFNESS_NAMES.contains(&upper.as_str()) {
                Some(Role::Stiffness)
            } else if MASS_NAMES.contains(&upper.as_str()) {
                Some(Role::Mass)
            } else if single {
                role
            } else {
                None
            };
            let f = Found {
                path: path.clone(),
                m,
            };
            match r {
                Some(Role::Stiffness) => stiffness.push(f),
                Some(Role::Mass) => mass.push(f),
                None => others.push(format!("{} {}", f.m.name, f.path.display())),
            }
        }
    }
    let pick = |v: Vec<Found>, what: &str, names: &[&str]| -> Result<Found> {
        let n = v.len();
        let mut it = v.into_iter();
        match (it.next(), n) {
            (Some(f), 1) => Ok(f),
            (None, _) => Err(Error::InvalidSetting(format!(
                "no {what} matrix in the OP4 files {}: name it {} in the file, or give a file holding only it as {}=FILE{}",
                files.iter().map(|f| f.1.display().to_string()).collect::<Vec<_>>().join(", "),
                names.join("/"),
                if what == "mass" { "M" } else { "K" },
                if others.is_empty() {
                    String::new()
                } else {
                    format!(" (other matrices found: {})", others.join(", "))
                }
            ))),
            (Some(f), _) => Err(Error::InvalidSetting(format!(
                "{n} {what} matrices: {}{}; give the files so that exactly one is found",
                f.describe(),
                it.map(|g| format!(", {}", g.describe())).collect::<String>()
            ))),
        }
    };
    let k = pick(stiffness, "stiffness", &STIFFNESS_NAMES)?;
    let m = pick(mass, "mass", &MASS_NAMES)?;
    for f in [&k, &m] {
        if f.m.rows != f.m.cols {
            return Err(f.error(format!(
                "is {}x{}; a stiffness or mass matrix is square",
                f.m.rows, f.m.cols
            )));
        }
        if ![1, 2, 6].contains(&f.m.form) {
            return Err(f.error(format!(
                "has form {}; only square (1), general (2) and symmetric (6) matrices are imported",
                f.m.form
            )));
        }
    }
    if k.m.rows != m.m.rows {
        return Err(Error::InvalidModel(format!(
            "mismatched sizes: stiffness {} but mass {}",
            k.describe(),
            m.describe()
        )));
    }
    let n = k.m.rows;
    for f in [&k, &m] {
        // A stiffness or mass matrix stores at least its diagonal: this bounds the CSC
        // column pointers (N + 1 words) by the entries the file actually held.
        if f.m.entries.len() < n {
            return Err(f.error(format!(
                "declares N = {n} but stores only {} nonzero entries; a stiffness or mass matrix holds at least its diagonal",
                f.m.entries.len()
            )));
        }
    }
    let mut notes = Vec::new();
    let (dofs, dofs_per_node) = match dof_map {
        Some(p) => {
            let dofs = read_dof_map(p)?;
            if dofs.len() != n {
                return Err(Error::InvalidModel(format!(
                    "{}: {} DoFs, but the matrices have N = {n}",
                    p.display(),
                    dofs.len()
                )));
            }
            let dpn = if dofs.iter().any(|d| d.dir > Direction::Z) {
                6
            } else {
                3
            };
            (dofs, dpn)
        }
        None if n % 6 == 0 => {
            notes.push(format!(
                "OP4 carries no DoF map and none was given: ASSUMED nodes 1..{} with components 1-6 (x, y, z, rx, ry, rz) each, in matrix order; give a DoF map file (`node component` per row) if that is wrong",
                n / 6
            ));
            let dofs = (0..n)
                .map(|i| Dof {
                    node: (i / 6 + 1) as u64,
                    dir: Direction::ALL[i % 6],
                })
                .collect();
            (dofs, 6)
        }
        None => {
            return Err(Error::InvalidSetting(format!(
                "OP4 files carry no DoF map and N = {n} is not a multiple of 6: give a DoF map file with the OP4 files (one `node component` row per DoF in matrix order, component 1-6, e.g. `17 3`)"
            )))
        }
    };
    notes.push(format!("stiffness: {}", k.describe()));
    notes.push(format!("mass: {}", m.describe()));
    for f in [&k, &m] {
        if f.m.precision == 1 {
            notes.push(format!(
                "{} is single precision (about 7 significant digits)",
                f.m.name
            ));
        }
    }
    notes.push(
        if m.m.entries.is_diagonal() {
            "mass: lumped (diagonal)"
        } else {
            "mass: consistent"
        }
        .into(),
    );
    let nodes = uniform_nodes(&dofs, dofs_per_node, None, None, &mut notes)?;
    let encoding = |f: &Found| match f.m.encoding {
        Encoding::Ascii => "ASCII",
        Encoding::BinaryLittleEndian => "binary little-endian",
        Encoding::BinaryBigEndian => "binary big-endian",
    };
    let producer = format!(
        "Nastran OUTPUT4 ({}, {}; {})",
        k.m.name,
        m.m.name,
        encoding(&k)
    );
    let mut paths: Vec<PathBuf> = files.iter().map(|f| f.1.clone()).collect();
    paths.extend(dof_map.map(Path::to_path_buf));
    let full = |f: Found| {
        let (lower, upper) = f.m.entries.triangles();
        let mirror = f.m.form == 6 && (lower == 0 || upper == 0);
        f.m.entries.into_csc(n, mirror)
    };
    Ok(Imported {
        format: Format::NastranOp4,
        files: paths,
        producer,
        units: "not recorded (OP4 files carry no units)".into(),
        mass: full(m),
        stiffness: full(k),
        dofs,
        nodes,
        dofs_per_node,
        removed: Vec::new(),
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dof_map_sniffing() {
        assert!(looks_like_dof_map(b"# map\nnode,component\n17, 3\n"));
        assert!(looks_like_dof_map(b"1 1\n1 2\n"));
        assert!(!looks_like_dof_map(b"1 7\n"));
        assert!(!looks_like_dof_map(b"1 2 3\n"));
    }
}
