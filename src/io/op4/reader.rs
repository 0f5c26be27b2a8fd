//! The OP4 reader, [`read_op4`] (the format: [`crate::io::op4`]).
//!
//! Only real matrices (types 1 and 2) are read; complex ones are refused naming the matrix
//! and its type. Exact zeros are not stored. The ASCII reader takes the number of values from
//! the value lines themselves and checks every value against the matrix size; for dense
//! records it also checks `NW` (pyNastran writes the value count instead of the word count
//! there, which is accepted).
//!
//! # Streaming and bounds
//! Binary files are read one record at a time (a record is one column at most), ASCII files
//! one line at a time; only the nonzero entries are kept. Every record length is checked
//! against the bytes left in the file before anything is allocated for it, and every row and
//! column index against the header's size, so a header declaring a huge matrix allocates
//! nothing by itself. Errors name the file and the line (ASCII) or the byte offset of the
//! record (binary).

use super::format::{split_string_header, Encoding, MAX_STRING_ROW};
use crate::io::binary::BinaryFile;
use crate::io::file::head;
use crate::io::text::{for_each_line, show};
use crate::sparse::Triplets;
use crate::{Error, Result};
use std::fmt;
use std::path::Path;

/// Where a matrix starts in its file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Location {
    /// 1-based line of the header (ASCII file).
    Line(usize),
    /// Byte offset of the header record (binary file).
    Byte(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "line {l}"),
            Location::Byte(b) => write!(f, "byte {b}"),
        }
    }
}

/// One real matrix of an OP4 file.
#[derive(Clone, Debug)]
pub struct Op4Matrix {
    /// The name, trimmed (`KAA`).
    pub name: String,
    /// Rows (the absolute value of the header's NROW).
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Form: 1 square, 2 rectangular, 6 symmetric, ... as the header says.
    pub form: i32,
    /// Type: 1 real single, 2 real double precision.
    pub precision: i32,
    /// True when the header announced the BIGMAT sparse layout.
    pub bigmat: bool,
    /// The nonzero entries as stored (0-based row, column); a symmetric matrix may hold one
    /// triangle or both.
    pub entries: Triplets,
    /// Where the header is.
    pub at: Location,
    /// The file's encoding.
    pub encoding: Encoding,
}

/// The name of an OP4 matrix type.
fn type_name(t: i32) -> &'static str {
    match t {
        1 => "real single precision",
        2 => "real double precision",
        3 => "complex single precision",
        4 => "complex double precision",
        _ => "unknown",
    }
}

/// Words per value of a real type; complex and unknown types are refused.
fn words_per_value(path: &Path, at: Location, name: &str, ty: i32) -> Result<usize> {
    let err = |msg: String| match at {
        Location::Line(l) => Error::parse(path, l, msg),
        Location::Byte(b) => Error::parse(path, 0, format!("byte {b}: {msg}")),
    };
    match ty {
        1 => Ok(1),
        2 => Ok(2),
        3 | 4 => Err(err(format!(
            "matrix {name} is complex (type {ty}, {}): only real matrices (types 1 and 2) can be imported",
            type_name(ty)
        ))),
        _ => Err(err(format!(
            "matrix {name} has type {ty}; OP4 types are 1-4 (corrupt header?)"
        ))),
    }
}

/// Rows and columns from the header (NROW < 0: BIGMAT), bounded by i32.
fn size(
    ncols: i64,
    nrows: i64,
    err: &dyn Fn(String) -> Error,
    name: &str,
) -> Result<(usize, usize, bool)> {
    let limit = i64::from(i32::MAX);
    if ncols < 1 || ncols > limit || nrows == 0 || nrows.unsigned_abs() > limit as u64 {
        return Err(err(format!(
            "matrix {name}: header declares {} rows and {ncols} columns; need 1 to {limit} each",
            nrows.unsigned_abs()
        )));
    }
    let bigmat = !(0..=MAX_STRING_ROW as i64).contains(&nrows);
    Ok((nrows.unsigned_abs() as usize, ncols as usize, bigmat))
}

/// Reads every matrix of an OP4 file, ASCII or binary (either byte order); the format and
/// the reader's checks: the module documentation of [`crate::io::op4`] and of this reader.
///
/// # Errors
/// [`Error::Io`]; [`Error::Parse`] naming the file and the line or byte offset: truncated
/// records, record-length markers that disagree, a record longer than the file, indices
/// outside the declared size, complex or unknown types, non-finite values.
pub fn read_op4(path: &Path) -> Result<Vec<Op4Matrix>> {
    read_op4_keeping(path, &|_| true)
}

