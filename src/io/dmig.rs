//! Nastran DMIG bulk data of a ROM (docs/design.md §3.9, §4): `dmig.bdf` holds the ROM's Mr
//! as `MAAX`, Kr as `KAAX`, when it is not zero Dr as `BAAX`, and with structural damping
//! K₄r as `K4AAX` (symmetric, IFO = 6, real double precision, TIN = 2; one triangle), for a
//! Nastran run to add with `M2GG = MAAX`, `K2GG = KAAX`, `B2GG = BAAX`, `K42GG = K4AAX`; and
//! `coordinates.csv`, which row is which.
//!
//! The ROM's coordinates are keyed by grid and component: a physical coordinate (an interface,
//! retained or boundary DoF) by the grid of its node and its component 1–6 — through the DoF
//! map of an imported model (the FE code's node numbers), else node i (0-based row of
//! `nodes.csv`) is grid i + 1 with components 1..dofs_per_node — and a modal coordinate
//! (Craig–Bampton's fixed-interface modes) by a scalar point numbered above the model's
//! largest grid, declared by `SPOINT` entries.
//!
//! A ROM of a coupled model (docs/design.md §3.11; [`coordinates`] with its [`Joints`]) keys
//! a coordinate that is an original DoF by that DoF's grid, a remote point's `POINT:DIR` by
//! component DIR (1–6) of a grid for the point — numbered after the largest grid, in point
//! order, and defined by a `GRID*` entry at the point's position in `dmig.bdf` (the grid a
//! joint of the Nastran assembly attaches to) — and a functional given as a matrix row or
//! column (`FILE row k`) by a scalar point, after the points' grids; the modal coordinates'
//! scalar points follow. Column entries are large-field `DMIG*`
//! (16-character fields); each value takes whichever Nastran real form keeps the most digits
//! in 16 characters (fixed `-1234567.8901234`, or the exponent without its `E`,
//! `1.234567890123-4`): 14–15 significant digits for 1 ≤ |v| < 1e14, 12–13 with a one-digit
//! exponent, 11 with two, 10 with three. Sixteen digits do not fit a bulk data field; the
//! exact values are in the OP4 export ([`crate::io::op4`]).

use crate::coupled::{self, Joints};
use crate::io::atomic;
use crate::io::import::Dof;
use crate::model::Model;
use crate::reduce::Rom;
use crate::{Error, Result};
use faer::MatRef;
use std::fmt::Write as _;
use std::path::Path;

/// The bulk data file [`write`] writes.
pub const BULK_FILE: &str = "dmig.bdf";
/// The coordinate map [`write`] writes next to it.
pub const MAP_FILE: &str = "coordinates.csv";
/// Largest Nastran grid or scalar point id (8 digits).
pub const MAX_ID: u64 = 99_999_999;

/// A ROM coordinate as Nastran sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Coordinate {
    /// Grid or scalar point id.
    pub id: u64,
    /// Component 1–6 of a grid; 0 for a scalar point.
    pub component: u8,
    /// The model DoF of a physical coordinate; `None` for a modal one (a scalar point).
    pub dof: Option<usize>,
    /// The remote point whose grid this is (a coupled model's `POINT:DIR`), by index.
    pub point: Option<usize>,
}

/// The grid ids of `count` remote points: after the largest of `grids`, in point order
/// (module doc).
///
/// # Errors
/// [`Error::InvalidSetting`] when they run past [`MAX_ID`].
pub fn point_grids(grids: &[(u64, u8)], count: usize) -> Result<Vec<u64>> {
    let max = grids.iter().map(|p| p.0).max().unwrap_or(0);
    if max + count as u64 > MAX_ID {
        return Err(Error::InvalidSetting(format!(
            "{count} remote points' grids above grid {max} run past Nastran's largest id {MAX_ID}"
        )));
    }
    Ok((1..=count as u64).map(|k| max + k).collect())
}

