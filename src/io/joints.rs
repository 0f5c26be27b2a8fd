//! The joints of a model directory (docs/design.md §4, §3.11): `[[remote_points]]` tables —
//! a name, a kind, a node selection (list, box or cylinder on `nodes.csv`) and optional
//! position and weights — and the scene's inputs and outputs as [`Functional`]s: a DoF, a
//! point's `POINT:DIR`, or the columns of `[scene] input_matrix` (B, N × p) and rows of
//! `output_matrix` (C, q × N). [`crate::io::model_dir::load`] couples the model with them
//! ([`crate::coupled::couple`]).

use crate::coupled::Functional;
use crate::coupling::{Kind, RemotePoint, SparseRow};
use crate::io::import::Direction;
use crate::io::matrix_market;
use crate::rigid::centroid;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A `[[remote_points]]` table.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RemotePointToml {
    /// The point's name, used as `NAME:DIR` in the scene (letters, digits, `_`; not starting
    /// with a digit).
    pub name: String,
    /// `rigid` (RBE2, kinematic) or `distributing` (RBE3).
    pub kind: String,
    /// The reference position; default: the centroid of the selected nodes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f64; 3]>,
    /// The nodes by their 0-based rows of `nodes.csv`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nodes: Option<Vec<usize>>,
    /// The nodes inside a closed box.
    #[serde(default, rename = "box", skip_serializing_if = "Option::is_none")]
    pub bbox: Option<BoxToml>,
    /// The nodes on a cylinder's mantle.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cylinder: Option<CylinderToml>,
    /// One weight per selected node in increasing node order (distributing only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weights: Option<Vec<f64>>,
}

/// `box = { min = [..], max = [..] }`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxToml {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

/// `cylinder = { center, axis, radius, length, tol }`: the nodes whose distance from the axis
/// line through `center` is within `tol` of `radius` and whose axial offset from `center` is
/// at most `length`/2.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderToml {
    /// A point on the axis, the middle of the selected length.
    pub center: [f64; 3],
    /// The axis direction (any length > 0).
    pub axis: [f64; 3],
    /// The mantle's radius.
    pub radius: f64,
    /// The selected length along the axis.
    pub length: f64,
    /// The radial tolerance.
    pub tol: f64,
}

