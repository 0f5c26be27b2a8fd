//! The OP4 writer: the layout [`read_op4`] reads (the format: [`crate::io::op4`]), written by
//! [`append`] in any of its encodings (ASCII, binary of either byte order) and column layouts
//! (dense, string-sparse, BIGMAT). ASCII values in real double precision carry 17 significant
//! digits and read back bit for bit; a value whose decimal exponent has three digits
//! (|v| < 1e-99 or ≥ 1e100) keeps 16, so that it still fits the 23-character field (pyNastran
//! and [`read_op4`] both read fields by width and neither reads Fortran's `E`-less form).
//!
//! [`read_op4`]: super::reader::read_op4

use super::format::{string_header, Encoding, MAX_STRING_ROW};
use crate::io::atomic;
use crate::sparse::Csc;
use crate::{Error, Result};
use faer::MatRef;
use std::path::Path;

/// How column records are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// One record per nonzero column: its values from the first to the last nonzero row.
    Dense,
    /// "String" records: runs of consecutive rows, each behind a one-word header
    /// `IROW + 65536·(L+1)` (at most 65535 rows).
    Sparse,
    /// As [`Layout::Sparse`] with two-word string headers `L+1, IROW` and a negative NROW.
    BigMat,
}

/// One matrix to write: columns of (0-based row, value), each sorted by row.
#[derive(Clone, Debug)]
pub struct Matrix<'a> {
    /// Name, 1–8 ASCII characters without blanks.
    pub name: &'a str,
    /// Rows.
    pub rows: usize,
    /// The columns; exact zeros are not written.
    pub cols: Vec<Vec<(usize, f64)>>,
    /// Form: 1 square, 2 rectangular, 6 symmetric, ...
    pub form: i32,
    /// Type: 1 real single, 2 real double precision.
    pub precision: i32,
}

/// Columns of a CSC matrix; with `lower`, only the lower triangle.
pub fn columns_of_csc(a: &Csc, lower: bool) -> Vec<Vec<(usize, f64)>> {
    (0..a.ncols())
        .map(|j| {
            a.row_idx_of_col_raw(j)
                .iter()
                .copied()
                .zip(a.val_of_col(j))
                .filter(|(i, _)| !lower || *i >= j)
                .map(|(i, &v)| (i, v))
                .collect()
        })
        .collect()
}

/// Columns of a dense matrix (its nonzero entries).
pub fn columns_of_dense(a: MatRef<'_, f64>) -> Vec<Vec<(usize, f64)>> {
    (0..a.ncols())
        .map(|j| {
            (0..a.nrows())
                .filter(|&i| a[(i, j)] != 0.0)
                .map(|i| (i, a[(i, j)]))
                .collect()
        })
        .collect()
}

/// Fortran `1P,E{width}.{digits}` of `v` (` 1.2345678901234567E+00`); a three-digit exponent
/// costs one mantissa digit so that the field keeps its width.
fn fortran_e(v: f64, digits: usize, width: usize) -> String {
    let field = |digits: usize| {
        let s = format!("{v:.digits$E}");
        let (mant, exp) = s.split_once('E').unwrap_or((&s, "0"));
        let exp: i32 = exp.parse().unwrap_or(0);
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{mant}E{sign}{:02}", exp.abs())
    };
    let s = field(digits);
    let s = if s.len() > width {
        field(digits - 1)
    } else {
        s
    };
    format!("{s:>width$}")
}

/// Runs of consecutive rows of one column.
fn runs(col: &[(usize, f64)]) -> Vec<&[(usize, f64)]> {
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..=col.len() {
        if k == col.len() || col[k].0 != col[k - 1].0 + 1 {
            out.push(&col[start..k]);
            start = k;
        }
    }
    out
}

/// An integer or a value of a column record.
enum Item {
    Int(i64),
    Value(f64),
}

