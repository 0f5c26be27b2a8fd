//! Matrix Market (`.mtx`) reading and writing (docs/design.md §4).
//!
//! # What is read
//!
//! The banner must be the first line:
//! `%%MatrixMarket matrix <format> <field> <symmetry>` with
//!
//! * format `coordinate` (sparse triplets `row column value`, one per line) or `array`
//!   (dense, one value per line, column-major);
//! * field `real`, `double` or `integer` (integers are read as `f64`);
//! * symmetry `general` or `symmetric`.
//!
//! Fields `complex` and `pattern` and symmetries `hermitian` and `skew-symmetric` are rejected
//! with an error that says what is supported. The banner keywords are case-insensitive.
//! Comment lines (starting with `%`) and blank lines may stand between the banner and the size
//! line; blank lines between entries are tolerated. Lines may end in `\n` or `\r\n`; tokens are
//! separated by spaces or tabs.
//!
//! A file whose first two bytes are the gzip magic `1f 8b` is decompressed transparently,
//! whatever its name (`.mtx.gz` or not).
//!
//! # Conventions
//!
//! * **Symmetric files are expanded to full storage.** A `symmetric` coordinate file stores one
//!   triangle; every off-diagonal entry is mirrored, so the returned matrix holds both
//!   triangles. The spec asks for the lower triangle; a file holding only the upper triangle is
//!   accepted too, but a file mixing strictly-lower and strictly-upper entries is an error
//!   naming the first line of the second triangle. A `symmetric` array file holds the lower
//!   triangle column by column (the spec's layout); it is expanded the same way.
//!   [`MtxMatrix::symmetry`] still tells what the file declared.
//! * **Duplicate coordinate entries are summed** (the finite-element assembly convention, as in
//!   scipy), in file order. A mirrored entry is summed the same way, so the expansion of a
//!   symmetric file is exactly symmetric.
//! * Sparse results are in canonical CSC form: rows sorted within each column, no duplicates.
//!   Explicitly stored zeros of a coordinate file are kept.
//! * [`read_sparse`] of an array file keeps only the nonzero values; [`read_dense`] of a
//!   coordinate file scatters the (summed, expanded) entries into a dense matrix.
//! * Every value must be finite: NaN and Inf (also as the overflow of a too-large literal such as
//!   `1e400`, or of the sum of duplicate entries) are errors.
//!
//! # Errors
//!
//! Malformed files give [`Error::Parse`] naming the file and the 1-based line: a missing or bad
//! banner, an unsupported format/field/symmetry, a bad size line, a non-square symmetric matrix,
//! a line with the wrong number of tokens, an unparsable number, an index out of range (the
//! message gives the allowed 1-based range), a NaN or Inf value, entries from both triangles in
//! a symmetric file, too many entries (at the first line too many) and too few entries
//! (expected and found count, at the file's last line). Corrupt or truncated gzip data is an
//! [`Error::Parse`] on line 0. No input makes the reader panic; sizes that cannot be allocated
//! give an error, too.
//!
//! # Writing
//!
//! [`write_coordinate`] and [`write_array`] write `real` files with 1-based indices and each
//! value in its shortest round-trip form (the `zmij` formatter, successor of `ryu`: `-0.0`,
//! `1e-300`, `3027152.8056777236`, `1.2345678901234568e+17`), so that a written matrix reads
//! back bit-exactly (including `-0.0`, subnormals and extreme exponents). The file is written
//! atomically ([`super::atomic::write_file`]: `<path>.tmp`, renamed to `<path>` only when it is
//! complete; on error the temporary file is removed and `<path>` is untouched). Non-finite
//! values are refused with [`Error::InvalidModel`] before anything is written.
//!
//! # Performance
//!
//! The whole file is read into memory (decompressed if gzip). The entry section of a coordinate
//! file (from 1 MiB on, with more than one thread in the current rayon pool) is split at line
//! boundaries and parsed in parallel; the common line shape takes a fast path (8 digits at a
//! time for indices, `fast-float2` for values), anything else a general path with the precise
//! errors. Entries are kept with 32-bit indices when the dimensions allow. The CSC matrix is
//! assembled by counting per column, a prefix sum and a scatter, then sorting rows within
//! columns (skipped when already sorted, as in files written column- or row-major; parallel over
//! column blocks) and summing duplicates. Time and memory are O(file size + nnz + ncols);
//! each buffer is freed as soon as the next stage is done with it, so the peak is about
//! max(file + 16 bytes per entry, 16 bytes per entry + 16 bytes per stored nonzero) for
//! 32-bit-indexable sizes (e.g. 480 MB for a 314 MB file of 9.8e6 entries).
//! Array files are parsed on one thread (dense matrices are small in this crate's use).

use std::io::{Read, Write};
use std::ops::Range;
use std::path::Path;

use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};
use faer::{Mat, MatRef};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::io::atomic;

/// The symmetry declared in a Matrix Market banner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// All entries are stored.
    General,
    /// One triangle is stored; the matrix equals its transpose.
    Symmetric,
}

/// The values of a Matrix Market file, always in full storage (symmetric files expanded).
#[derive(Debug, Clone)]
pub enum MtxData {
    /// From a `coordinate` file: canonical CSC (rows sorted, no duplicates).
    Sparse(SparseColMat<usize, f64>),
    /// From an `array` file.
    Dense(Mat<f64>),
}

/// A matrix read from a Matrix Market file.
#[derive(Debug, Clone)]
pub struct MtxMatrix {
    /// The symmetry the file declared. [`MtxMatrix::data`] holds both triangles either way.
    pub symmetry: Symmetry,
    /// The values, in full storage.
    pub data: MtxData,
}

impl MtxMatrix {
    /// Number of rows.
    pub fn nrows(&self) -> usize {
        match &self.data {
            MtxData::Sparse(a) => a.nrows(),
            MtxData::Dense(a) => a.nrows(),
        }
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        match &self.data {
            MtxData::Sparse(a) => a.ncols(),
            MtxData::Dense(a) => a.ncols(),
        }
    }
}

/// Reads a Matrix Market file (coordinate or array; gzip-compressed or not).
///
/// Symmetric files are expanded to full storage; see the [module documentation](self) for the
/// accepted formats and the conventions.
pub fn read(path: &Path) -> Result<MtxMatrix> {
    let bytes = super::read_regular(path)?;
    // Each buffer is dropped as soon as the next stage no longer needs it, so the peak memory
    // is max(file + entries, entries + matrix), not their sum.
    let parsed = if bytes.starts_with(&GZIP_MAGIC) {
        let plain = gunzip(&bytes, path)?;
        drop(bytes);
        parse_plain(&plain, path)?
    } else {
        let parsed = parse_plain(&bytes, path)?;
        drop(bytes);
        parsed
    };
    parsed.finish(path)
}

