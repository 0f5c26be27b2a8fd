//! Array (dense, column-major) values.

use std::path::Path;

use faer::Mat;

use super::coordinate::parse_value;
use super::header::{show, Header, Symmetry};
use crate::error::{Error, Result};
use crate::io::text::{words, Lines};

/// Largest dimension of an empty (0×n or n×0) array file.
pub(super) const MAX_EMPTY_DIM: usize = 1 << 20;

/// Whether a dense `nrows x ncols` matrix can be allocated (probed without touching memory).
/// faer pads columns and does work per column even when `nrows == 0`, hence the margins.
pub(super) fn dense_fits(nrows: usize, ncols: usize) -> bool {
    nrows
        .checked_next_multiple_of(16)
        .and_then(|r| r.max(16).checked_mul(ncols.max(1)))
        .is_some_and(|len| {
            len <= isize::MAX as usize / 8 && Vec::<f64>::new().try_reserve_exact(len).is_ok()
        })
}

pub(super) fn parse_array_body(body: &[u8], h: &Header, path: &Path) -> Result<Mat<f64>> {
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
        let mut tokens = words(line);
        let Some(tok) = tokens.next() else {
            continue;
        };
        if tokens.next().is_some() {
            return Err(Error::parse(
                path,
                number,
                format!(
                    "wrong number of tokens: an array file holds 1 value per line, found {} in `{}`",
                    words(line).count(),
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
            lines.next_line().saturating_sub(1).max(h.size_line),
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