/// Checks `m` before anything is written: name, type, sizes, row order and finite values.
fn check(m: &Matrix, lay: Layout) -> Result<()> {
    let bad = |msg: String| {
        Err(Error::InvalidSetting(format!(
            "OP4 matrix '{}': {msg}",
            m.name
        )))
    };
    if m.name.is_empty() || m.name.len() > 8 || !m.name.bytes().all(|b| b.is_ascii_graphic()) {
        return bad("a name is 1 to 8 ASCII characters without blanks".into());
    }
    if ![1, 2].contains(&m.precision) {
        return bad(format!(
            "type {}: only real matrices, single (1) or double (2) precision, are written",
            m.precision
        ));
    }
    let limit = i32::MAX as usize - 1;
    if m.rows > limit || m.cols.len() > limit {
        return bad(format!(
            "{}x{} is larger than OP4's 32-bit sizes",
            m.rows,
            m.cols.len()
        ));
    }
    if lay == Layout::Sparse && m.rows > MAX_STRING_ROW {
        return bad(format!(
            "{} rows do not fit the string-sparse header (at most {MAX_STRING_ROW}): use the BIGMAT layout",
            m.rows
        ));
    }
    for (j, col) in m.cols.iter().enumerate() {
        for (k, &(i, v)) in col.iter().enumerate() {
            if i >= m.rows || (k > 0 && col[k - 1].0 >= i) {
                return bad(format!(
                    "column {}: rows must be increasing and below {}",
                    j + 1,
                    m.rows
                ));
            }
            if !v.is_finite() {
                return bad(format!("entry ({}, {}) is {v}", i + 1, j + 1));
            }
        }
    }
    Ok(())
}

/// Appends `m` to `out` in OUTPUT4 layout (see the module doc).
///
/// # Errors
/// [`Error::InvalidSetting`] naming the matrix: a name that is not 1–8 ASCII characters, a
/// complex or unknown type, sizes beyond 32 bits (or 65535 rows in [`Layout::Sparse`]),
/// unsorted or out-of-range rows, a value that is not finite.
pub fn append(out: &mut Vec<u8>, m: &Matrix, enc: Encoding, lay: Layout) -> Result<()> {
    check(m, lay)?;
    let ncols = m.cols.len();
    let wpv = if m.precision == 1 { 1 } else { 2 };
    let nrows = if lay == Layout::BigMat {
        -(m.rows as i64)
    } else {
        m.rows as i64
    };
    // (icol, irow, nw, items)
    let mut recs: Vec<(usize, usize, usize, Vec<Item>)> = Vec::new();
    for (j, col) in m.cols.iter().enumerate() {
        let col: Vec<(usize, f64)> = col.iter().copied().filter(|e| e.1 != 0.0).collect();
        if col.is_empty() {
            continue;
        }
        match lay {
            Layout::Dense => {
                let (first, last) = (col[0].0, col[col.len() - 1].0);
                let mut vals = vec![0.0; last - first + 1];
                for &(i, v) in &col {
                    vals[i - first] = v;
                }
                let n = vals.len();
                recs.push((
                    j + 1,
                    first + 1,
                    n * wpv,
                    vals.into_iter().map(Item::Value).collect(),
                ));
            }
            Layout::Sparse | Layout::BigMat => {
                let mut items = Vec::new();
                let mut words = 0;
                for r in runs(&col) {
                    let l = (r.len() * wpv) as i64;
                    let row = r[0].0 as i64 + 1;
                    if lay == Layout::BigMat {
                        items.push(Item::Int(l + 1));
                        items.push(Item::Int(row));
                        words += 2;
                    } else {
                        items.push(Item::Int(string_header(row, l)));
                        words += 1;
                    }
                    items.extend(r.iter().map(|e| Item::Value(e.1)));
                    words += l as usize;
                }
                recs.push((j + 1, 0, words, items));
            }
        }
    }
    recs.push((ncols + 1, 1, wpv, vec![Item::Value(1.0)]));
    match enc {
        Encoding::Ascii => ascii(out, m, ncols, nrows, lay, recs),
        Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => {
            binary(out, m, ncols, nrows, enc == Encoding::BinaryBigEndian, recs)
        }
    }
    Ok(())
}