/// Reads a Matrix Market file as a sparse matrix in canonical CSC form.
///
/// Symmetric files are expanded to full storage (both triangles), rows are sorted within each
/// column and duplicate entries are summed. An array file is converted, keeping its nonzero
/// values.
pub fn read_sparse(path: &Path) -> Result<SparseColMat<usize, f64>> {
    let m = read(path)?;
    Ok(match m.data {
        MtxData::Sparse(a) => a,
        MtxData::Dense(a) => dense_to_sparse(a.as_ref()),
    })
}

/// Reads a Matrix Market file as a dense matrix.
///
/// Symmetric files are expanded to full storage. A coordinate file is converted (duplicates
/// summed, missing entries zero); its declared size must fit in memory densely.
pub fn read_dense(path: &Path) -> Result<Mat<f64>> {
    let m = read(path)?;
    match m.data {
        MtxData::Dense(a) => Ok(a),
        MtxData::Sparse(a) => sparse_to_dense(a.as_ref(), path),
    }
}

/// Parses Matrix Market data already in memory (gzip-compressed or not).
///
/// `path` is used only to name the source in errors. Same rules as [`read`].
pub fn parse_bytes(bytes: &[u8], path: &Path) -> Result<MtxMatrix> {
    let parsed = if bytes.starts_with(&GZIP_MAGIC) {
        let plain = gunzip(bytes, path)?;
        parse_plain(&plain, path)?
    } else {
        parse_plain(bytes, path)?
    };
    parsed.finish(path)
}

const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// Writes `a` as a `coordinate real` Matrix Market file.
///
/// With `symmetric == false` every stored entry is written (`general`). With
/// `symmetric == true` the header says `symmetric` and only the stored entries of the lower
/// triangle (row >= column) are written; the caller guarantees that `a` is symmetric (only
/// squareness is checked). Entries are written column by column in storage order, with 1-based
/// indices and shortest round-trip values, so [`read_sparse`] returns the same matrix
/// bit-exactly (for a canonical `a`). The file is written to `<path>.tmp` and then renamed.
pub fn write_coordinate(
    path: &Path,
    a: SparseColMatRef<'_, usize, f64>,
    symmetric: bool,
) -> Result<()> {
    let (m, n) = (a.nrows(), a.ncols());
    if symmetric && m != n {
        return Err(Error::InvalidModel(format!(
            "cannot write {} as a symmetric Matrix Market file: the matrix is {m}x{n}, not square",
            path.display()
        )));
    }
    let mut nnz = 0usize;
    for j in 0..n {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            if symmetric && i < j {
                continue;
            }
            if !v.is_finite() {
                return Err(non_finite_write(path, i, j, v));
            }
            nnz += 1;
        }
    }
    let kind = if symmetric { "symmetric" } else { "general" };
    atomic::write_file(path, |w| {
        writeln!(w, "%%MatrixMarket matrix coordinate real {kind}")?;
        writeln!(w, "{m} {n} {nnz}")?;
        let mut line = Vec::with_capacity(64);
        for j in 0..n {
            for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                if symmetric && i < j {
                    continue;
                }
                line.clear();
                push_usize(&mut line, i + 1);
                line.push(b' ');
                push_usize(&mut line, j + 1);
                line.push(b' ');
                push_f64(&mut line, v);
                line.push(b'\n');
                w.write_all(&line)?;
            }
        }
        Ok(())
    })
}

/// Writes `a` as an `array real general` Matrix Market file, column-major, one value per line,
/// in shortest round-trip form (so [`read_dense`] returns `a` bit-exactly). The file is written
/// to `<path>.tmp` and then renamed.
pub fn write_array(path: &Path, a: MatRef<'_, f64>) -> Result<()> {
    let (m, n) = (a.nrows(), a.ncols());
    for j in 0..n {
        for i in 0..m {
            let v = a[(i, j)];
            if !v.is_finite() {
                return Err(non_finite_write(path, i, j, v));
            }
        }
    }
    atomic::write_file(path, |w| {
        writeln!(w, "%%MatrixMarket matrix array real general")?;
        writeln!(w, "{m} {n}")?;
        let mut line = Vec::with_capacity(32);
        for j in 0..n {
            for i in 0..m {
                line.clear();
                push_f64(&mut line, a[(i, j)]);
                line.push(b'\n');
                w.write_all(&line)?;
            }
        }
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// Writing helpers

fn non_finite_write(path: &Path, i: usize, j: usize, v: f64) -> Error {
    Error::InvalidModel(format!(
        "cannot write {}: entry ({}, {}) is {v}; Matrix Market files must hold finite values",
        path.display(),
        i + 1,
        j + 1
    ))
}

/// Appends the decimal digits of `x`.
fn push_usize(out: &mut Vec<u8>, mut x: usize) {
    let mut buf = [0u8; 20];
    let mut k = buf.len();
    loop {
        k -= 1;
        buf[k] = b'0' + (x % 10) as u8;
        x /= 10;
        if x == 0 {
            break;
        }
    }
    out.extend_from_slice(&buf[k..]);
}

/// Appends finite `v` in the shortest form that parses back to the same bits.
#[inline]
fn push_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(zmij::Buffer::new().format_finite(v).as_bytes());
}

// ---------------------------------------------------------------------------------------------
// Reading: input, header

fn gunzip(data: &[u8], path: &Path) -> Result<Vec<u8>> {
    // The gzip trailer holds the uncompressed size mod 2^32: a good capacity hint for files
    // under 4 GiB, and harmless otherwise (the vector grows).
    let hint = match data.len().checked_sub(4).and_then(|k| data.get(k..)) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]) as usize,
        _ => 0,
    };
    let mut out = Vec::new();
    let _ = out.try_reserve_exact(hint.min(data.len().saturating_mul(64)).saturating_add(1));
    flate2::read::MultiGzDecoder::new(data)
        .read_to_end(&mut out)
        .map_err(|e| {
            Error::parse(
                path,
                0,
                format!("corrupt or truncated gzip data ({e}); the file starts with the gzip magic bytes 1f 8b but cannot be decompressed"),
            )
        })?;
    Ok(out)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Coordinate,
    Array,
}

#[derive(Debug, Clone, Copy)]
struct Header {
    format: Format,
    symmetry: Symmetry,
    nrows: usize,
    ncols: usize,
    /// Declared number of entries (coordinate only).
    nnz: usize,
    /// 1-based line of the size line.
    size_line: usize,
    /// Byte offset of the first line after the size line.
    body_start: usize,
}

/// Iterates over the lines of `buf` (without their `\n`), with 1-based line numbers.
struct Lines<'a> {
    buf: &'a [u8],
    pos: usize,
    next_line: usize,
}