/// [`read_op4`], keeping the entries only of the matrices `keep` accepts by name (the others
/// are parsed and checked but come back without entries).
pub fn read_op4_keeping(path: &Path, keep: &dyn Fn(&str) -> bool) -> Result<Vec<Op4Matrix>> {
    let h = head(path)?;
    if h.len() >= 4 {
        let w = [h[0], h[1], h[2], h[3]];
        for (v, big) in [
            (u32::from_le_bytes(w), false),
            (u32::from_be_bytes(w), true),
        ] {
            if v == 24 {
                return read_binary(path, big, keep);
            }
            if v == 48 {
                return Err(Error::parse(
                    path,
                    0,
                    "byte 0: a 48-byte header record: an OP4 file with 8-byte integers, which is not supported; write it with 4-byte integers",
                ));
            }
        }
    }
    read_ascii(path, keep)
}

/// True when `h` (a file's first bytes) looks like an OP4 file: a binary header record (24 or
/// 48 bytes, framed by equal markers) or an ASCII header line.
pub(crate) fn looks_like_op4(h: &[u8]) -> bool {
    if h.len() >= 32 {
        let w = |i: usize| [h[i], h[i + 1], h[i + 2], h[i + 3]];
        for f in [u32::from_le_bytes, u32::from_be_bytes] {
            if f(w(0)) == 24 && f(w(28)) == 24 {
                return true;
            }
            if f(w(0)) == 48 && h.len() >= 56 && f(w(52)) == 48 {
                return true;
            }
        }
    }
    let line = h.split(|&b| b == b'\n').next().unwrap_or(&[]);
    ascii_header(line).is_some()
}

/// An ASCII header line: `NCOL NROW NF NTYPE` in 4 fields of 8, the name in 8 columns, the
/// values' Fortran format (`1P,3E23.16`). Returns the numbers, the name and (values a line,
/// field width).
fn ascii_header(line: &[u8]) -> Option<([i64; 4], String, (usize, usize))> {
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    if line.len() < 41 || !line.is_ascii() {
        return None;
    }
    let text = std::str::from_utf8(line).ok()?;
    let mut nums = [0i64; 4];
    let fixed = nums.iter_mut().enumerate().all(|(k, n)| {
        // Fortran I8: right-justified.
        text.get(8 * k..8 * k + 8)
            .filter(|f| f.ends_with(|c: char| c.is_ascii_digit()))
            .and_then(|f| f.trim().parse().ok())
            .map(|v| *n = v)
            .is_some()
    });
    let (name, fmt) = if fixed {
        (text.get(32..40)?.trim(), text.get(40..)?)
    } else {
        // Numbers wider than their 8 columns: read the fields between blanks.
        let t: Vec<&str> = text.split_whitespace().collect();
        if t.len() != 6 {
            return None;
        }
        for (n, f) in nums.iter_mut().zip(&t) {
            *n = f.parse().ok()?;
        }
        (t[4], t[5])
    };
    let name = name.to_string();
    if name.is_empty() {
        return None;
    }
    let fmt = fmt.trim().to_ascii_uppercase();
    let spec = fmt.rsplit(',').next()?;
    let (count, rest) = spec.split_once(['E', 'D'])?;
    let width = rest.split('.').next()?;
    let count: usize = if count.is_empty() {
        1
    } else {
        count.parse().ok()?
    };
    let width: usize = width.parse().ok()?;
    (count >= 1 && (2..=64).contains(&width)).then_some((nums, name, (count, width)))
}

/// Sequential reader of Fortran unformatted records.
struct Records {
    f: BinaryFile,
    buf: Vec<u8>,
}

impl Records {
    fn error(&self, at: u64, msg: impl fmt::Display) -> Error {
        self.f.error(at, msg)
    }

    fn word(&self, b: &[u8]) -> u32 {
        self.f.word(b)
    }

    fn int(&self, i: usize) -> i32 {
        self.word(&self.buf[4 * i..4 * i + 4]) as i32
    }

    fn read_exact(&mut self, n: usize, at: u64, what: &str) -> Result<()> {
        self.buf.resize(n, 0);
        self.f.read_exact(&mut self.buf[..n], at, what)
    }