fn ascii(
    out: &mut Vec<u8>,
    m: &Matrix,
    ncols: usize,
    nrows: i64,
    lay: Layout,
    recs: Vec<(usize, usize, usize, Vec<Item>)>,
) {
    let (per, digits, width, fmt) = if m.precision == 1 {
        (5, 9, 16, "1P,5E16.9")
    } else {
        (3, 16, 23, "1P,3E23.16")
    };
    let mut s = format!(
        "{ncols:8}{nrows:8}{:8}{:8}{:<8}{fmt}\n",
        m.form, m.precision, m.name
    );
    let flush = |s: &mut String, line: &mut Vec<String>| {
        if !line.is_empty() {
            s.push_str(&line.concat());
            s.push('\n');
            line.clear();
        }
    };
    for (icol, irow, nw, items) in recs {
        s.push_str(&format!("{icol:8}{irow:8}{nw:8}\n"));
        let mut line = Vec::new();
        let mut ints = Vec::new();
        for it in items {
            match it {
                Item::Int(i) => {
                    flush(&mut s, &mut line);
                    ints.push(i);
                    if lay != Layout::BigMat || ints.len() == 2 {
                        s.push_str(&ints.iter().map(|i| format!("{i:8}")).collect::<String>());
                        s.push('\n');
                        ints.clear();
                    }
                }
                Item::Value(v) => {
                    line.push(fortran_e(v, digits, width));
                    if line.len() == per {
                        flush(&mut s, &mut line);
                    }
                }
            }
        }
        flush(&mut s, &mut line);
    }
    out.extend_from_slice(s.as_bytes());
}

fn binary(
    out: &mut Vec<u8>,
    m: &Matrix,
    ncols: usize,
    nrows: i64,
    be: bool,
    recs: Vec<(usize, usize, usize, Vec<Item>)>,
) {
    // every integer was checked to fit 32 bits
    let i4 = |v: i64| -> [u8; 4] {
        let v = v as i32;
        if be {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    };
    let record = |out: &mut Vec<u8>, body: Vec<u8>| {
        out.extend_from_slice(&i4(body.len() as i64));
        out.extend_from_slice(&body);
        out.extend_from_slice(&i4(body.len() as i64));
    };
    let mut h = Vec::new();
    for v in [ncols as i64, nrows, m.form as i64, m.precision as i64] {
        h.extend_from_slice(&i4(v));
    }
    h.extend_from_slice(format!("{:<8}", m.name).as_bytes());
    record(out, h);
    for (icol, irow, nw, items) in recs {
        let mut b = Vec::new();
        for v in [icol, irow, nw] {
            b.extend_from_slice(&i4(v as i64));
        }
        for it in items {
            match it {
                Item::Int(i) => b.extend_from_slice(&i4(i)),
                Item::Value(v) if m.precision == 1 => b.extend_from_slice(&if be {
                    (v as f32).to_be_bytes()
                } else {
                    (v as f32).to_le_bytes()
                }),
                Item::Value(v) => {
                    b.extend_from_slice(&if be { v.to_be_bytes() } else { v.to_le_bytes() })
                }
            }
        }
        record(out, b);
    }
}

/// Writes `mats` into the file `path` (atomically: a temporary file renamed at the end).
///
/// # Errors
/// As [`append`]; I/O errors naming the file.
pub fn write(path: &Path, mats: &[Matrix], enc: Encoding, lay: Layout) -> Result<()> {
    let mut bytes = Vec::new();
    for m in mats {
        append(&mut bytes, m, enc, lay)?;
    }
    atomic::write_bytes(path, bytes)
}