impl<'a> Lines<'a> {
    fn new(buf: &'a [u8], first_line: usize) -> Self {
        Lines {
            buf,
            pos: 0,
            next_line: first_line,
        }
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, &'a [u8]);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        let rest = self.buf.get(self.pos..)?;
        if rest.is_empty() {
            return None;
        }
        let (line, advance) = match memchr::memchr(b'\n', rest) {
            Some(k) => (&rest[..k], k + 1),
            None => (rest, rest.len()),
        };
        self.pos += advance;
        let number = self.next_line;
        self.next_line += 1;
        Some((number, line))
    }
}

#[inline(always)]
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// The next whitespace-separated token of `line` from `*pos`.
#[inline(always)]
fn next_token<'a>(line: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    let mut i = *pos;
    while i < line.len() && is_space(line[i]) {
        i += 1;
    }
    if i >= line.len() {
        *pos = i;
        return None;
    }
    let start = i;
    while i < line.len() && !is_space(line[i]) {
        i += 1;
    }
    *pos = i;
    Some(&line[start..i])
}

fn count_tokens(line: &[u8]) -> usize {
    let mut pos = 0;
    let mut n = 0;
    while next_token(line, &mut pos).is_some() {
        n += 1;
    }
    n
}

fn tokens(line: &[u8]) -> Vec<&[u8]> {
    let mut pos = 0;
    let mut out = Vec::new();
    while let Some(t) = next_token(line, &mut pos) {
        out.push(t);
    }
    out
}

/// `bytes` for an error message: lossy UTF-8, cut to a readable length.
fn show(bytes: &[u8]) -> String {
    const MAX: usize = 60;
    let s = String::from_utf8_lossy(&bytes[..bytes.len().min(MAX)]);
    if bytes.len() > MAX {
        format!("{s}...")
    } else {
        s.into_owned()
    }
}

/// A non-negative decimal integer (no sign), or `None` if malformed or too large.
#[inline(always)]
fn parse_usize(tok: &[u8]) -> Option<usize> {
    if tok.is_empty() {
        return None;
    }
    let mut v: usize = 0;
    for &b in tok {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v.checked_mul(10)?.checked_add(d as usize)?;
    }
    Some(v)
}

const BANNER_HELP: &str =
    "the first line must be `%%MatrixMarket matrix <format> <field> <symmetry>` \
     with format coordinate or array, field real, double or integer, symmetry general or symmetric";

fn parse_header(bytes: &[u8], path: &Path) -> Result<Header> {
    let err = |line: usize, msg: String| Error::parse(path, line, msg);
    let mut lines = Lines::new(bytes, 1);
    let Some((_, first)) = lines.next() else {
        return Err(err(
            1,
            format!("empty file: missing the Matrix Market banner; {BANNER_HELP}"),
        ));
    };
    let words = tokens(first);
    if !words
        .first()
        .is_some_and(|w| w.eq_ignore_ascii_case(b"%%MatrixMarket"))
    {
        return Err(err(
            1,
            format!(
                "missing Matrix Market banner (found `{}`); {BANNER_HELP}",
                show(first)
            ),
        ));
    }
    if words.len() != 5 {
        return Err(err(
            1,
            format!(
                "bad banner `{}`: expected 5 words, found {}; {BANNER_HELP}",
                show(first),
                words.len()
            ),
        ));
    }
    let lower = |w: &[u8]| show(w).to_ascii_lowercase();
    let (object, format, field, symmetry) = (
        lower(words[1]),
        lower(words[2]),
        lower(words[3]),
        lower(words[4]),
    );
    if object != "matrix" {
        return Err(err(
            1,
            format!("unsupported object `{object}`: only `matrix` is supported; {BANNER_HELP}"),
        ));
    }
    let format = match format.as_str() {
        "coordinate" => Format::Coordinate,
        "array" => Format::Array,
        _ => {
            return Err(err(
                1,
                format!(
                    "unsupported format `{format}`: supported are coordinate (sparse) and array (dense)"
                ),
            ))
        }
    };
    match field.as_str() {
        "real" | "double" | "integer" => {}
        _ => {
            return Err(err(
                1,
                format!("unsupported field `{field}`: supported are real, double and integer (complex and pattern matrices are not)"),
            ))
        }
    }
    let symmetry = match symmetry.as_str() {
        "general" => Symmetry::General,
        "symmetric" => Symmetry::Symmetric,
        _ => {
            return Err(err(
                1,
                format!("unsupported symmetry `{symmetry}`: supported are general and symmetric (hermitian and skew-symmetric are not)"),
            ))
        }
    };

    // Comments and blank lines, then the size line.
    let mut last_line = 1;
    let (size_line, size) = loop {
        let Some((number, line)) = lines.next() else {
            return Err(err(
                last_line,
                "missing size line: the file ends after the banner and comments".to_string(),
            ));
        };
        last_line = number;
        let mut pos = 0;
        match next_token(line, &mut pos) {
            None => continue,
            Some(t) if t.first() == Some(&b'%') => continue,
            Some(_) => break (number, line),
        }
    };
    let words = tokens(size);
    let (want, what) = match format {
        Format::Coordinate => (3, "`rows columns entries`"),
        Format::Array => (2, "`rows columns`"),
    };
    let numbers: Vec<Option<usize>> = words.iter().map(|w| parse_usize(w)).collect();
    let bad_size = || {
        err(
            size_line,
            format!(
                "bad size line `{}`: expected {what} ({want} non-negative integers) for a{} {} file",
                show(size),
                if format == Format::Array { "n" } else { "" },
                if format == Format::Array { "array" } else { "coordinate" },
            ),
        )
    };
    if words.len() != want || numbers.iter().any(Option::is_none) {
        return Err(bad_size());
    }
    let nrows = numbers[0].unwrap_or(0);
    let ncols = numbers[1].unwrap_or(0);
    let nnz = numbers.get(2).copied().flatten().unwrap_or(0);
    if nrows > isize::MAX as usize || ncols > isize::MAX as usize {
        return Err(err(
            size_line,
            format!("matrix dimensions {nrows}x{ncols} are too large"),
        ));
    }
    if symmetry == Symmetry::Symmetric && nrows != ncols {
        return Err(err(
            size_line,
            format!(
                "a symmetric matrix must be square, but the size line declares {nrows}x{ncols}"
            ),
        ));
    }
    Ok(Header {
        format,
        symmetry,
        nrows,
        ncols,
        nnz,
        size_line,
        body_start: lines.pos,
    })
}

/// A parsed file that no longer needs the text.
enum Parsed {
    /// Coordinate entries with 32-bit indices (when the dimensions allow: half the memory).
    Coord32(Header, Vec<Vec<Entry<u32>>>),
    /// Coordinate entries with full-width indices.
    Coord64(Header, Vec<Vec<Entry<usize>>>),
    /// An array file.
    Dense(Header, Mat<f64>),
}

