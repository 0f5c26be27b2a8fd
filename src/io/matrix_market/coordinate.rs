//! Coordinate entries: parallel line parsing (fast path + precise errors) and CSC assembly.

use std::path::Path;

use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use rayon::prelude::*;

use super::header::{show, Header, Symmetry};
use crate::error::{Error, Result};
use crate::io::text::{finite_f64, line_at, par_pieces, parse_usize, words, BadNumber};

/// An index type for the entry list: `u32` when the dimensions allow, else `usize`.
pub(super) trait Ix: Copy + Send + Sync + Default + std::fmt::Debug {
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
pub(super) struct Entry<I> {
    pub(super) row: I,
    pub(super) col: I,
    pub(super) val: f64,
}

/// The entries of a range of lines.
#[derive(Debug, Default)]
pub(super) struct CoordChunk<I> {
    pub(super) entries: Vec<Entry<I>>,
    /// Number of entry lines seen.
    pub(super) count: usize,
    /// Whether a strictly-lower / strictly-upper entry was seen.
    pub(super) has_lower: bool,
    pub(super) has_upper: bool,
    /// Number of the last line seen (0 if none).
    pub(super) last_line: usize,
}

/// Below this many bytes of entries, parse on one thread.
pub(super) const PARALLEL_MIN_BYTES: usize = 1 << 20;

/// Parses the entry section. With more than one rayon thread and a large section, the section
/// is split at line boundaries and the pieces are parsed in parallel; if any piece fails, or the
/// pieces disagree with the header (entry count, triangles), the whole section is parsed again
/// on one thread, which finds the first problem with its exact line number.
pub(super) fn parse_coordinate_body<I: Ix>(
    body: &[u8],
    h: &Header,
    path: &Path,
) -> Result<Vec<Vec<Entry<I>>>> {
    let threads = rayon::current_num_threads();
    if threads > 1 && body.len() >= PARALLEL_MIN_BYTES {
        let per_byte = h.nnz as f64 / body.len() as f64;
        let chunks: Vec<Option<CoordChunk<I>>> = par_pieces(body, threads * 4, |_, piece| {
            let len = piece.len();
            let cap = ((len as f64 * per_byte * 1.02) as usize + 64).min(len / 6 + 1);
            parse_coordinate_lines(piece, 0, h, path, None, cap).ok()
        });
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

/// Parses the coordinate entry lines of `text`, whose first line is number `first_line`.
///
/// With `limit`, more than `limit` entries is an error at the first extra line. Mixing
/// triangles in a symmetric file is an error at the first line of the second triangle seen.
///
/// Each line first goes through [`fast_entry`], which accepts the common well-formed line;
/// anything else (blank lines, odd spacing, malformed or out-of-range data) is handled by
/// [`slow_entry`], which gives the precise error.
pub(super) fn parse_coordinate_lines<I: Ix>(
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

/// The common case of an entry line at `pos`: `row col value` separated by spaces or tabs,
/// indices in range, a finite value, optional trailing spaces or `\r`, then `\n` or the end.
/// Returns the 1-based indices, the value and the position after the line, or `None` if the
/// line is anything else (then [`slow_entry`] decides).
#[inline(always)]
pub(super) fn fast_entry(
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
pub(super) fn skip_blanks(text: &[u8], mut p: usize, required: bool) -> Option<usize> {
    let start = p;
    while let Some(b' ' | b'\t' | b'\r') = text.get(p) {
        p += 1;
    }
    (!required || p > start).then_some(p)
}

pub(super) const ONES: u64 = 0x0101_0101_0101_0101;

/// The decimal integer at `text[p..]` (1 to 19 digits, not followed by another digit) and the
/// position after it. Reads 8 digits at a time (SWAR) where 8 bytes are available.
#[inline(always)]
pub(super) fn leading_digits(text: &[u8], p: usize) -> Option<(usize, usize)> {
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
pub(super) fn slow_entry(
    line: &[u8],
    number: usize,
    h: &Header,
    path: &Path,
) -> Result<Option<(usize, usize, f64)>> {
    let mut tokens = words(line);
    let Some(t_row) = tokens.next() else {
        return Ok(None);
    };
    let t_col = tokens.next();
    let t_val = tokens.next();
    let extra = tokens.next();
    let (Some(t_col), Some(t_val), None) = (t_col, t_val, extra) else {
        return Err(Error::parse(
            path,
            number,
            format!(
                "wrong number of tokens: expected 3 (row column value), found {} in `{}`",
                words(line).count(),
                show(line)
            ),
        ));
    };
    let row = parse_index(t_row, "row", h.nrows, number, path)?;
    let col = parse_index(t_col, "column", h.ncols, number, path)?;
    let val = parse_value(t_val, number, path)?;
    Ok(Some((row, col, val)))
}

/// A finite real value ([`finite_f64`]).
pub(super) fn parse_value(tok: &[u8], number: usize, path: &Path) -> Result<f64> {
    finite_f64(tok).map_err(|bad| {
        let msg = match bad {
            BadNumber::NotFinite => format!(
                "value `{}` is not finite (NaN and Inf are not allowed)",
                show(tok)
            ),
            BadNumber::NotANumber => {
                format!("unparsable value `{}`: expected a real number", show(tok))
            }
        };
        Error::parse(path, number, msg)
    })
}

/// A 1-based index in `1..=n`.
#[inline(always)]
pub(super) fn parse_index(
    tok: &[u8],
    what: &str,
    n: usize,
    line: usize,
    path: &Path,
) -> Result<usize> {
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

pub(super) fn too_large(path: &Path, h: &Header, what: &str) -> Error {
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
pub(super) fn try_filled<T: Clone>(
    n: usize,
    value: T,
    path: &Path,
    h: &Header,
    what: &str,
) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(n)
        .map_err(|_| too_large(path, h, what))?;
    v.resize(n, value);
    Ok(v)
}

/// Assembles the canonical CSC matrix from the entries (in file order), mirroring off-diagonal
/// entries of a symmetric file and summing duplicates.
///
/// This mirrors while it scatters, as [`crate::sparse::Scatter`] does, but on its own
/// arrays: the entries come as unsorted chunks (either triangle, duplicates, 32-bit indices)
/// that are freed one by one as they are scattered, and every allocation is fallible (a
/// too-large declared size is an error, not an abort), where `Scatter` allocates as the
/// crate's other arrays do.
pub(super) fn build_csc<I: Ix>(
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
pub(super) fn sort_columns(col_ptr: &[usize], row_idx: &mut [usize], val: &mut [f64]) -> bool {
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
pub(super) fn sum_duplicates(
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