/// The grid and component (1–6) of every DoF of the model (see the module doc).
///
/// # Errors
/// [`Error::InvalidSetting`] when the DoF map does not have one entry per DoF, or a grid id
/// is 0 or above [`MAX_ID`].
pub fn grids(model: &Model, dof_map: Option<&[Dof]>) -> Result<Vec<(u64, u8)>> {
    let n = model.n();
    let dpn = model.dofs_per_node.max(1);
    let g: Vec<(u64, u8)> = match dof_map {
        Some(map) => {
            if map.len() != n {
                return Err(Error::InvalidSetting(format!(
                    "model '{}': its DoF map names {} DoFs, the matrices have {n}",
                    model.name,
                    map.len()
                )));
            }
            map.iter().map(|d| (d.node, d.dir as u8 + 1)).collect()
        }
        None => (0..n)
            .map(|i| ((i / dpn) as u64 + 1, (i % dpn) as u8 + 1))
            .collect(),
    };
    if let Some(&(id, _)) = g.iter().find(|(id, _)| *id == 0 || *id > MAX_ID) {
        return Err(Error::InvalidSetting(format!(
            "model '{}': node {id} is not a Nastran grid id (1..={MAX_ID})",
            model.name
        )));
    }
    Ok(g)
}

/// The Nastran key of each ROM coordinate, in the ROM's order (see the module doc). For a
/// coupled model, `joints` relates its DoFs to the original model's, whose grids (by
/// `dof_map`) key them.
///
/// # Errors
/// [`Error::InvalidSetting`] when a ROM DoF is not a DoF of the model, the points' grids or
/// the scalar points run past [`MAX_ID`], or as [`grids`].
pub fn coordinates(
    rom: &Rom,
    model: &Model,
    dof_map: Option<&[Dof]>,
    joints: Option<&Joints>,
) -> Result<Vec<Coordinate>> {
    let g = grids(joints.map_or(model, |j| &j.original), dof_map)?;
    let points = point_grids(&g, joints.map_or(0, |j| j.points.len()))?;
    let max = points
        .last()
        .copied()
        .unwrap_or_else(|| g.iter().map(|p| p.0).max().unwrap_or(0));
    let out_of_range = |d: usize| Error::DofOutOfRange {
        what: "ROM dofs".into(),
        dof: d,
        n: joints.map_or(g.len(), |j| j.coordinates.len()),
    };
    let mut spoints = 0u64;
    let mut out = Vec::with_capacity(rom.order());
    for &d in &rom.dofs {
        let original = match joints {
            None => Some(d),
            Some(j) => match j.coordinates.get(d).ok_or_else(|| out_of_range(d))? {
                coupled::Coordinate::Dof(q) => Some(*q),
                coupled::Coordinate::Point { point, dir } => {
                    out.push(Coordinate {
                        id: points[*point],
                        component: *dir as u8 + 1,
                        dof: Some(d),
                        point: Some(*point),
                    });
                    continue;
                }
                coupled::Coordinate::Row(_) => None,
            },
        };
        let (id, component) = match original {
            Some(q) => *g.get(q).ok_or_else(|| out_of_range(d))?,
            None => {
                spoints += 1;
                (max + spoints, 0)
            }
        };
        out.push(Coordinate {
            id,
            component,
            dof: Some(d),
            point: None,
        });
    }
    let modal = rom.order().saturating_sub(rom.dofs.len()) as u64;
    if max + spoints + modal > MAX_ID {
        return Err(Error::InvalidSetting(format!(
            "{} scalar points above grid {max} run past Nastran's largest id {MAX_ID}",
            spoints + modal
        )));
    }
    out.extend((1..=modal).map(|k| Coordinate {
        id: max + spoints + k,
        component: 0,
        dof: None,
        point: None,
    }));
    Ok(out)
}