impl Parsed {
    /// Assembles the matrix.
    fn finish(self, path: &Path) -> Result<MtxMatrix> {
        let (h, data) = match self {
            Parsed::Coord32(h, chunks) => (h, MtxData::Sparse(build_csc(&h, chunks, path)?)),
            Parsed::Coord64(h, chunks) => (h, MtxData::Sparse(build_csc(&h, chunks, path)?)),
            Parsed::Dense(h, m) => (h, MtxData::Dense(m)),
        };
        Ok(MtxMatrix {
            symmetry: h.symmetry,
            data,
        })
    }
}

fn parse_plain(bytes: &[u8], path: &Path) -> Result<Parsed> {
    let h = parse_header(bytes, path)?;
    let body = bytes.get(h.body_start..).unwrap_or(&[]);
    Ok(match h.format {
        Format::Coordinate if h.nrows.max(h.ncols) <= u32::MAX as usize => {
            Parsed::Coord32(h, parse_coordinate_body(body, &h, path)?)
        }
        Format::Coordinate => Parsed::Coord64(h, parse_coordinate_body(body, &h, path)?),
        Format::Array => Parsed::Dense(h, parse_array_body(body, &h, path)?),
    })
}

// ---------------------------------------------------------------------------------------------
// Reading: coordinate entries

/// An index type for the entry list: `u32` when the dimensions allow, else `usize`.
trait Ix: Copy + Send + Sync + Default + std::fmt::Debug {
    /// `x`, which the caller guarantees to fit.
    fn from_usize(x: usize) -> Self;
    fn to_usize(self) -> usize;
}

impl Ix for u32 {
    #[inline(always)]
    fn from_usize(x: usize) -> Self {
        x as u32
    }
    #[inline(always)]
    fn to_usize(self) -> usize {
        self as usize
    }
}

impl Ix for usize {
    #[inline(always)]
    fn from_usize(x: usize) -> Self {
        x
    }
    #[inline(always)]
    fn to_usize(self) -> usize {
        self
    }
}

/// One entry, 0-based.
#[derive(Debug, Clone, Copy)]
struct Entry<I> {
    row: I,
    col: I,
    val: f64,
}

/// The entries of a range of lines.
#[derive(Debug, Default)]
struct CoordChunk<I> {
    entries: Vec<Entry<I>>,
    /// Number of entry lines seen.
    count: usize,
    /// Whether a strictly-lower / strictly-upper entry was seen.
    has_lower: bool,
    has_upper: bool,
    /// Number of the last line seen (0 if none).
    last_line: usize,
}

/// Below this many bytes of entries, parse on one thread.
const PARALLEL_MIN_BYTES: usize = 1 << 20;

/// Parses the entry section. With more than one rayon thread and a large section, the section
/// is split at line boundaries and the pieces are parsed in parallel; if any piece fails, or the
/// pieces disagree with the header (entry count, triangles), the whole section is parsed again
/// on one thread, which finds the first problem with its exact line number.
fn parse_coordinate_body<I: Ix>(
    body: &[u8],
    h: &Header,
    path: &Path,
) -> Result<Vec<Vec<Entry<I>>>> {
    let threads = rayon::current_num_threads();
    if threads > 1 && body.len() >= PARALLEL_MIN_BYTES {
        let ranges = split_at_lines(body, threads * 4);
        let per_byte = h.nnz as f64 / body.len() as f64;
        let chunks: Vec<Option<CoordChunk<I>>> = ranges
            .into_par_iter()
            .map(|r| {
                let len = r.len();
                let cap = ((len as f64 * per_byte * 1.02) as usize + 64).min(len / 6 + 1);
                parse_coordinate_lines(&body[r], 0, h, path, None, cap).ok()
            })
            .collect();
        let consistent = chunks.iter().all(Option::is_some) && {
            let all = chunks.iter().flatten();
            let count: usize = all.clone().map(|c| c.count).sum();
            let lower = all.clone().any(|c| c.has_lower);
            let upper = all.clone().any(|c| c.has_upper);
            count == h.nnz && !(lower && upper)
        };
        if consistent {
            return Ok(chunks.into_iter().flatten().map(|c| c.entries).collect());
        }
    }
    let cap = h.nnz.min(body.len() / 6 + 1);
    let chunk = parse_coordinate_lines(body, h.size_line + 1, h, path, Some(h.nnz), cap)?;
    if chunk.count < h.nnz {
        return Err(Error::parse(
            path,
            chunk.last_line.max(h.size_line),
            format!(
                "too few entries: the size line (line {}) declares {} entries, but the file holds only {}",
                h.size_line, h.nnz, chunk.count
            ),
        ));
    }
    Ok(vec![chunk.entries])
}

/// Splits `body` into about `pieces` ranges that end just after a newline (the last one at the
/// end of `body`).
fn split_at_lines(body: &[u8], pieces: usize) -> Vec<Range<usize>> {
    let pieces = pieces.max(1);
    let mut out = Vec::with_capacity(pieces);
    let mut start = 0;
    for k in 1..pieces {
        let target = (body.len() / pieces * k).max(start);
        if target >= body.len() {
            break;
        }
        let end = match memchr::memchr(b'\n', &body[target..]) {
            Some(i) => target + i + 1,
            None => body.len(),
        };
        out.push(start..end);
        start = end;
        if start >= body.len() {
            break;
        }
    }
    if start < body.len() || out.is_empty() {
        out.push(start..body.len());
    }
    out
}

