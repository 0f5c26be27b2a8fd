//! Harwell–Boeing sparse matrices, as ANSYS writes them (`HBMAT`, APDL Math
//! `*EXPORT,…,HBMAT`): [`read`] gives the full-storage CSC matrix.
//!
//! # The format
//! From I. S. Duff, R. G. Grimes, J. G. Lewis, "Users' Guide for the Harwell-Boeing Sparse
//! Matrix Collection (Release I)", 1992 (scipy's `scipy.io.hb_read` is a public reader of the
//! same layout). A text file of fixed-width Fortran records:
//!
//! | line | Fortran | contents |
//! |---|---|---|
//! | 1 | `(A72, A8)` | title, key |
//! | 2 | `(5I14)` | TOTCRD, PTRCRD, INDCRD, VALCRD, RHSCRD: lines in total and per section (RHSCRD may be omitted) |
//! | 3 | `(A3, 11X, 4I14)` | MXTYPE, NROW, NCOL, NNZERO, NELTVL (0 or omitted for assembled matrices) |
//! | 4 | `(2A16, 2A20)` | the Fortran formats of the pointers, row indices, values, right-hand sides |
//! | 5 | `(A3, 11X, 2I14)` | right-hand-side type and counts, only when RHSCRD > 0 |
//!
//! then PTRCRD lines of the NCOL + 1 column pointers (1-based; pointer j is the position of
//! column j's first entry, the last is NNZERO + 1), INDCRD lines of the NNZERO 1-based row
//! indices, column by column, and VALCRD lines of the NNZERO values in the same order. Each
//! line holds the repeat count of its format's fields (the last line of a section fewer), field
//! k in columns `k·w + 1 ..= (k+1)·w`: numbers that fill their width run together
//! (`1.0E+00-2.5E-01`), so a line is cut by position unless it holds exactly the expected
//! number of blank-separated numbers (then those are read: the same values for a file true to
//! its formats, and writers whose fields are narrower than their format says, like scipy's
//! `hb_write` printing 24 characters under `(3E25.16)`, still read).
//!
//! MXTYPE is three letters: value type `R` real (`C` complex, `P` pattern only), structure `S`
//! symmetric, `U` unsymmetric, `R` rectangular (`H` Hermitian, `Z` skew symmetric), storage `A`
//! assembled (`E` elemental). Read here: `RSA` (one triangle stored, mirrored to full
//! storage), `RUA` and `RRA`; the others, and right-hand sides (RHSCRD > 0), are refused with
//! the reason.
//!
//! Formats read: `(nIw)` for pointers and indices; `(nEw.d)`, `(nDw.d)`, `(nFw.d)`,
//! `(nGw.d)`, `(nESw.d)`, optionally `Ee` after `d` and a scale factor `kP` in front (`(1P,4E20.12)`,
//! `(1P4E20.12)`) for values. As on Fortran input, a value may carry its exponent as `E`, `D`
//! or a bare sign (`1.5-120`), and the scale factor only applies to a value without exponent
//! (it is then divided by 10^k).
//!
//! The file is streamed line by line (never held whole); the header's counts are checked
//! against the file's size before anything is allocated, so a header declaring 10¹² entries in
//! a small file is an error, not an allocation. Errors name the file and the line.

use crate::io::file::check_regular;
use crate::io::text::{for_each_line, show};
use crate::sparse::{from_parts, Csc, Triplets};
use crate::{Error, Result};
use std::path::Path;

/// What the header of a Harwell–Boeing file says.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Header {
    /// The title (columns 1–72 of line 1), trimmed.
    pub title: String,
    /// The key (columns 73–80 of line 1), trimmed.
    pub key: String,
    /// MXTYPE, e.g. `RSA`.
    pub mxtype: String,
    /// Rows.
    pub nrow: usize,
    /// Columns.
    pub ncol: usize,
    /// Stored entries (one triangle of a symmetric matrix).
    pub nnz: usize,
}