/// `v` as a Nastran real in at most `width` characters, keeping as many significant digits
/// as fit: fixed notation, or an exponent written without `E` (`1.25-3`), whichever parses
/// back closer to `v`. `None` for a value that is not finite.
pub fn real_field(v: f64, width: usize) -> Option<String> {
    if !v.is_finite() {
        return None;
    }
    if v == 0.0 {
        return Some("0.0".into());
    }
    let mut candidates = Vec::new();
    // exponent form: the most mantissa digits that fit
    for d in (1..width).rev() {
        let s = format!("{v:.d$e}");
        let (mant, exp) = s.split_once('e')?;
        let exp: i32 = exp.parse().ok()?;
        let s = format!("{mant}{}{}", if exp < 0 { '-' } else { '+' }, exp.abs());
        if s.len() <= width {
            candidates.push(s);
            break;
        }
    }
    // the same with the mantissa cut instead of rounded: finite where rounding up overflows
    let full = format!("{v:.20e}");
    let (mant, exp) = full.split_once('e')?;
    let exp: i32 = exp.parse().ok()?;
    let tail = format!("{}{}", if exp < 0 { '-' } else { '+' }, exp.abs());
    let keep = width.saturating_sub(tail.len()).min(mant.len());
    candidates.push(format!("{}{tail}", &mant[..keep]));
    // fixed form: the most decimals that fit (a leading "0." written as ".")
    for d in (1..width).rev() {
        let s = format!("{v:.d$}");
        let s = s
            .strip_prefix("0.")
            .map(|r| format!(".{r}"))
            .or_else(|| s.strip_prefix("-0.").map(|r| format!("-.{r}")))
            .unwrap_or(s);
        if s.len() <= width {
            candidates.push(s);
            break;
        }
    }
    // the exponent form has its exponent's sign after the first character
    let parse = |s: &str| -> f64 {
        match s[1..].rfind(['+', '-']) {
            Some(k) => format!("{}e{}", &s[..k + 1], &s[k + 1..]).parse(),
            None => s.parse(),
        }
        .unwrap_or(f64::NAN)
    };
    candidates
        .into_iter()
        .filter(|s| parse(s) != 0.0 && parse(s).is_finite())
        .min_by(|a, b| {
            (parse(a) - v)
                .abs()
                .total_cmp(&(parse(b) - v).abs())
                .then(a.len().cmp(&b.len()))
        })
}

/// A 16-character large field, right-aligned.
fn f16(s: &str) -> String {
    format!("{s:>16}")
}

/// Appends one symmetric DMIG matrix: the small-field header and one large-field column entry
/// per nonzero column, the lower triangle in (id, component) order.
fn matrix(out: &mut String, name: &str, a: MatRef<'_, f64>, keys: &[Coordinate]) -> Result<()> {
    let _ = writeln!(out, "$ {name}: {}x{}", a.nrows(), a.ncols());
    let _ = writeln!(out, "DMIG    {name:<8}       0       6       2       0");
    let mut order: Vec<usize> = (0..keys.len()).collect();
    order.sort_by_key(|&i| (keys[i].id, keys[i].component));
    for (pj, &j) in order.iter().enumerate() {
        let rows: Vec<usize> = order[pj..]
            .iter()
            .copied()
            .filter(|&i| a[(i, j)] != 0.0)
            .collect();
        if rows.is_empty() {
            continue;
        }
        let _ = writeln!(
            out,
            "DMIG*   {}{}{}",
            f16(name),
            f16(&keys[j].id.to_string()),
            f16(&keys[j].component.to_string())
        );
        for i in rows {
            let v = real_field(a[(i, j)], 16).ok_or_else(|| {
                Error::InvalidSetting(format!(
                    "{name}: entry ({i}, {j}) is {}; only finite values can be written",
                    a[(i, j)]
                ))
            })?;
            let _ = writeln!(
                out,
                "*       {}{}{}",
                f16(&keys[i].id.to_string()),
                f16(&keys[i].component.to_string()),
                f16(&v)
            );
        }
    }
    Ok(())
}

/// The DMIG names [`write`] uses for Mr, Kr, Dr and K₄r.
pub const NAMES: [&str; 4] = ["MAAX", "KAAX", "BAAX", "K4AAX"];