/// Parses the coordinate entry lines of `text`, whose first line is number `first_line`.
///
/// With `limit`, more than `limit` entries is an error at the first extra line. Mixing
/// triangles in a symmetric file is an error at the first line of the second triangle seen.
///
/// Each line first goes through [`fast_entry`], which accepts the common well-formed line;
/// anything else (blank lines, odd spacing, malformed or out-of-range data) is handled by
/// [`slow_entry`], which gives the precise error.
fn parse_coordinate_lines<I: Ix>(
    text: &[u8],
    first_line: usize,
    h: &Header,
    path: &Path,
    limit: Option<usize>,
    capacity: usize,
) -> Result<CoordChunk<I>> {
    let mut out = CoordChunk::<I>::default();
    out.entries
        .try_reserve_exact(capacity)
        .map_err(|_| too_large(path, h, "the entries"))?;
    let symmetric = h.symmetry == Symmetry::Symmetric;
    let limit = limit.unwrap_or(usize::MAX);
    // First strictly-lower / strictly-upper entry: (line, row, col), 1-based.
    let mut first_lower: Option<(usize, usize, usize)> = None;
    let mut first_upper: Option<(usize, usize, usize)> = None;
    let mut pos = 0;
    let mut number = first_line;
    while pos < text.len() {
        let (row, col, val) = match fast_entry(text, pos, h.nrows, h.ncols) {
            Some((row, col, val, next)) => {
                pos = next;
                (row, col, val)
            }
            None => {
                let (line, next) = line_at(text, pos);
                pos = next;
                match slow_entry(line, number, h, path)? {
                    Some(entry) => entry,
                    None => {
                        number += 1;
                        continue; // blank line
                    }
                }
            }
        };
        out.count += 1;
        if out.count > limit {
            return Err(Error::parse(
                path,
                number,
                format!(
                    "too many entries: the size line (line {}) declares {limit} entries, but this is entry {}",
                    h.size_line, out.count
                ),
            ));
        }
        if symmetric && row != col {
            let (mine, other, mine_name, other_name) = if row > col {
                (&mut first_lower, first_upper, "lower", "upper")
            } else {
                (&mut first_upper, first_lower, "upper", "lower")
            };
            if let Some((l, r, c)) = other {
                return Err(Error::parse(
                    path,
                    number,
                    format!(
                        "symmetric file mixes triangles: entry ({row}, {col}) is in the {mine_name} triangle, \
                         but line {l} holds ({r}, {c}) in the {other_name} triangle; \
                         a symmetric file must store one triangle only (the lower, per the spec)"
                    ),
                ));
            }
            if mine.is_none() {
                *mine = Some((number, row, col));
            }
        }
        out.entries.push(Entry {
            row: I::from_usize(row - 1),
            col: I::from_usize(col - 1),
            val,
        });
        number += 1;
    }
    out.last_line = number.saturating_sub(1);
    out.has_lower = first_lower.is_some();
    out.has_upper = first_upper.is_some();
    Ok(out)
}

/// The line starting at `pos` (without its `\n`) and the position after it.
#[inline]
fn line_at(text: &[u8], pos: usize) -> (&[u8], usize) {
    let rest = text.get(pos..).unwrap_or(&[]);
    match memchr::memchr(b'\n', rest) {
        Some(k) => (&rest[..k], pos + k + 1),
        None => (rest, text.len()),
    }
}

/// The common case of an entry line at `pos`: `row col value` separated by spaces or tabs,
/// indices in range, a finite value, optional trailing spaces or `\r`, then `\n` or the end.
/// Returns the 1-based indices, the value and the position after the line, or `None` if the
/// line is anything else (then [`slow_entry`] decides).
#[inline(always)]
fn fast_entry(
    text: &[u8],
    pos: usize,
    nrows: usize,
    ncols: usize,
) -> Option<(usize, usize, f64, usize)> {
    let (row, mut p) = leading_digits(text, pos)?;
    p = skip_blanks(text, p, true)?;
    let (col, q) = leading_digits(text, p)?;
    p = skip_blanks(text, q, true)?;
    let (val, used) = fast_float2::parse_partial::<f64, _>(text.get(p..)?).ok()?;
    p = skip_blanks(text, p + used, false)?;
    match text.get(p) {
        Some(b'\n') => p += 1,
        None => {}
        Some(_) => return None,
    }
    let ok = row.wrapping_sub(1) < nrows && col.wrapping_sub(1) < ncols && val.is_finite();
    ok.then_some((row, col, val, p))
}

/// Skips spaces, tabs and `\r` from `p`; with `required`, at least one must be there.
#[inline(always)]
fn skip_blanks(text: &[u8], mut p: usize, required: bool) -> Option<usize> {
    let start = p;
    while let Some(b' ' | b'\t' | b'\r') = text.get(p) {
        p += 1;
    }
    (!required || p > start).then_some(p)
}

const ONES: u64 = 0x0101_0101_0101_0101;

/// The decimal integer at `text[p..]` (1 to 19 digits, not followed by another digit) and the
/// position after it. Reads 8 digits at a time (SWAR) where 8 bytes are available.
#[inline(always)]
fn leading_digits(text: &[u8], p: usize) -> Option<(usize, usize)> {
    let (mut value, mut q) = match text.get(p..p.wrapping_add(8)) {
        Some(chunk) => {
            let mut bytes = [0u8; 8];
            bytes.copy_from_slice(chunk);
            let lo = u64::from_le_bytes(bytes) ^ (0x30 * ONES);
            // High bit of each byte set iff that byte is not an ASCII digit (exact per byte).
            let non_digit = (((lo & (0x7f * ONES)) + 0x76 * ONES) | lo) & (0x80 * ONES);
            let count = (non_digit.trailing_zeros() / 8) as usize;
            if count == 0 {
                return None;
            }
            // Right-align the digits (first digit most significant), then combine pairwise.
            let mut v = lo << (8 * (8 - count));
            v = ((v & 0x0F0F_0F0F_0F0F_0F0F).wrapping_mul(2561)) >> 8;
            v = ((v & 0x00FF_00FF_00FF_00FF).wrapping_mul(6_553_601)) >> 16;
            v = ((v & 0x0000_FFFF_0000_FFFF).wrapping_mul(42_949_672_960_001)) >> 32;
            if count < 8 {
                return Some((v as usize, p + count));
            }
            (v as usize, p + 8)
        }
        None => (0, p),
    };
    // Fewer than 8 bytes left, or more than 8 digits: continue one digit at a time.
    let start = p;
    while let Some(&b) = text.get(q) {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        value = value.checked_mul(10)?.checked_add(d as usize)?;
        q += 1;
    }
    (q > start).then_some((value, q))
}

/// Parses one entry line in full generality, with precise errors. `Ok(None)` for a blank line.
fn slow_entry(
    line: &[u8],
    number: usize,
    h: &Header,
    path: &Path,
) -> Result<Option<(usize, usize, f64)>> {
    let mut pos = 0;
    let Some(t_row) = next_token(line, &mut pos) else {
        return Ok(None);
    };
    let t_col = next_token(line, &mut pos);
    let t_val = next_token(line, &mut pos);
    let extra = next_token(line, &mut pos);
    let (Some(t_col), Some(t_val), None) = (t_col, t_val, extra) else {
        return Err(Error::parse(
            path,
            number,
            format!(
                "wrong number of tokens: expected 3 (row column value), found {} in `{}`",
                count_tokens(line),
                show(line)
            ),
        ));
    };
    let row = parse_index(t_row, "row", h.nrows, number, path)?;
    let col = parse_index(t_col, "column", h.ncols, number, path)?;
    let val = parse_value(t_val, number, path)?;
    Ok(Some((row, col, val)))
}