    /// Reads the next record into `buf`; returns its byte offset.
    fn record(&mut self, what: &str) -> Result<u64> {
        let at = self.f.pos;
        if self.f.len - at < 4 {
            return Err(self.error(at, format!("the file ends before {what} (truncated file?)")));
        }
        self.read_exact(4, at, what)?;
        let n = u64::from(self.word(&self.buf[..4]));
        let left = self.f.len - at - 4;
        if n > left.saturating_sub(4) {
            return Err(self.error(
                at,
                format!(
                    "{what}: the record-length marker says {n} bytes but only {} bytes follow (truncated file or wrong marker?)",
                    left.saturating_sub(4)
                ),
            ));
        }
        let n = n as usize;
        self.read_exact(n + 4, at, what)?;
        let trailer = self.word(&self.buf[n..n + 4]);
        if trailer as usize != n {
            return Err(self.error(
                at,
                format!(
                    "{what}: the record-length marker at byte {at} says {n} bytes, the one closing it at byte {} says {trailer} (corrupt file)",
                    at + 4 + n as u64
                ),
            ));
        }
        self.buf.truncate(n);
        self.f.pos = at + 8 + n as u64;
        Ok(at)
    }

    /// Value `k` (0-based) of the data that starts at word `w0` of the record.
    fn value(&self, w0: usize, k: usize, wpv: usize) -> f64 {
        let b = &self.buf[4 * (w0 + k * wpv)..];
        if wpv == 1 {
            f64::from(f32::from_bits(self.word(b)))
        } else {
            let mut w = [0u8; 8];
            w.copy_from_slice(&b[..8]);
            f64::from_bits(if self.f.big_endian {
                u64::from_be_bytes(w)
            } else {
                u64::from_le_bytes(w)
            })
        }
    }
}

/// Adds one value; rejects non-finite ones, skips exact zeros.
fn put(
    t: &mut Triplets,
    keep: bool,
    row: usize,
    col: usize,
    v: f64,
) -> std::result::Result<(), String> {
    if !v.is_finite() {
        return Err(format!(
            "value {v} at row {}, column {} is not finite",
            row + 1,
            col + 1
        ));
    }
    if keep && v != 0.0 {
        t.push(row, col, v);
    }
    Ok(())
}