/// True when the first bytes of a file have the Harwell–Boeing header layout: a line 2 of 4
/// or 5 whole numbers and a line 3 starting with a 3-letter type followed by 3 or 4 whole
/// numbers (`RSA  …  6  6  12  0`).
pub(crate) fn looks_like(head: &[u8]) -> bool {
    let text = String::from_utf8_lossy(head);
    let mut lines = text.lines();
    let (Some(_), Some(l2), Some(l3)) = (lines.next(), lines.next(), lines.next()) else {
        return false;
    };
    let whole = |s: &str, counts: std::ops::RangeInclusive<usize>| {
        let t: Vec<&str> = s.split_whitespace().collect();
        counts.contains(&t.len()) && t.iter().all(|t| t.parse::<u64>().is_ok())
    };
    let b3 = l3.as_bytes();
    whole(l2, 4..=5)
        && b3.len() > 3
        && b3[..3].iter().all(u8::is_ascii_alphabetic)
        && b3[3].is_ascii_whitespace()
        && whole(&l3[3..], 3..=4)
}

/// Reads a Harwell–Boeing matrix (see the [module documentation](self)) in full storage: a
/// symmetric (`RSA`) file's stored triangle is mirrored.
///
/// # Errors
/// [`Error::Io`]; [`Error::Parse`] naming the file and the line: an unsupported type, a
/// Fortran format that is not one of those read, counts that disagree, a truncated file,
/// pointers that do not start at 1, decrease or do not end at NNZERO + 1, a row index outside
/// 1..=NROW or given twice in a column, a symmetric file storing entries in both triangles, a
/// field that is not a number.
pub fn read(path: &Path) -> Result<Csc> {
    read_with_header(path).map(|(_, a)| a)
}

/// [`read`], also returning the [`Header`].
///
/// # Errors
/// As [`read`].
pub fn read_with_header(path: &Path) -> Result<(Header, Csc)> {
    check_regular(path)?;
    let size = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    let mut r = Reader::new(path, size);
    for_each_line(path, |no, line| r.line(no, line))?;
    r.finish()
}

/// One Fortran edit descriptor repeated: `count` fields of `width` characters.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Fortran {
    count: usize,
    width: usize,
    integer: bool,
    /// The scale factor `kP` (values only).
    scale: i32,
}

/// Parses a format like `(16I5)`, `(4E20.12)`, `(1P,3D25.16)`; `Err` says why not.
fn parse_format(s: &str) -> std::result::Result<Fortran, String> {
    let t: String = s
        .chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_uppercase();
    let inner = t
        .strip_prefix('(')
        .and_then(|t| t.strip_suffix(')'))
        .ok_or("a format is enclosed in parentheses")?;
    let b = inner.as_bytes();
    let mut i = 0;
    let digits = |i: &mut usize| -> Option<usize> {
        let start = *i;
        while *i < b.len() && b[*i].is_ascii_digit() {
            *i += 1;
        }
        if *i == start || *i - start > 9 {
            return None;
        }
        inner[start..*i].parse().ok()
    };
    // Optional scale factor kP (k may be signed), optionally followed by a comma.
    let mut scale = 0i32;
    if let Some(p) = inner.find('P') {
        let k = &inner[..p];
        scale = k
            .parse()
            .ok()
            .filter(|k: &i32| k.abs() <= 99)
            .ok_or("the scale factor before P is not a small whole number")?;
        i = p + 1;
        if b.get(i) == Some(&b',') {
            i += 1;
        }
    }
    let count = if b.get(i).is_some_and(u8::is_ascii_digit) {
        digits(&mut i).ok_or("bad repeat count")?
    } else {
        1
    };
    let kind_start = i;
    while i < b.len() && b[i].is_ascii_alphabetic() {
        i += 1;
    }
    let kind = &inner[kind_start..i];
    let integer = match kind {
        "I" => true,
        "E" | "D" | "F" | "G" | "ES" | "EN" => false,
        "" => return Err("no edit descriptor (I, E, D, F, G)".into()),
        k => {
            return Err(format!(
                "edit descriptor '{k}' is not one of I, E, D, F, G, ES, EN"
            ))
        }
    };
    let width = digits(&mut i).ok_or("no field width after the edit descriptor")?;
    if b.get(i) == Some(&b'.') {
        i += 1;
        digits(&mut i).ok_or("no digit count after '.'")?;
        if b.get(i) == Some(&b'E') {
            i += 1;
            digits(&mut i).ok_or("no exponent width after 'E'")?;
        }
    } else if !integer {
        return Err(format!(
            "'{kind}{width}' needs a digit count, e.g. {kind}{width}.8"
        ));
    }
    if i != b.len() {
        return Err(format!(
            "unexpected '{}' (only one repeated edit descriptor is read, e.g. (4E20.12))",
            &inner[i..]
        ));
    }
    if count == 0 || width == 0 || width > 1000 {
        return Err("repeat count and width must be between 1 and 1000".into());
    }
    if integer && scale != 0 {
        return Err("a scale factor P with an integer format".into());
    }
    Ok(Fortran {
        count,
        width,
        integer,
        scale,
    })
}