/// A finite real value.
fn parse_value(tok: &[u8], number: usize, path: &Path) -> Result<f64> {
    match fast_float2::parse::<f64, _>(tok) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(Error::parse(
            path,
            number,
            format!(
                "value `{}` is not finite (NaN and Inf are not allowed)",
                show(tok)
            ),
        )),
        Err(_) => Err(Error::parse(
            path,
            number,
            format!("unparsable value `{}`: expected a real number", show(tok)),
        )),
    }
}

/// A 1-based index in `1..=n`.
#[inline(always)]
fn parse_index(tok: &[u8], what: &str, n: usize, line: usize, path: &Path) -> Result<usize> {
    match parse_usize(tok) {
        Some(i) if i >= 1 && i <= n => Ok(i),
        Some(i) => Err(Error::parse(
            path,
            line,
            format!("{what} index {i} is out of range: allowed 1..={n} (1-based)"),
        )),
        None => Err(Error::parse(
            path,
            line,
            format!(
                "unparsable {what} index `{}`: expected an integer in 1..={n}",
                show(tok)
            ),
        )),
    }
}

fn too_large(path: &Path, h: &Header, what: &str) -> Error {
    Error::parse(
        path,
        h.size_line,
        format!(
            "the matrix ({}x{}, {} entries declared) is too large: cannot allocate {what}",
            h.nrows, h.ncols, h.nnz
        ),
    )
}

/// A vector of `n` copies of `value`, or an error if it cannot be allocated.
fn try_filled<T: Clone>(n: usize, value: T, path: &Path, h: &Header, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n)
        .map_err(|_| too_large(path, h, what))?;
    v.resize(n, value);
    Ok(v)
}

/// Assembles the canonical CSC matrix from the entries (in file order), mirroring off-diagonal
/// entries of a symmetric file and summing duplicates.
///
/// This mirrors while it scatters instead of using [`crate::sparse::mirror_lower`]: the
/// entries come as unsorted chunks (either triangle, duplicates, 32-bit indices) that are freed
/// one by one as they are scattered, and every allocation is fallible (a too-large declared
/// size is an error, not an abort); building the triangle first and mirroring it afterwards
/// would hold a second copy of the matrix.
fn build_csc<I: Ix>(
    h: &Header,
    chunks: Vec<Vec<Entry<I>>>,
    path: &Path,
) -> Result<SparseColMat<usize, f64>> {
    let (nrows, ncols) = (h.nrows, h.ncols);
    let mirror = h.symmetry == Symmetry::Symmetric;

    // Count per column, prefix sum.
    let mut col_ptr = try_filled(ncols + 1, 0usize, path, h, "the column pointers")?;
    for chunk in &chunks {
        for e in chunk {
            let (r, c) = (e.row.to_usize(), e.col.to_usize());
            col_ptr[c + 1] += 1;
            if mirror && r != c {
                col_ptr[r + 1] += 1;
            }
        }
    }
    for j in 0..ncols {
        col_ptr[j + 1] += col_ptr[j];
    }
    let total = col_ptr[ncols];

    // Scatter, keeping file order within each column; each chunk is freed once scattered.
    let mut row_idx = try_filled(total, 0usize, path, h, "the row indices")?;
    let mut val = try_filled(total, 0.0f64, path, h, "the values")?;
    let mut next = try_filled(ncols, 0usize, path, h, "the column cursors")?;
    next.copy_from_slice(&col_ptr[..ncols]);
    for chunk in chunks {
        for e in chunk {
            let (r, c) = (e.row.to_usize(), e.col.to_usize());
            let p = &mut next[c];
            row_idx[*p] = r;
            val[*p] = e.val;
            *p += 1;
            if mirror && r != c {
                let p = &mut next[r];
                row_idx[*p] = c;
                val[*p] = e.val;
                *p += 1;
            }
        }
    }
    drop(next);

    if sort_columns(&col_ptr, &mut row_idx, &mut val) {
        if let Some((i, j)) = sum_duplicates(&mut col_ptr, &mut row_idx, &mut val) {
            return Err(Error::parse(
                path,
                0,
                format!(
                    "the duplicate entries of ({}, {}) sum to a value that is not finite (overflow); \
                     duplicates are summed (finite-element assembly), so their sum must fit in a double",
                    i + 1,
                    j + 1
                ),
            ));
        }
    }
    let symbolic = SymbolicSparseColMat::new_checked(nrows, ncols, col_ptr, None, row_idx);
    Ok(SparseColMat::new(symbolic, val))
}

/// Sorts the rows of each column (stably, so duplicates stay in file order); returns whether
/// some column holds a duplicate row. Parallel over blocks of columns.
fn sort_columns(col_ptr: &[usize], row_idx: &mut [usize], val: &mut [f64]) -> bool {
    let ncols = col_ptr.len() - 1;
    let total = col_ptr[ncols];
    let threads = rayon::current_num_threads();
    let blocks = if threads > 1 && total >= 1 << 16 {
        threads * 4
    } else {
        1
    };
    // Column boundaries of blocks with about equal numbers of entries.
    let mut bounds = vec![0usize];
    for k in 1..blocks {
        let target = total / blocks * k;
        let j = col_ptr.partition_point(|&p| p < target).min(ncols);
        if j > *bounds.last().unwrap_or(&0) {
            bounds.push(j);
        }
    }
    if *bounds.last().unwrap_or(&0) < ncols || bounds.len() == 1 {
        bounds.push(ncols);
    }
    let mut work = Vec::with_capacity(bounds.len());
    let (mut rows_rest, mut vals_rest) = (row_idx, val);
    for w in bounds.windows(2) {
        let (j0, j1) = (w[0], w[1]);
        let len = col_ptr[j1] - col_ptr[j0];
        let (r, rr) = rows_rest.split_at_mut(len);
        let (v, vr) = vals_rest.split_at_mut(len);
        rows_rest = rr;
        vals_rest = vr;
        work.push((j0..j1, r, v));
    }
    work.into_par_iter()
        .map(|(cols, rows, vals)| {
            let base = col_ptr[cols.start];
            let mut dup = false;
            let mut scratch: Vec<(usize, f64)> = Vec::new();
            for j in cols {
                let range = col_ptr[j] - base..col_ptr[j + 1] - base;
                let r = &mut rows[range.clone()];
                let v = &mut vals[range];
                let mut sorted = true;
                for k in 1..r.len() {
                    if r[k - 1] >= r[k] {
                        if r[k - 1] == r[k] {
                            dup = true;
                        } else {
                            sorted = false;
                            break;
                        }
                    }
                }
                if !sorted {
                    scratch.clear();
                    scratch.extend(r.iter().copied().zip(v.iter().copied()));
                    scratch.sort_by_key(|&(i, _)| i);
                    for (k, &(i, x)) in scratch.iter().enumerate() {
                        r[k] = i;
                        v[k] = x;
                    }
                    dup |= r.windows(2).any(|w| w[0] == w[1]);
                }
            }
            dup
        })
        .reduce(|| false, |a, b| a || b)
}