fn read_binary(path: &Path, big: bool, keep: &dyn Fn(&str) -> bool) -> Result<Vec<Op4Matrix>> {
    let mut r = Records {
        f: BinaryFile::open(path, big)?,
        buf: Vec::new(),
    };
    let encoding = if big {
        Encoding::BinaryBigEndian
    } else {
        Encoding::BinaryLittleEndian
    };
    let mut out = Vec::new();
    while r.f.pos < r.f.len {
        let at = r.record("the matrix header record")?;
        if r.buf.len() != 24 {
            return Err(r.error(
                at,
                format!(
                    "expected a matrix header record of 24 bytes (NCOL, NROW, NF, NTYPE, NAME), found {} bytes",
                    r.buf.len()
                ),
            ));
        }
        let (ncols, nrows, form, ty) = (r.int(0), r.int(1), r.int(2), r.int(3));
        let name = String::from_utf8_lossy(&r.buf[16..24]).trim().to_string();
        let loc = Location::Byte(at);
        let wpv = words_per_value(path, loc, &name, ty)?;
        let (rows, cols, bigmat) = size(
            i64::from(ncols),
            i64::from(nrows),
            &|m| r.error(at, m),
            &name,
        )?;
        let kept = keep(&name);
        let mut t = Triplets::default();
        loop {
            let what = format!("a column record of matrix {name}");
            let rat = r.record(&what)?;
            let e = |r: &Records, m: String| r.error(rat, format!("matrix {name}: {m}"));
            if r.buf.len() < 12 || r.buf.len() % 4 != 0 {
                return Err(e(
                    &r,
                    format!(
                        "a column record of {} bytes; it needs ICOL, IROW, NW and whole words",
                        r.buf.len()
                    ),
                ));
            }
            let (icol, irow, nw) = (r.int(0), r.int(1), r.int(2));
            let words = r.buf.len() / 4 - 3;
            if icol as i64 == cols as i64 + 1 {
                break;
            }
            if icol < 1 || icol as usize > cols {
                return Err(e(
                    &r,
                    format!(
                        "column {icol} outside 1..={cols} (and not the end record {})",
                        cols + 1
                    ),
                ));
            }
            if nw < 0 || nw as usize != words {
                return Err(e(
                    &r,
                    format!("the column record says NW = {nw} words but holds {words}"),
                ));
            }
            let col = icol as usize - 1;
            if irow > 0 {
                let first = irow as usize - 1;
                let n = words / wpv;
                if words % wpv != 0 || first + n > rows {
                    return Err(e(
                        &r,
                        format!(
                            "column {icol}: {words} words from row {irow} do not fit {rows} rows of {} values",
                            type_name(ty)
                        ),
                    ));
                }
                for k in 0..n {
                    let v = r.value(3, k, wpv);
                    put(&mut t, kept, first + k, col, v).map_err(|m| e(&r, m))?;
                }
            } else if irow == 0 {
                let mut w = 3;
                let end = 3 + words;
                while w < end {
                    let (first, l, hw) = if bigmat {
                        if w + 2 > end {
                            return Err(e(
                                &r,
                                format!("column {icol}: a string header is cut off"),
                            ));
                        }
                        (r.int(w + 1) as i64, r.int(w) as i64 - 1, 2)
                    } else {
                        let (first, l) = split_string_header(i64::from(r.int(w)));
                        (first, l, 1)
                    };
                    w += hw;
                    if l < 1 || l as usize % wpv != 0 || l as usize > end - w {
                        return Err(e(
                            &r,
                            format!(
                                "column {icol}: a string of {l} words at word {} does not fit the record ({} words left, {wpv} per value)",
                                w - hw,
                                end - w
                            ),
                        ));
                    }
                    let n = l as usize / wpv;
                    if first < 1 || first as usize - 1 + n > rows {
                        return Err(e(
                            &r,
                            format!("column {icol}: a string of {n} values from row {first} does not fit {rows} rows"),
                        ));
                    }
                    for k in 0..n {
                        let v = r.value(w, k, wpv);
                        put(&mut t, kept, first as usize - 1 + k, col, v).map_err(|m| e(&r, m))?;
                    }
                    w += l as usize;
                }
            } else {
                return Err(e(&r, format!("column {icol}: IROW = {irow} is negative")));
            }
        }
        out.push(Op4Matrix {
            name,
            rows,
            cols,
            form,
            precision: ty,
            bigmat,
            entries: t,
            at: loc,
            encoding,
        });
    }
    if out.is_empty() {
        return Err(Error::parse(path, 0, "byte 0: no matrix in the file"));
    }
    Ok(out)
}

struct Current {
    m: Op4Matrix,
    kept: bool,
    wpv: usize,
    per_line: usize,
    width: usize,
    /// Column (0-based) of the record being read; `None` after the end record.
    col: Option<usize>,
    /// Next row (0-based) a value goes to; `None` while a sparse record waits for a string
    /// header.
    row: Option<usize>,
    /// Dense record: its line, NW and the values read so far.
    dense: Option<(usize, i64, usize)>,
}

