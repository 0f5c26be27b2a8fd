//! The banner, the size line and the tokenizer shared by the entry readers.

use std::path::Path;

use super::Symmetry;
use crate::error::{Error, Result};

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

/// Iterates over the lines of `buf` (without their `\n`), with 1-based line numbers.
pub(super) struct Lines<'a> {
    pub(super) buf: &'a [u8],
    pub(super) pos: usize,
    pub(super) next_line: usize,
}

impl<'a> Lines<'a> {
    pub(super) fn new(buf: &'a [u8], first_line: usize) -> Self {
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
pub(super) fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// The next whitespace-separated token of `line` from `*pos`.
#[inline(always)]
pub(super) fn next_token<'a>(line: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
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

pub(super) fn count_tokens(line: &[u8]) -> usize {
    let mut pos = 0;
    let mut n = 0;
    while next_token(line, &mut pos).is_some() {
        n += 1;
    }
    n
}

pub(super) fn tokens(line: &[u8]) -> Vec<&[u8]> {
    let mut pos = 0;
    let mut out = Vec::new();
    while let Some(t) = next_token(line, &mut pos) {
        out.push(t);
    }
    out
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

/// A non-negative decimal integer (no sign), or `None` if malformed or too large.
#[inline(always)]
pub(super) fn parse_usize(tok: &[u8]) -> Option<usize> {
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