/// Sums adjacent equal rows within each (sorted) column, in order, compacting the arrays.
/// Returns the first (row, column), 0-based, whose sum overflowed to ±Inf, if any (found by
/// the `mtx` fuzz target's re-validation: `1 1 1e308` twice gave an Inf entry).
fn sum_duplicates(
    col_ptr: &mut [usize],
    row_idx: &mut Vec<usize>,
    val: &mut Vec<f64>,
) -> Option<(usize, usize)> {
    let mut overflow = None;
    let ncols = col_ptr.len() - 1;
    let mut w = 0;
    let mut start = 0;
    for j in 0..ncols {
        let end = col_ptr[j + 1];
        col_ptr[j] = w;
        let mut k = start;
        while k < end {
            let r = row_idx[k];
            let mut v = val[k];
            k += 1;
            while k < end && row_idx[k] == r {
                v += val[k];
                k += 1;
            }
            if !v.is_finite() && overflow.is_none() {
                overflow = Some((r, j));
            }
            row_idx[w] = r;
            val[w] = v;
            w += 1;
        }
        start = end;
    }
    col_ptr[ncols] = w;
    row_idx.truncate(w);
    val.truncate(w);
    overflow
}

// ---------------------------------------------------------------------------------------------
// Reading: array values

/// Largest dimension of an empty (0×n or n×0) array file.
const MAX_EMPTY_DIM: usize = 1 << 20;

fn parse_array_body(body: &[u8], h: &Header, path: &Path) -> Result<Mat<f64>> {
    let (nrows, ncols) = (h.nrows, h.ncols);
    let symmetric = h.symmetry == Symmetry::Symmetric;
    let expected = if symmetric {
        nrows
            .checked_add(1)
            .and_then(|n1| n1.checked_mul(nrows))
            .map(|x| x / 2)
    } else {
        nrows.checked_mul(ncols)
    };
    let Some(expected) = expected else {
        return Err(Error::parse(
            path,
            h.size_line,
            format!("the matrix ({nrows}x{ncols}) is too large to hold densely"),
        ));
    };
    // An empty array still costs memory: faer pads columns to 16 rows, so 0×n takes 128·n
    // bytes. An empty matrix holds nothing, so a huge declared dimension is a corrupt size line
    // (a fuzzed 0×18518521 file asked for 2.4 GB).
    if expected == 0 && nrows.max(ncols) > MAX_EMPTY_DIM {
        return Err(Error::parse(
            path,
            h.size_line,
            format!(
                "the size line declares an empty {nrows}x{ncols} array: an empty matrix needs no dimension above                  {MAX_EMPTY_DIM}; check the size line"
            ),
        ));
    }
    // Each value takes at least two bytes (a digit and a newline) but the last: a file too short
    // to hold `expected` values gets its "too few entries" error without allocating the matrix.
    let plausible = expected <= body.len() / 2 + 1 && dense_fits(nrows, ncols);
    let mut mat = if plausible {
        Some(Mat::<f64>::zeros(nrows, ncols))
    } else {
        None
    };
    let (mut i, mut j) = (0usize, 0usize);
    let mut count = 0usize;
    let mut lines = Lines::new(body, h.size_line + 1);
    for (number, line) in lines.by_ref() {
        let mut pos = 0;
        let Some(tok) = next_token(line, &mut pos) else {
            continue;
        };
        if next_token(line, &mut pos).is_some() {
            return Err(Error::parse(
                path,
                number,
                format!(
                    "wrong number of tokens: an array file holds 1 value per line, found {} in `{}`",
                    count_tokens(line),
                    show(line)
                ),
            ));
        }
        count += 1;
        if count > expected {
            return Err(Error::parse(
                path,
                number,
                format!(
                    "too many entries: the size line (line {}) declares {nrows}x{ncols}{}, i.e. {expected} values, but this is value {count}",
                    h.size_line,
                    if symmetric { " symmetric (lower triangle stored)" } else { "" },
                ),
            ));
        }
        let v = parse_value(tok, number, path)?;
        if let Some(m) = mat.as_mut() {
            // count <= expected keeps (i, j) inside the matrix.
            m[(i, j)] = v;
            if symmetric {
                m[(j, i)] = v;
            }
        }
        i += 1;
        if i == nrows {
            j += 1;
            i = if symmetric { j } else { 0 };
        }
    }
    if count < expected {
        return Err(Error::parse(
            path,
            lines.next_line.saturating_sub(1).max(h.size_line),
            format!(
                "too few entries: the size line (line {}) declares {nrows}x{ncols}{}, i.e. {expected} values, but the file holds only {count}",
                h.size_line,
                if symmetric { " symmetric (lower triangle stored)" } else { "" },
            ),
        ));
    }
    // `count == expected` here, so the matrix exists unless its shape cannot be allocated
    // (e.g. 0 x 10^18).
    mat.ok_or_else(|| {
        Error::parse(
            path,
            h.size_line,
            format!("the matrix ({nrows}x{ncols}) is too large to hold densely"),
        )
    })
}

/// Whether a dense `nrows x ncols` matrix can be allocated (probed without touching memory).
/// faer pads columns and does work per column even when `nrows == 0`, hence the margins.
fn dense_fits(nrows: usize, ncols: usize) -> bool {
    nrows
        .checked_next_multiple_of(16)
        .and_then(|r| r.max(16).checked_mul(ncols.max(1)))
        .is_some_and(|len| {
            len <= isize::MAX as usize / 8 && Vec::<f64>::new().try_reserve_exact(len).is_ok()
        })
}

// ---------------------------------------------------------------------------------------------
// Conversions

fn dense_to_sparse(a: MatRef<'_, f64>) -> SparseColMat<usize, f64> {
    let (m, n) = (a.nrows(), a.ncols());
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::new();
    let mut val = Vec::new();
    col_ptr.push(0);
    for j in 0..n {
        for i in 0..m {
            let v = a[(i, j)];
            if v != 0.0 {
                row_idx.push(i);
                val.push(v);
            }
        }
        col_ptr.push(row_idx.len());
    }
    let symbolic = SymbolicSparseColMat::new_checked(m, n, col_ptr, None, row_idx);
    SparseColMat::new(symbolic, val)
}