impl Current {
    fn check_dense(&mut self, path: &Path) -> Result<()> {
        if let Some((line, nw, got)) = self.dense.take() {
            let words = (got * self.wpv) as i64;
            if nw != words && nw != got as i64 {
                return Err(Error::parse(
                    path,
                    line,
                    format!(
                        "matrix {}: the column record says NW = {nw} words but {got} values follow",
                        self.m.name
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The integers of a line whose every token is one: the first four and the count; `None`
/// when a token is not an integer (a line of values). No allocation: this runs per line.
fn all_ints(line: &[u8]) -> Option<([i64; 4], usize)> {
    let mut out = [0i64; 4];
    let mut count = 0;
    for t in line
        .split(u8::is_ascii_whitespace)
        .filter(|t| !t.is_empty())
    {
        let v = std::str::from_utf8(t).ok()?.parse::<i64>().ok()?;
        if count < 4 {
            out[count] = v;
        }
        count += 1;
    }
    Some((out, count))
}

/// Starts a matrix at an ASCII header line.
fn ascii_start(
    path: &Path,
    line: usize,
    bytes: &[u8],
    keep: &dyn Fn(&str) -> bool,
) -> Result<Box<Current>> {
    let Some(([ncols, nrows, form, ty], name, (per_line, width))) = ascii_header(bytes) else {
        return Err(Error::parse(
            path,
            line,
            format!(
                "expected an OP4 matrix header `NCOL NROW NF NTYPE NAME FORMAT` (4I8, A8, e.g. 1P,3E23.16), found '{}'",
                show(bytes)
            ),
        ));
    };
    let loc = Location::Line(line);
    let ty = i32::try_from(ty).unwrap_or(0);
    let wpv = words_per_value(path, loc, &name, ty)?;
    let (rows, cols, bigmat) = size(ncols, nrows, &|m| Error::parse(path, line, m), &name)?;
    let kept = keep(&name);
    Ok(Box::new(Current {
        m: Op4Matrix {
            name,
            rows,
            cols,
            form: i32::try_from(form).unwrap_or(0),
            precision: ty,
            bigmat,
            entries: Triplets::default(),
            at: loc,
            encoding: Encoding::Ascii,
        },
        kept,
        wpv,
        per_line,
        width,
        col: Some(0),
        row: None,
        dense: None,
    }))
}

/// One line inside a matrix: a column record, a string header or values.
fn ascii_line(path: &Path, line: usize, bytes: &[u8], c: &mut Current) -> Result<()> {
    let err =
        |c: &Current, m: String| Error::parse(path, line, format!("matrix {}: {m}", c.m.name));
    if let Some((ints, count)) = all_ints(bytes) {
        let ints = &ints[..count.min(4)];
        if c.col.is_none() {
            return Err(err(
                c,
                "an integer line after the end record; expected the next matrix header".into(),
            ));
        }
        let rows = c.m.rows as i64;
        match *ints {
            [icol, irow, nw] => {
                c.check_dense(path)?;
                if icol == c.m.cols as i64 + 1 {
                    c.col = None;
                    c.row = None;
                    return Ok(());
                }
                if icol < 1 || icol > c.m.cols as i64 {
                    return Err(err(
                        c,
                        format!(
                            "column {icol} outside 1..={} (and not the end record {})",
                            c.m.cols,
                            c.m.cols + 1
                        ),
                    ));
                }
                c.col = Some(icol as usize - 1);
                if irow > 0 {
                    if irow > rows {
                        return Err(err(
                            c,
                            format!("column {icol}: row {irow} outside 1..={rows}"),
                        ));
                    }
                    c.row = Some(irow as usize - 1);
                    c.dense = Some((line, nw, 0));
                } else if irow == 0 {
                    c.row = None;
                } else {
                    return Err(err(c, format!("column {icol}: IROW = {irow} is negative")));
                }
            }
            [is] if !c.m.bigmat && c.dense.is_none() => {
                let (first, _) = split_string_header(is);
                if first < 1 || first > rows {
                    return Err(err(
                        c,
                        format!("string header {is}: row {first} outside 1..={rows}"),
                    ));
                }
                c.row = Some(first as usize - 1);
            }
            [_, first] if c.m.bigmat && c.dense.is_none() => {
                if first < 1 || first > rows {
                    return Err(err(
                        c,
                        format!("BIGMAT string header: row {first} outside 1..={rows}"),
                    ));
                }
                c.row = Some(first as usize - 1);
            }
            _ => {
                return Err(err(
                    c,
                    format!(
                "unexpected line of {} integer(s) '{}': expected a column record `ICOL IROW NW`{}",
                count,
                show(bytes),
                if c.m.bigmat {
                    " or a BIGMAT string header `L+1 IROW`"
                } else {
                    " or a string header IS"
                }
            ),
                ))
            }
        }
        return Ok(());
    }
    let Some(col) = c.col else {
        // The end record's dummy value.
        return Ok(());
    };
    let Some(mut row) = c.row else {
        return Err(err(
            c,
            format!(
                "values '{}' before a column record or string header",
                show(bytes)
            ),
        ));
    };
    let bytes = bytes.strip_suffix(b"\r").unwrap_or(bytes);
    let mut got = 0;
    for chunk in bytes.chunks(c.width) {
        let s = chunk.trim_ascii();
        if s.is_empty() {
            continue;
        }
        // `E` exponents parse as they are; a Fortran `D` exponent is rewritten first
        let v = fast_float2::parse::<f64, _>(s).or_else(|_| {
            let e: Vec<u8> = s
                .iter()
                .map(|&b| if b == b'D' || b == b'd' { b'E' } else { b })
                .collect();
            fast_float2::parse::<f64, _>(&e)
        });
        let v: f64 = v.map_err(|_| {
            err(
                c,
                format!(
                    "'{}' is not a number (values are {} characters wide per the header's format)",
                    show(s),
                    c.width
                ),
            )
        })?;
        if row >= c.m.rows {
            return Err(err(
                c,
                format!("column {}: more values than the {} rows", col + 1, c.m.rows),
            ));
        }
        // Single precision as the binary files hold it.
        let v = if c.wpv == 1 { f64::from(v as f32) } else { v };
        put(&mut c.m.entries, c.kept, row, col, v).map_err(|m| err(c, m))?;
        row += 1;
        got += 1;
    }
    if got > c.per_line {
        return Err(err(
            c,
            format!(
                "{got} values on one line; the header's format has {} a line",
                c.per_line
            ),
        ));
    }
    c.row = Some(row);
    if let Some(d) = &mut c.dense {
        d.2 += got;
    }
    Ok(())
}

fn read_ascii(path: &Path, keep: &dyn Fn(&str) -> bool) -> Result<Vec<Op4Matrix>> {
    let mut out = Vec::new();
    let mut current: Option<Box<Current>> = None;
    for_each_line(path, |line, bytes| {
        if bytes.iter().all(u8::is_ascii_whitespace) {
            return Ok(());
        }
        match &mut current {
            Some(c) if c.col.is_some() || ascii_header(bytes).is_none() => {
                ascii_line(path, line, bytes, c)
            }
            _ => {
                let next = ascii_start(path, line, bytes, keep)?;
                if let Some(done) = current.replace(next) {
                    out.push(done.m);
                }
                Ok(())
            }
        }
    })?;
    if let Some(c) = current {
        if c.col.is_some() {
            return Err(Error::parse(
                path,
                0,
                format!(
                    "the file ends inside matrix {} (header at {}) before its end record (column {}): truncated file?",
                    c.m.name,
                    c.m.at,
                    c.m.cols + 1
                ),
            ));
        }
        out.push(c.m);
    }
    if out.is_empty() {
        return Err(Error::parse(path, 1, "no matrix in the file"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_headers() {
        let h = b"       3      -3       6       2KAA     1P,3E23.16";
        let (n, name, f) = ascii_header(h).unwrap();
        assert_eq!(n, [3, -3, 6, 2]);
        assert_eq!(name, "KAA");
        assert_eq!(f, (3, 23));
        assert_eq!(
            ascii_header(b"       3       3       6       1MAA     1P,5E16.9\r")
                .unwrap()
                .2,
            (5, 16)
        );
        assert!(ascii_header(b"1 2 3 4 KAA").is_none());
        assert!(ascii_header(b"       3       3       6       2KAA     nonsense").is_none());
        assert!(looks_like_op4(h));
        assert!(!looks_like_op4(b"1 2 3.0\n"));
    }

    /// pyNastran 1.4.1's ASCII output for a 3x3 tridiagonal symmetric matrix, sparse and
    /// dense (its dense NW counts values, not words).
    #[test]
    fn pynastran_ascii_sparse_and_dense() {
        let sparse = "       3       3       6       2KAA     1P,3E23.16
       1       0       5
  327681
 2.0000000000000000E+00-1.0000000000000000E+00
       2       0       7
  458753
-1.0000000000000000E+00 2.0000000000000000E+00-1.0000000000000000E+00
       3       0       5
  327682
-1.0000000000000000E+00 2.0000000000000000E+00
       4       1       1
 1.0000000000000000E+00
";
        let dense = "       3       3       6       2MAA     1P,3E23.16
       1       1       2
 2.0000000000000000E+00-1.0000000000000000E+00
       2       1       3
-1.0000000000000000E+00 2.0000000000000000E+00-1.0000000000000000E+00
       3       2       2
-1.0000000000000000E+00 2.0000000000000000E+00
       4       1       1
 1.0000000000000000E+00
";
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.op4");
        std::fs::write(&p, format!("{sparse}{dense}")).unwrap();
        let ms = read_op4(&p).unwrap();
        assert_eq!(ms.len(), 2);
        for m in ms {
            assert_eq!((m.rows, m.cols, m.form, m.precision), (3, 3, 6, 2));
            let a = m.entries.into_csc(3, false);
            assert_eq!(a.val().len(), 7);
            assert_eq!(a.val()[0], 2.0);
        }
    }
}