/// A field read but not yet checked.
#[derive(Clone, Copy, Debug)]
enum Item {
    Int(usize),
    Real(f64),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Title,
    Counts,
    Type,
    Formats,
    Pointers,
    Indices,
    Values,
    Done,
}

struct Reader<'a> {
    path: &'a Path,
    size: u64,
    stage: Stage,
    header: Header,
    /// TOTCRD, PTRCRD, INDCRD, VALCRD, RHSCRD.
    crd: [u64; 5],
    symmetric: bool,
    /// Pointer, index, value formats.
    formats: Option<[Fortran; 3]>,
    /// 0-based column pointers.
    ptr: Vec<usize>,
    rows: Vec<usize>,
    vals: Vec<f64>,
    /// Items still to read in the current section.
    left: usize,
    /// Column of the next row index.
    col: usize,
    /// Symmetric files: the stored triangle, 1 lower, -1 upper, 0 not yet seen.
    triangle: i8,
    sorted: bool,
    first_index_line: usize,
    last_line: usize,
    field: Vec<u8>,
    items: Vec<Item>,
}

impl<'a> Reader<'a> {
    /// A reader at the title line of `path` (`size` bytes).
    fn new(path: &'a Path, size: u64) -> Self {
        Reader {
            path,
            size,
            stage: Stage::Title,
            header: Header {
                title: String::new(),
                key: String::new(),
                mxtype: String::new(),
                nrow: 0,
                ncol: 0,
                nnz: 0,
            },
            crd: [0; 5],
            symmetric: false,
            formats: None,
            ptr: Vec::new(),
            rows: Vec::new(),
            vals: Vec::new(),
            left: 0,
            col: 0,
            triangle: 0,
            sorted: true,
            first_index_line: 0,
            last_line: 0,
            field: Vec::new(),
            items: Vec::new(),
        }
    }
    fn err(&self, line: usize, msg: impl Into<String>) -> Error {
        Error::parse(self.path, line, msg)
    }

    /// Whole numbers of a header line (blank-separated).
    fn header_numbers(
        &self,
        no: usize,
        text: &[u8],
        counts: std::ops::RangeInclusive<usize>,
        what: &str,
    ) -> Result<Vec<u64>> {
        let t: Vec<&[u8]> = text
            .split(u8::is_ascii_whitespace)
            .filter(|t| !t.is_empty())
            .collect();
        if !counts.contains(&t.len()) {
            return Err(self.err(
                no,
                format!(
                    "expected {} to {} whole numbers ({what}), found {} field(s)",
                    counts.start(),
                    counts.end(),
                    t.len()
                ),
            ));
        }
        t.iter()
            .map(|t| {
                std::str::from_utf8(t)
                    .ok()
                    .and_then(|s| s.parse::<u64>().ok())
                    .ok_or_else(|| {
                        self.err(no, format!("'{}' is not a whole number ({what})", show(t)))
                    })
            })
            .collect()
    }