fn sparse_to_dense(a: SparseColMatRef<'_, usize, f64>, path: &Path) -> Result<Mat<f64>> {
    let (m, n) = (a.nrows(), a.ncols());
    // Probe the allocation first: the dimensions come from the file.
    if !dense_fits(m, n) {
        return Err(Error::parse(
            path,
            0,
            format!("the {m}x{n} sparse matrix is too large to convert to a dense matrix"),
        ));
    }
    let mut out = Mat::<f64>::zeros(m, n);
    for j in 0..n {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            out[(i, j)] += v;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference for [`leading_digits`]: one digit at a time.
    fn digits_ref(text: &[u8], p: usize) -> Option<(usize, usize)> {
        let mut v = 0usize;
        let mut q = p;
        while let Some(&b) = text.get(q) {
            if !b.is_ascii_digit() {
                break;
            }
            v = v.checked_mul(10)?.checked_add((b - b'0') as usize)?;
            q += 1;
        }
        (q > p).then_some((v, q))
    }

    #[test]
    fn leading_digits_matches_reference() {
        let cases: &[&[u8]] = &[
            b"1 2 3",
            b"12345678 1",
            b"123456789012 x",
            b"99999999999999999999 1",
            b"18446744073709551615",
            b"18446744073709551616",
            b"0",
            b"007 1",
            b"x1",
            b"",
            b"1234567",
            b"12345678",
            b"1/2:3",
            b"9\xff\x80",
            b"/0123456789:",
        ];
        for &c in cases {
            for p in 0..=c.len() {
                assert_eq!(leading_digits(c, p), digits_ref(c, p), "{c:?} at {p}");
            }
        }
        // Every byte value right after a digit, at every alignment.
        for b in 0..=255u8 {
            for k in 0..10 {
                let mut text = vec![b'7'; k + 1];
                text.push(b);
                text.extend_from_slice(b"        ");
                assert_eq!(
                    leading_digits(&text, 0),
                    digits_ref(&text, 0),
                    "byte {b} after {k}"
                );
            }
        }
    }

    #[test]
    fn fast_entry_accepts_only_the_common_case() {
        let f = |s: &[u8]| fast_entry(s, 0, 10, 10);
        assert_eq!(f(b"1 2 3.5\n"), Some((1, 2, 3.5, 8)));
        assert_eq!(f(b"10\t10  -1e-3 \r\nnext"), Some((10, 10, -1e-3, 15)));
        assert_eq!(f(b"1 2 3"), Some((1, 2, 3.0, 5)));
        for bad in [
            &b" 1 2 3\n"[..],
            b"1 2\n",
            b"1 2 3 4\n",
            b"0 1 1\n",
            b"11 1 1\n",
            b"1 1 nan\n",
            b"1 1 inf\n",
            b"1 1 1e400\n",
            b"1 1 1.5x\n",
            b"1,1 1\n",
            b"1 1 1\x0c\n",
        ] {
            assert_eq!(f(bad), None, "{:?}", String::from_utf8_lossy(bad));
        }
    }

    #[test]
    fn split_at_lines_covers_everything_at_line_ends() {
        let text = b"a\nbb\nccc\n\ndddd\neeeee";
        for pieces in 1..12 {
            let r = split_at_lines(text, pieces);
            assert_eq!(r.first().map(|r| r.start), Some(0));
            assert_eq!(r.last().map(|r| r.end), Some(text.len()));
            for w in r.windows(2) {
                assert_eq!(w[0].end, w[1].start);
                assert_eq!(text[w[0].end - 1], b'\n');
            }
        }
        assert_eq!(split_at_lines(b"", 4), vec![0..0]);
    }

    #[test]
    fn parallel_and_sequential_parses_agree() {
        // A file with duplicates, unsorted order and both index widths' paths.
        let mut text = String::from("%%MatrixMarket matrix coordinate real symmetric\n");
        let n = 200_000usize;
        text.push_str(&format!("1000 1000 {n}\n"));
        let mut x = 12345u64;
        for _ in 0..n {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let (i, j) = ((x % 1000) as usize + 1, ((x >> 20) % 1000) as usize + 1);
            let (i, j) = if i >= j { (i, j) } else { (j, i) };
            text.push_str(&format!("{i} {j} {}\n", (x >> 11) as f64 / 1e10));
        }
        let path = Path::new("mem.mtx");
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let four = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let a = one.install(|| parse_bytes(text.as_bytes(), path)).unwrap();
        let b = four.install(|| parse_bytes(text.as_bytes(), path)).unwrap();
        let (MtxData::Sparse(a), MtxData::Sparse(b)) = (a.data, b.data) else {
            panic!("sparse expected")
        };
        assert_eq!(a.symbolic().col_ptr(), b.symbolic().col_ptr());
        assert_eq!(a.symbolic().row_idx(), b.symbolic().row_idx());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(a.val()), bits(b.val()));
        // The usize entry path gives the same matrix as the u32 one.
        let h = parse_header(text.as_bytes(), path).unwrap();
        let body = &text.as_bytes()[h.body_start..];
        let wide = build_csc(
            &h,
            parse_coordinate_body::<usize>(body, &h, path).unwrap(),
            path,
        )
        .unwrap();
        assert_eq!(wide.symbolic().row_idx(), a.symbolic().row_idx());
        assert_eq!(bits(wide.val()), bits(a.val()));
    }

    #[test]
    fn huge_declared_sizes_error_instead_of_panicking() {
        let p = Path::new("huge.mtx");
        let cases: &[&[u8]] = &[
            b"%%MatrixMarket matrix coordinate real general\n1 1000000000000000000 0\n",
            b"%%MatrixMarket matrix coordinate real general\n1 1 18446744073709551615\n1 1 1\n",
            b"%%MatrixMarket matrix array real general\n0 1000000000000000000\n",
            b"%%MatrixMarket matrix array real general\n1000000000000000000 1000000000000000000\n1\n",
            b"%%MatrixMarket matrix array real symmetric\n10000000000 10000000000\n1\n",
        ];
        for &c in cases {
            assert!(parse_bytes(c, p).is_err(), "{}", String::from_utf8_lossy(c));
        }
        // A tall coordinate matrix whose dense form cannot exist.
        let text =
            b"%%MatrixMarket matrix coordinate real general\n1000000000000000000 2 1\n1 1 1\n";
        let m = parse_bytes(text, p).unwrap();
        let MtxData::Sparse(a) = m.data else {
            panic!("sparse expected")
        };
        assert!(sparse_to_dense(a.as_ref(), p).is_err());
    }

    #[test]
    fn push_helpers() {
        let mut v = Vec::new();
        push_usize(&mut v, 0);
        v.push(b' ');
        push_usize(&mut v, usize::MAX);
        v.push(b' ');
        push_f64(&mut v, -0.0);
        v.push(b' ');
        push_f64(&mut v, 1e-300);
        assert_eq!(
            String::from_utf8(v).unwrap(),
            format!("0 {} -0.0 1e-300", usize::MAX)
        );
    }
}