/// Writes `dmig.bdf` and `coordinates.csv` (see the module doc) into the new directory `dir`;
/// `joints` for a ROM of a coupled model (its points' grids are defined in `dmig.bdf`).
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty (naming it), as
/// [`coordinates`], or for a matrix value or point position that is not finite; I/O errors.
pub fn write(
    dir: &Path,
    rom: &Rom,
    model: &Model,
    dof_map: Option<&[Dof]>,
    joints: Option<&Joints>,
) -> Result<()> {
    rom.check_model(model.n())?;
    let keys = coordinates(rom, model, dof_map, joints)?;
    let spoints: Vec<u64> = keys
        .iter()
        .filter(|c| c.component == 0)
        .map(|c| c.id)
        .collect();
    let damped = rom.dr.col_iter().any(|c| c.iter().any(|&v| v != 0.0));
    let mut bdf = String::new();
    let _ = writeln!(
        bdf,
        "$ sparsemor {} {} ROM of model '{}', order {}: DMIG bulk data",
        env!("CARGO_PKG_VERSION"),
        rom.method(),
        model.name,
        rom.order()
    );
    let _ = writeln!(
        bdf,
        "$ case control: M2GG = MAAX, K2GG = KAAX{}{}; rows and columns: {MAP_FILE}",
        if damped { ", B2GG = BAAX" } else { "" },
        if rom.k4r.is_some() {
            ", K42GG = K4AAX"
        } else {
            ""
        }
    );
    if let Some(j) = joints {
        let g = grids(&j.original, dof_map)?;
        for (p, id) in j.points.iter().zip(point_grids(&g, j.points.len())?) {
            let x = p
                .position
                .map(|v| real_field(v, 16))
                .into_iter()
                .collect::<Option<Vec<String>>>()
                .ok_or_else(|| {
                    Error::InvalidSetting(format!(
                        "remote point {}: its position {:?} is not finite",
                        p.name, p.position
                    ))
                })?;
            let _ = writeln!(bdf, "$ remote point {}: grid {id}", p.name);
            let _ = writeln!(
                bdf,
                "GRID*   {}{}{}{}\n*       {}",
                f16(&id.to_string()),
                f16(""),
                f16(&x[0]),
                f16(&x[1]),
                f16(&x[2])
            );
        }
    }
    if let (Some(first), Some(last)) = (spoints.first(), spoints.last()) {
        let what = if keys.iter().any(|c| c.component == 0 && c.dof.is_some()) {
            "functionals and modal coordinates"
        } else {
            "modal coordinates"
        };
        let _ = writeln!(bdf, "$ {what}: scalar points {first}..{last}");
        let _ = if first == last {
            writeln!(bdf, "SPOINT  {first:<8}")
        } else {
            writeln!(bdf, "SPOINT  {first:<8}THRU    {last:<8}")
        };
    }
    matrix(&mut bdf, NAMES[0], rom.mr.as_ref(), &keys)?;
    matrix(&mut bdf, NAMES[1], rom.kr.as_ref(), &keys)?;
    if damped {
        matrix(&mut bdf, NAMES[2], rom.dr.as_ref(), &keys)?;
    }
    if let Some(k4r) = &rom.k4r {
        matrix(&mut bdf, NAMES[3], k4r.as_ref(), &keys)?;
    }
    let mut csv = String::from("row,id,component,kind,model_dof\n");
    for (r, c) in keys.iter().enumerate() {
        let _ = match (c.dof, c.point, c.component) {
            (Some(d), Some(_), _) => writeln!(csv, "{r},{},{},point,{d}", c.id, c.component),
            (Some(d), None, 0) => writeln!(csv, "{r},{},0,spoint,{d}", c.id),
            (Some(d), None, _) => writeln!(csv, "{r},{},{},grid,{d}", c.id, c.component),
            (None, _, _) => writeln!(csv, "{r},{},0,spoint,", c.id),
        };
    }
    atomic::write_dir(dir, |tmp| {
        atomic::write_bytes(&tmp.join(BULK_FILE), bdf)?;
        atomic::write_bytes(&tmp.join(MAP_FILE), csv)
    })
}