    fn line(&mut self, no: usize, line: &[u8]) -> Result<()> {
        self.last_line = no;
        match self.stage {
            Stage::Title => {
                let text = String::from_utf8_lossy(line);
                let split = text.char_indices().nth(72).map_or(text.len(), |(i, _)| i);
                self.header.title = text[..split].trim().to_string();
                self.header.key = text[split..].trim().to_string();
                self.stage = Stage::Counts;
            }
            Stage::Counts => {
                let v = self.header_numbers(
                    no,
                    line,
                    4..=5,
                    "TOTCRD PTRCRD INDCRD VALCRD [RHSCRD]: lines per section",
                )?;
                self.crd[..v.len()].copy_from_slice(&v);
                let [tot, ptr, ind, val, rhs] = self.crd;
                if rhs > 0 {
                    return Err(self.err(
                        no,
                        format!(
                            "RHSCRD = {rhs}: the file carries right-hand sides, which are not \
                             read; write the matrix alone (RHSCRD 0)"
                        ),
                    ));
                }
                if ptr.checked_add(ind).and_then(|s| s.checked_add(val)) != Some(tot) {
                    return Err(self.err(
                        no,
                        format!(
                            "TOTCRD = {tot} but PTRCRD + INDCRD + VALCRD = {ptr} + {ind} + {val}"
                        ),
                    ));
                }
                self.stage = Stage::Type;
            }
            Stage::Type => {
                if line.len() < 3 || !line[..3].iter().all(u8::is_ascii_alphabetic) {
                    return Err(self.err(
                        no,
                        format!(
                            "expected the 3-letter matrix type (RSA, RUA) at the start, found '{}'",
                            show(line)
                        ),
                    ));
                }
                let ty = String::from_utf8_lossy(&line[..3]).to_ascii_uppercase();
                let tb = ty.as_bytes();
                let refuse = |why: &str| {
                    Err(self.err(
                        no,
                        format!(
                            "matrix type {ty}: {why}; only real assembled matrices (RSA, RUA, \
                             RRA) are read"
                        ),
                    ))
                };
                match tb[0] {
                    b'R' => {}
                    b'C' => return refuse("complex values"),
                    b'P' => return refuse("a pattern without values"),
                    _ => return refuse("unknown value type (first letter R, C or P)"),
                }
                match tb[2] {
                    b'A' => {}
                    b'E' => return refuse("elemental (unassembled) storage"),
                    _ => return refuse("unknown storage (third letter A or E)"),
                }
                self.symmetric = match tb[1] {
                    b'S' => true,
                    b'U' | b'R' => false,
                    b'Z' => return refuse("skew symmetric"),
                    b'H' => return refuse("Hermitian"),
                    _ => return refuse("unknown structure (second letter S, U, R, H or Z)"),
                };
                let v = self.header_numbers(no, &line[3..], 3..=4, "NROW NCOL NNZERO [NELTVL]")?;
                if v.len() == 4 && v[3] != 0 {
                    return Err(self.err(
                        no,
                        format!("NELTVL = {} for an assembled matrix: expected 0", v[3]),
                    ));
                }
                let fit = |x: u64| usize::try_from(x).map_err(|_| self.err(no, "count too large"));
                let (nr, nc, nz) = (fit(v[0])?, fit(v[1])?, fit(v[2])?);
                self.header.mxtype = ty.clone();
                (self.header.nrow, self.header.ncol, self.header.nnz) = (nr, nc, nz);
                let (nrow, ncol, nnz) = (v[0], v[1], v[2]);
                if self.symmetric && nrow != ncol {
                    return Err(self.err(
                        no,
                        format!("a symmetric matrix ({ty}) of {nrow} rows and {ncol} columns"),
                    ));
                }
                if u128::from(nnz) > u128::from(nrow) * u128::from(ncol) {
                    return Err(self.err(
                        no,
                        format!("NNZERO = {nnz} entries do not fit in {nrow}×{ncol}"),
                    ));
                }
                // Every pointer, index and value takes at least one character.
                let least = u128::from(ncol) + 1 + 2 * u128::from(nnz);
                if least > u128::from(self.size) {
                    return Err(self.err(
                        no,
                        format!(
                            "the header declares {ncol} columns and {nnz} entries, which need at \
                             least {least} characters, but the file has {} bytes (truncated, or a \
                             wrong header)",
                            self.size
                        ),
                    ));
                }
                self.stage = Stage::Formats;
            }
            Stage::Formats => {
                let text = String::from_utf8_lossy(line);
                let mut groups = Vec::new();
                let mut rest = text.as_ref();
                while let Some(open) = rest.find('(') {
                    let Some(close) = rest[open..].find(')') else {
                        break;
                    };
                    groups.push(&rest[open..=open + close]);
                    rest = &rest[open + close + 1..];
                }
                if groups.len() < 3 {
                    return Err(self.err(
                        no,
                        format!(
                            "expected the Fortran formats of pointers, row indices and values, \
                             e.g. (10I8) (10I8) (4E20.12), found {} in '{}'",
                            groups.len(),
                            show(line)
                        ),
                    ));
                }
                let mut f = [Fortran {
                    count: 1,
                    width: 1,
                    integer: true,
                    scale: 0,
                }; 3];
                for (k, what) in ["pointer", "row index", "value"].into_iter().enumerate() {
                    f[k] = parse_format(groups[k]).map_err(|why| {
                        self.err(no, format!("{what} format {}: {why}", groups[k]))
                    })?;
                }
                if !f[0].integer || !f[1].integer {
                    return Err(self.err(
                        no,
                        format!(
                            "pointers and row indices need an integer format (nIw), found {} {}",
                            groups[0], groups[1]
                        ),
                    ));
                }
                if f[2].integer {
                    return Err(self.err(
                        no,
                        format!(
                            "values need a real format (nEw.d, nDw.d, …), found {}",
                            groups[2]
                        ),
                    ));
                }
                let (ncol, nnz) = (self.header.ncol as u64, self.header.nnz as u64);
                for (k, items, what) in [
                    (0, ncol + 1, "PTRCRD"),
                    (1, nnz, "INDCRD"),
                    (2, nnz, "VALCRD"),
                ] {
                    let per = f[k].count as u64;
                    let need = items.div_ceil(per);
                    if self.crd[k + 1] != need {
                        return Err(self.err(
                            no,
                            format!(
                                "{what} = {} lines on line 2, but {items} items at {per} per line \
                                 ({}) take {need}",
                                self.crd[k + 1],
                                groups[k]
                            ),
                        ));
                    }
                }
                self.formats = Some(f);
                // Bounded by the file size (checked on line 3).
                self.ptr = Vec::with_capacity(self.header.ncol + 1);
                self.left = self.header.ncol + 1;
                self.stage = Stage::Pointers;
            }
            Stage::Pointers => self.section(no, line, 0)?,
            Stage::Indices => self.section(no, line, 1)?,
            Stage::Values => self.section(no, line, 2)?,
            Stage::Done => {
                if !line.iter().all(u8::is_ascii_whitespace) {
                    return Err(self.err(
                        no,
                        format!(
                            "text after the last value '{}': the header's counts (line 2, 3) \
                             cover fewer lines",
                            show(line)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// One line of section `k` (0 pointers, 1 row indices, 2 values).
    /// One field of section `k` (0 pointers, 1 row indices, 2 values), not yet checked.
    fn number(&mut self, no: usize, tok: &[u8], k: usize, scale: i32) -> Result<Item> {
        match k {
            0 => self.whole(no, tok, "column pointer").map(Item::Int),
            1 => self.whole(no, tok, "row index").map(Item::Int),
            _ => self.real(no, tok, scale).map(Item::Real),
        }
    }

    /// One line of section `k` (0 pointers, 1 row indices, 2 values).
    fn section(&mut self, no: usize, line: &[u8], k: usize) -> Result<()> {
        let Some(formats) = self.formats else {
            return Err(self.err(no, "no formats line"));
        };
        let f = formats[k];
        let take = f.count.min(self.left);
        let mut items = std::mem::take(&mut self.items);
        items.clear();
        // Blank-separated numbers, as many as the line should hold: read them as they are
        // (this also reads writers whose fields are narrower or wider than their format says,
        // e.g. scipy's `hb_write`, which prints 24 characters under (3E25.16)).
        let mut separated = true;
        for tok in line
            .split(u8::is_ascii_whitespace)
            .filter(|t| !t.is_empty())
        {
            if items.len() == take {
                separated = false;
                break;
            }
            match self.number(no, tok, k, f.scale) {
                Ok(x) => items.push(x),
                Err(_) => {
                    separated = false;
                    break;
                }
            }
        }
        if !separated || items.len() != take {
            // Otherwise the fields by position, as Fortran reads them (numbers that fill
            // their width run together).
            items.clear();
            for i in 0..take {
                let start = i * f.width;
                if start >= line.len() {
                    return Err(self.err(
                        no,
                        format!(
                            "the line ends after {i} field(s) of {} characters; expected {take} \
                             (truncated, or the counts of the header are wrong)",
                            f.width
                        ),
                    ));
                }
                let tok = line[start..line.len().min(start + f.width)].trim_ascii();
                if tok.is_empty() {
                    return Err(self.err(
                        no,
                        format!(
                            "field {} (columns {}–{}) is blank",
                            i + 1,
                            start + 1,
                            start + f.width
                        ),
                    ));
                }
                let x = self.number(no, tok, k, f.scale)?;
                items.push(x);
            }
            let used = take * f.width;
            if line.len() > used && !line[used..].iter().all(u8::is_ascii_whitespace) {
                return Err(self.err(
                    no,
                    format!(
                        "unexpected '{}' after {take} field(s) of {} characters (the header's \
                         counts or formats do not match the data)",
                        show(line[used..].trim_ascii()),
                        f.width
                    ),
                ));
            }
        }
        for &x in &items {
            match x {
                Item::Int(p) if k == 0 => self.pointer(no, p)?,
                Item::Int(r) => self.index(no, r)?,
                Item::Real(v) => self.vals.push(v),
            }
        }
        self.items = items;
        self.left -= take;
        if self.left == 0 {
            self.next_section(no)?;
        }
        Ok(())
    }

    fn next_section(&mut self, no: usize) -> Result<()> {
        match self.stage {
            Stage::Pointers => {
                let (nnz, last) = (self.header.nnz, self.ptr.last().copied().unwrap_or(0));
                if last != nnz {
                    return Err(self.err(
                        no,
                        format!(
                            "the last column pointer is {} but NNZERO + 1 = {}",
                            last + 1,
                            nnz + 1
                        ),
                    ));
                }
                self.rows = Vec::with_capacity(nnz);
                self.left = nnz;
                self.col = 0;
                self.first_index_line = no + 1;
                self.stage = Stage::Indices;
            }
            Stage::Indices => {
                self.vals = Vec::with_capacity(self.header.nnz);
                self.left = self.header.nnz;
                self.stage = Stage::Values;
            }
            _ => self.stage = Stage::Done,
        }
        if self.left == 0 && self.stage != Stage::Done {
            // An empty section (NNZERO = 0) has no lines.
            self.next_section(no)?;
        }
        Ok(())
    }

    fn whole(&self, no: usize, tok: &[u8], what: &str) -> Result<usize> {
        let digits = tok.strip_prefix(b"+").unwrap_or(tok);
        if digits.is_empty() || digits.len() > 18 || !digits.iter().all(u8::is_ascii_digit) {
            return Err(self.err(no, format!("{what} '{}' is not a whole number", show(tok))));
        }
        let v = digits
            .iter()
            .fold(0u64, |v, &b| 10 * v + u64::from(b - b'0'));
        usize::try_from(v).map_err(|_| self.err(no, format!("{what} {v} is too large")))
    }

    fn pointer(&mut self, no: usize, p: usize) -> Result<()> {
        let j = self.ptr.len();
        let prev = self.ptr.last().map_or(1, |&q| q + 1);
        if j == 0 && p != 1 {
            return Err(self.err(no, format!("the first column pointer is {p}: expected 1")));
        }
        if p < prev {
            return Err(self.err(
                no,
                format!("column pointer {} is {p}, less than the one before ({prev}): pointers never decrease", j + 1),
            ));
        }
        if p > self.header.nnz + 1 {
            return Err(self.err(
                no,
                format!(
                    "column pointer {} is {p}, past NNZERO + 1 = {}",
                    j + 1,
                    self.header.nnz + 1
                ),
            ));
        }
        self.ptr.push(p - 1);
        Ok(())
    }

    fn index(&mut self, no: usize, r: usize) -> Result<()> {
        if r == 0 || r > self.header.nrow {
            return Err(self.err(
                no,
                format!("row index {r} is outside 1..={}", self.header.nrow),
            ));
        }
        let (r, k) = (r - 1, self.rows.len());
        while self.ptr.get(self.col + 1).is_some_and(|&p| p <= k) {
            self.col += 1;
        }
        let c = self.col;
        if self.symmetric && r != c {
            let side = if r > c { 1 } else { -1 };
            if self.triangle == 0 {
                self.triangle = side;
            } else if self.triangle != side {
                return Err(self.err(
                    no,
                    format!(
                        "row {} of column {}: a symmetric ({}) file stores one triangle, but this \
                         entry is in the other one",
                        r + 1,
                        c + 1,
                        self.header.mxtype
                    ),
                ));
            }
        }
        if k > self.ptr[c] {
            let prev = self.rows[k - 1];
            if prev == r {
                return Err(self.err(
                    no,
                    format!("row {} appears twice in column {}", r + 1, c + 1),
                ));
            }
            self.sorted &= prev < r;
        }
        self.rows.push(r);
        Ok(())
    }

    fn real(&mut self, no: usize, tok: &[u8], scale: i32) -> Result<f64> {
        // Fortran input: D for E, or a bare sign before the exponent (1.5-120).
        let f = &mut self.field;
        f.clear();
        let mut exponent = false;
        for (i, &b) in tok.iter().enumerate() {
            match b {
                b'D' | b'd' | b'E' | b'e' | b'Q' | b'q' => {
                    exponent = true;
                    f.push(b'E');
                }
                b'+' | b'-' if i > 0 && !exponent => {
                    exponent = true;
                    f.push(b'E');
                    f.push(b);
                }
                _ => f.push(b),
            }
        }
        let v = match fast_float2::parse::<f64, _>(&f[..]) {
            Ok(v) if v.is_finite() => v,
            _ => return Err(self.err(no, format!("value '{}' is not a finite number", show(tok)))),
        };
        Ok(if exponent || scale == 0 {
            v
        } else {
            v / 10f64.powi(scale)
        })
    }

    fn finish(mut self) -> Result<(Header, Csc)> {
        if self.stage != Stage::Done {
            let what = match self.stage {
                Stage::Title | Stage::Counts | Stage::Type | Stage::Formats => {
                    "the header (4 lines)".to_string()
                }
                Stage::Pointers => format!("the column pointers ({} missing)", self.left),
                Stage::Indices => format!("the row indices ({} missing)", self.left),
                _ => format!("the values ({} missing)", self.left),
            };
            return Err(self.err(
                self.last_line + 1,
                format!("the file ends inside {what}: truncated"),
            ));
        }
        let (nrow, ncol) = (self.header.nrow, self.header.ncol);
        let (ptr, mut rows, mut vals) = (
            std::mem::take(&mut self.ptr),
            std::mem::take(&mut self.rows),
            std::mem::take(&mut self.vals),
        );
        if !self.sorted {
            let mut pairs: Vec<(usize, f64)> = Vec::new();
            for j in 0..ncol {
                let (a, b) = (ptr[j], ptr[j + 1]);
                pairs.clear();
                pairs.extend(rows[a..b].iter().copied().zip(vals[a..b].iter().copied()));
                pairs.sort_by_key(|p| p.0);
                if let Some(w) = pairs.windows(2).find(|w| w[0].0 == w[1].0) {
                    return Err(self.err(
                        self.first_index_line,
                        format!(
                            "row {} appears twice in column {} (row indices from this line on)",
                            w[0].0 + 1,
                            j + 1
                        ),
                    ));
                }
                for (t, (r, v)) in pairs.iter().enumerate() {
                    rows[a + t] = *r;
                    vals[a + t] = *v;
                }
            }
        }
        if self.symmetric {
            // one stored triangle: the importers' one mirroring assembly (rows are distinct
            // within a column, so nothing is summed)
            let mut t = Triplets::default();
            for j in 0..ncol {
                for q in ptr[j]..ptr[j + 1] {
                    t.push(rows[q], j, vals[q]);
                }
            }
            return Ok((self.header, t.into_csc(ncol, true)));
        }
        Ok((self.header, from_parts(nrow, ncol, ptr, rows, vals)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fortran_formats() {
        let f = |s: &str| parse_format(s).map(|f| (f.count, f.width, f.integer, f.scale));
        assert_eq!(f("(16I5)"), Ok((16, 5, true, 0)));
        assert_eq!(f("(10I8)"), Ok((10, 8, true, 0)));
        assert_eq!(f("(4E20.12)"), Ok((4, 20, false, 0)));
        assert_eq!(f("(3D25.16)"), Ok((3, 25, false, 0)));
        assert_eq!(f("(1P,4E20.12)"), Ok((4, 20, false, 1)));
        assert_eq!(f("(1P4E20.12)"), Ok((4, 20, false, 1)));
        assert_eq!(f("( 5 e 16 . 8 )"), Ok((5, 16, false, 0)));
        assert_eq!(f("(I8)"), Ok((1, 8, true, 0)));
        assert_eq!(f("(4ES20.12E3)"), Ok((4, 20, false, 0)));
        for bad in [
            "16I5",
            "(16X5)",
            "(4E20)",
            "(0I5)",
            "(4(E20.12))",
            "(2I5,3I4)",
            "(1PI5)",
            "()",
            "(4E20.12,)",
        ] {
            assert!(parse_format(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn fortran_reals() {
        let mut r = Reader::new(Path::new("t"), 0);
        r.stage = Stage::Done;
        let mut v = |s: &str, k: i32| r.real(1, s.as_bytes(), k).ok();
        assert_eq!(v("1.5D+03", 0), Some(1500.0));
        assert_eq!(v("-2.5d-1", 0), Some(-0.25));
        assert_eq!(v("1.5-120", 0), Some(1.5e-120));
        assert_eq!(v("+1.5+003", 0), Some(1500.0));
        assert_eq!(v("0.1E+01", 1), Some(1.0));
        assert_eq!(v("12.5", 1), Some(1.25));
        assert_eq!(v("7", 0), Some(7.0));
        assert_eq!(v("1.0E+400", 0), None);
        assert_eq!(v("1.0 E+4", 0), None);
        assert_eq!(v("abc", 0), None);
    }

    #[test]
    fn sniffing() {
        assert!(looks_like(
            b"title\n 8 1 1 6\nRUA  5 5 16 0\n(26I3) (40I2) (3E25.16)\n"
        ));
        assert!(looks_like(b"t\n 1 1 1 1 0\nRSA  5 5 16\n"));
        assert!(!looks_like(b"1 0 0 0\n2 1 0 0\n3 2 0 0\n"));
        assert!(!looks_like(b"%%MatrixMarket\n"));
    }
}
