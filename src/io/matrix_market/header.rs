//! The banner (with the [`Symmetry`] it declares), the size line, and how the entry readers
//! show a token in an error; tokens and lines come from [`crate::io::text`].

use std::path::Path;

use crate::error::{Error, Result};
use crate::io::text::{parse_usize, words, Lines};

/// The symmetry declared in a Matrix Market banner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// All entries are stored.
    General,
    /// One triangle is stored; the matrix equals its transpose.
    Symmetric,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Format {
    Coordinate,
    Array,
}

#[derive(Debug, Clone, Copy)]
pub(super) struct Header {
    pub(super) format: Format,
    pub(super) symmetry: Symmetry,
    pub(super) nrows: usize,
    pub(super) ncols: usize,
    /// Declared number of entries (coordinate only).
    pub(super) nnz: usize,
    /// 1-based line of the size line.
    pub(super) size_line: usize,
    /// Byte offset of the first line after the size line.
    pub(super) body_start: usize,
}

/// `bytes` for an error message: lossy UTF-8, cut to a readable length.
pub(super) fn show(bytes: &[u8]) -> String {
    const MAX: usize = 60;
    let s = String::from_utf8_lossy(&bytes[..bytes.len().min(MAX)]);
    if bytes.len() > MAX {
        format!("{s}...")
    } else {
        s.into_owned()
    }
}

pub(super) const BANNER_HELP: &str =
    "the first line must be `%%MatrixMarket matrix <format> <field> <symmetry>` \
     with format coordinate or array, field real, double or integer, symmetry general or symmetric";

pub(super) fn parse_header(bytes: &[u8], path: &Path) -> Result<Header> {
    let err = |line: usize, msg: String| Error::parse(path, line, msg);
    let mut lines = Lines::new(bytes, 1);
    let Some((_, first)) = lines.next() else {
        return Err(err(
            1,
            format!("empty file: missing the Matrix Market banner; {BANNER_HELP}"),
        ));
    };
    let banner: Vec<&[u8]> = words(first).collect();
    if !banner
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
    if banner.len() != 5 {
        return Err(err(
            1,
            format!(
                "bad banner `{}`: expected 5 words, found {}; {BANNER_HELP}",
                show(first),
                banner.len()
            ),
        ));
    }
    let lower = |w: &[u8]| show(w).to_ascii_lowercase();
    let (object, format, field, symmetry) = (
        lower(banner[1]),
        lower(banner[2]),
        lower(banner[3]),
        lower(banner[4]),
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
        match words(line).next() {
            None => continue,
            Some(t) if t.first() == Some(&b'%') => continue,
            Some(_) => break (number, line),
        }
    };
    let sizes: Vec<&[u8]> = words(size).collect();
    let (want, what) = match format {
        Format::Coordinate => (3, "`rows columns entries`"),
        Format::Array => (2, "`rows columns`"),
    };
    let numbers: Vec<Option<usize>> = sizes.iter().map(|w| parse_usize(w)).collect();
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
    if sizes.len() != want || numbers.iter().any(Option::is_none) {
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
        body_start: lines.pos(),
    })
}