impl RemotePointToml {
    /// The remote point over `nodes` (the model's node coordinates).
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] naming the point: a bad name or kind, not exactly one
    /// selection, a selection of no node, weights on a rigid point, non-finite geometry.
    pub fn point(&self, nodes: &[[f64; 3]]) -> Result<RemotePoint> {
        let bad = |why: String| {
            Error::InvalidSetting(format!("[[remote_points]] '{}': {why}", self.name))
        };
        let valid_name = self
            .name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !valid_name {
            return Err(bad(
                "a name is letters, digits and '_', not starting with a digit (it is used as \
                 NAME:DIR in [scene])"
                    .into(),
            ));
        }
        let kind = match self.kind.as_str() {
            "rigid" => Kind::Rigid,
            "distributing" => Kind::Distributing,
            k => {
                return Err(bad(format!(
                    "kind = \"{k}\": use \"rigid\" (RBE2) or \"distributing\" (RBE3)"
                )))
            }
        };
        let selected = match (&self.nodes, &self.bbox, &self.cylinder) {
            (Some(list), None, None) => list.clone(),
            (None, Some(b), None) => select(nodes, |x| {
                (0..3).all(|a| b.min[a] <= x[a] && x[a] <= b.max[a])
            }),
            (None, None, Some(c)) => {
                let len = c.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
                let finite = [c.radius, c.length, c.tol, len]
                    .iter()
                    .chain(&c.center)
                    .all(|v| v.is_finite());
                if !(finite && len > 0.0 && c.tol >= 0.0 && c.length >= 0.0) {
                    return Err(bad(
                        "cylinder: need finite center, a nonzero axis, radius, length >= 0 and \
                         tol >= 0"
                            .into(),
                    ));
                }
                let e = c.axis.map(|v| v / len);
                select(nodes, |x| {
                    let d = [0, 1, 2].map(|a| x[a] - c.center[a]);
                    let along: f64 = (0..3).map(|a| d[a] * e[a]).sum();
                    let radial = (0..3)
                        .map(|a| (d[a] - along * e[a]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    along.abs() <= 0.5 * c.length && (radial - c.radius).abs() <= c.tol
                })
            }
            _ => {
                return Err(bad(
                    "give exactly one node selection: `nodes`, `box` or `cylinder`".into(),
                ))
            }
        };
        if selected.is_empty() {
            return Err(bad(
                "its selection holds no node; check it against nodes.csv".into(),
            ));
        }
        if let Some(&i) = selected.iter().find(|&&i| i >= nodes.len()) {
            return Err(bad(format!(
                "node {i} is out of range (nodes.csv has {} nodes)",
                nodes.len()
            )));
        }
        let weights = self.weights.clone().unwrap_or_default();
        if kind == Kind::Rigid && !weights.is_empty() {
            return Err(bad(
                "weights apply to a distributing point only; remove them".into(),
            ));
        }
        let position = match self.position {
            Some(p) => p,
            None => centroid(&selected.iter().map(|&i| nodes[i]).collect::<Vec<_>>()),
        };
        Ok(RemotePoint {
            name: self.name.clone(),
            position,
            nodes: selected,
            weights,
            kind,
        })
    }
}

/// The rows of `nodes` (increasing) for which `keep` holds.
fn select(nodes: &[[f64; 3]], keep: impl Fn(&[f64; 3]) -> bool) -> Vec<usize> {
    (0..nodes.len()).filter(|&i| keep(&nodes[i])).collect()
}

/// The points of `tables` over `nodes`.
///
/// # Errors
/// As [`RemotePointToml::point`], and two points of one name.
pub fn points(tables: &[RemotePointToml], nodes: &[[f64; 3]]) -> Result<Vec<RemotePoint>> {
    for (k, t) in tables.iter().enumerate() {
        if tables[..k].iter().any(|u| u.name == t.name) {
            return Err(Error::InvalidSetting(format!(
                "[[remote_points]]: two points are named '{}'; names must be unique",
                t.name
            )));
        }
    }
    tables.iter().map(|t| t.point(nodes)).collect()
}

/// `NAME:DIR` of one of `points`, or `None` when the token names no point.
///
/// # Errors
/// [`Error::InvalidSetting`] for a point's name with an unknown direction.
pub fn point_dof(points: &[RemotePoint], token: &str) -> Result<Option<Functional>> {
    let Some((name, dir)) = token.split_once(':') else {
        return Ok(None);
    };
    let Some(point) = points.iter().position(|p| p.name == name.trim()) else {
        return Ok(None);
    };
    let dir: Direction = dir.parse()?;
    Ok(Some(Functional::Point {
        point,
        dir: dir as usize,
    }))
}

/// The columns (`by_column`, B) or rows (C) of the Matrix Market file `path` as functionals
/// over a model of `n` DoFs, named by file and 0-based index.
///
/// # Errors
/// As [`matrix_market::read_sparse`]; [`Error::InvalidSetting`] naming the file for a size
/// that does not match N.
pub fn matrix_functionals(path: &Path, n: usize, by_column: bool) -> Result<Vec<Functional>> {
    let a = matrix_market::read_sparse(path)?;
    let (along, across, what) = if by_column {
        (a.nrows(), a.ncols(), "column")
    } else {
        (a.ncols(), a.nrows(), "row")
    };
    if along != n {
        let (shape, need) = if by_column {
            ("B", format!("{n} × p"))
        } else {
            ("C", format!("q × {n}"))
        };
        return Err(Error::InvalidSetting(format!(
            "{}: {} × {} but {shape} must be {need} (the model has N = {n})",
            path.display(),
            a.nrows(),
            a.ncols()
        )));
    }
    let mut rows = vec![SparseRow::default(); across];
    for j in 0..a.ncols() {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            let (k, c) = if by_column { (j, i) } else { (i, j) };
            rows[k].idx.push(c);
            rows[k].val.push(v);
        }
    }
    let file = path.file_name().map_or_else(
        || path.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    // a CSC walk gives each row's (and column's) entries in increasing index
    rows.into_iter()
        .enumerate()
        .map(|(k, r)| {
            if r.val.iter().all(|v| *v == 0.0) {
                return Err(Error::InvalidSetting(format!(
                    "{}: {what} {k} is zero; every input and output needs a nonzero entry",
                    path.display()
                )));
            }
            Ok(Functional::Row(format!("{file} {what} {k}"), r))
        })
        .collect()
}
