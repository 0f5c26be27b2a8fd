//! The text toolkit of the readers (docs/design.md §4): lines, tokens and numbers of text
//! files and the parallel line parser, shared by Matrix Market ([`super::matrix_market`]) and
//! the importers ([`super::import`]).
//!
//! * **Lines** end in `\n`. [`line_at`] and [`Lines`] give a line of a buffer without its `\n`
//!   (a `\r` before it stays: Matrix Market's tokens treat it as a blank);
//!   [`for_each_line`] and [`par_lines`] read a file and give each line without `\r\n` or `\n`.
//! * **Tokens** are the maximal runs of bytes that are not separators ([`Tokens`]):
//!   [`words`] separates at blanks (space, tab, `\r`, vertical tab, form feed: Matrix Market),
//!   [`fields`] at spaces, tabs and commas (the free-format lines of the FE codes' files).
//! * **Numbers**: [`finite_f64`] (`fast-float2`, finite values only) under the readers' own
//!   messages, [`parse_f64`] and [`parse_u64`] with the importers' messages, [`parse_usize`]
//!   for Matrix Market's sizes and indices.
//! * **Parallel parsing** cuts a buffer at line ends into pieces ([`split_at_lines`]) that the
//!   rayon pool parses, the results in text order ([`par_pieces`]); [`par_lines`] does this
//!   for a file read in blocks, with every line's 1-based number.

use crate::{Error, Result};
use rayon::prelude::*;
use std::io::Read;
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Lines

/// The line starting at `pos` (without its `\n`) and the position after it.
#[inline]
pub(crate) fn line_at(text: &[u8], pos: usize) -> (&[u8], usize) {
    let rest = text.get(pos..).unwrap_or(&[]);
    match memchr::memchr(b'\n', rest) {
        Some(k) => (&rest[..k], pos + k + 1),
        None => (rest, text.len()),
    }
}

/// The lines of a buffer (each without its `\n`, [`line_at`]) with their 1-based numbers,
/// counted from the number given to [`Lines::new`].
pub(crate) struct Lines<'a> {
    buf: &'a [u8],
    pos: usize,
    next_line: usize,
}

impl<'a> Lines<'a> {
    /// The lines of `buf`, the first numbered `first_line`.
    pub(crate) fn new(buf: &'a [u8], first_line: usize) -> Self {
        Lines {
            buf,
            pos: 0,
            next_line: first_line,
        }
    }

    /// Byte offset of the next line in the buffer (its length once all lines are read).
    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    /// The number the next line gets (one past the last line read).
    pub(crate) fn next_line(&self) -> usize {
        self.next_line
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (usize, &'a [u8]);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.pos >= self.buf.len() {
            return None;
        }
        let (line, next) = line_at(self.buf, self.pos);
        self.pos = next;
        let number = self.next_line;
        self.next_line += 1;
        Some((number, line))
    }
}

/// The first line of `head` that is not blank, trimmed (lossy UTF-8; empty if there is none):
/// what the content sniffing of the text formats looks at.
pub(crate) fn first_nonblank_line(head: &[u8]) -> String {
    String::from_utf8_lossy(head)
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("")
        .to_string()
}

/// Calls `f(line_number, line)` for every line of a text file (1-based numbers, `\r\n` and
/// `\n` endings, the line without its ending), reading 1 MiB blocks: the file is never held
/// whole in memory.
///
/// # Errors
/// [`Error::Io`], or the first error `f` returns.
pub(crate) fn for_each_line(
    path: &Path,
    mut f: impl FnMut(usize, &[u8]) -> Result<()>,
) -> Result<()> {
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut buf = vec![0u8; 1 << 20];
    let (mut start, mut end, mut line) = (0usize, 0usize, 0usize);
    let trim = |l: &[u8]| -> usize { l.len() - usize::from(l.last() == Some(&b'\r')) };
    loop {
        if start > 0 {
            buf.copy_within(start..end, 0);
            end -= start;
            start = 0;
        }
        if end == buf.len() {
            buf.resize(2 * buf.len(), 0);
        }
        let got = file.read(&mut buf[end..]).map_err(|e| Error::io(path, e))?;
        if got == 0 {
            if end > start {
                let l = &buf[start..end];
                f(line + 1, &l[..trim(l)])?;
            }
            return Ok(());
        }
        end += got;
        let mut pos = start;
        for nl in memchr::memchr_iter(b'\n', &buf[start..end]) {
            let l = &buf[pos..start + nl];
            pos = start + nl + 1;
            line += 1;
            f(line, &l[..trim(l)])?;
        }
        start = pos;
    }
}

// ---------------------------------------------------------------------------------------------
// Tokens

/// A Matrix Market blank: space, tab, `\r`, vertical tab or form feed.
#[inline(always)]
pub(crate) fn is_blank(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// The tokens of a line: the maximal runs of bytes for which `is_sep` is false, in order.
#[derive(Clone)]
pub(crate) struct Tokens<'a, S> {
    line: &'a [u8],
    pos: usize,
    is_sep: S,
}

impl<'a, S: Fn(u8) -> bool> Iterator for Tokens<'a, S> {
    type Item = &'a [u8];

    #[inline(always)]
    fn next(&mut self) -> Option<&'a [u8]> {
        let line = self.line;
        let mut i = self.pos;
        while i < line.len() && (self.is_sep)(line[i]) {
            i += 1;
        }
        if i >= line.len() {
            self.pos = i;
            return None;
        }
        let start = i;
        while i < line.len() && !(self.is_sep)(line[i]) {
            i += 1;
        }
        self.pos = i;
        Some(&line[start..i])
    }
}

/// The tokens of a line separated by blanks ([`is_blank`]): Matrix Market's banner, size line
/// and entries.
#[inline(always)]
pub(crate) fn words(line: &[u8]) -> Tokens<'_, impl Fn(u8) -> bool> {
    Tokens {
        line,
        pos: 0,
        is_sep: is_blank,
    }
}

/// The fields of a free-format line, separated by spaces, tabs and commas (Abaqus matrices and
/// decks, DoF maps).
#[inline(always)]
pub(crate) fn fields(line: &[u8]) -> Tokens<'_, impl Fn(u8) -> bool> {
    Tokens {
        line,
        pos: 0,
        is_sep: |b| matches!(b, b' ' | b'\t' | b','),
    }
}

/// The first `K` tokens of a line and how many it has, without allocating (this runs per line).
pub(crate) fn first_fields<'a, const K: usize>(
    tokens: impl Iterator<Item = &'a [u8]>,
) -> ([&'a [u8]; K], usize) {
    let mut f: [&[u8]; K] = [&[]; K];
    let mut count = 0;
    for x in tokens {
        if count < K {
            f[count] = x;
        }
        count += 1;
    }
    (f, count)
}

/// A token for an importer's error message (at most 40 characters).
pub(crate) fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.into_owned()
    }
}

// ---------------------------------------------------------------------------------------------
// Numbers

/// Why a token is not a finite `f64`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BadNumber {
    /// A number, but NaN or ±Inf (also a literal that overflows, such as `1e400`).
    NotFinite,
    /// Not a number.
    NotANumber,
}

/// A finite `f64` token (decimal or exponent notation, parsed by `fast-float2`, correctly
/// rounded).
#[inline(always)]
pub(crate) fn finite_f64(tok: &[u8]) -> std::result::Result<f64, BadNumber> {
    match fast_float2::parse::<f64, _>(tok) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(BadNumber::NotFinite),
        Err(_) => Err(BadNumber::NotANumber),
    }
}

/// A finite `f64` token of an imported file ([`finite_f64`]); `what` names it in the error.
pub(crate) fn parse_f64(tok: &[u8], path: &Path, line: usize, what: &str) -> Result<f64> {
    finite_f64(tok).map_err(|bad| {
        let why = match bad {
            BadNumber::NotFinite => "is not finite",
            BadNumber::NotANumber => "is not a number",
        };
        Error::parse(path, line, format!("{what} '{}' {why}", show(tok)))
    })
}

/// A positive integer token of an imported file (an index or a node number; at most 19
/// digits, an optional `+`); `what` names it in the error.
pub(crate) fn parse_u64(tok: &[u8], path: &Path, line: usize, what: &str) -> Result<u64> {
    let digits = tok.strip_prefix(b"+").unwrap_or(tok);
    // 19 digits always fit in a u64.
    let ok = !digits.is_empty() && digits.len() <= 19 && digits.iter().all(u8::is_ascii_digit);
    let v = digits.iter().fold(0u64, |v, &b| {
        v.wrapping_mul(10)
            .wrapping_add(u64::from(b.wrapping_sub(b'0')))
    });
    if ok && v > 0 {
        Ok(v)
    } else {
        Err(Error::parse(
            path,
            line,
            format!("{what} '{}' is not a positive whole number", show(tok)),
        ))
    }
}

/// A non-negative decimal integer (digits only, no sign), or `None` if malformed or above
/// `usize::MAX`.
#[inline(always)]
pub(crate) fn parse_usize(tok: &[u8]) -> Option<usize> {
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

// ---------------------------------------------------------------------------------------------
// Parallel parsing

/// Splits `body` into about `pieces` ranges that end just after a newline (the last one at the
/// end of `body`).
pub(crate) fn split_at_lines(body: &[u8], pieces: usize) -> Vec<std::ops::Range<usize>> {
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

/// `f(k, piece)` for every piece `k` of `text` cut at line ends into about `pieces` pieces
/// ([`split_at_lines`]), on the rayon pool; the results in text order. The cut depends only
/// on `text` and `pieces`, so two calls with both equal see the same pieces.
pub(crate) fn par_pieces<R: Send>(
    text: &[u8],
    pieces: usize,
    f: impl Fn(usize, &[u8]) -> R + Sync,
) -> Vec<R> {
    split_at_lines(text, pieces)
        .into_par_iter()
        .enumerate()
        .map(|(k, r)| f(k, &text[r]))
        .collect()
}

/// Bytes of text [`par_lines`] parses per block (the file is read block by block).
const PAR_BLOCK: usize = 32 << 20;

/// Parses every line of a text file on the rayon pool and hands the results to `consume` in
/// file order: `parse(line_number, line)` (1-based, the line without `\r\n`/`\n`) runs in
/// parallel and may skip a line (`None`); `consume(line_number, item)` runs on the calling
/// thread. The file is read in blocks of [`PAR_BLOCK`] bytes (never whole); each block's
/// complete lines are cut into pieces ([`par_pieces`]) whose newlines are counted in parallel,
/// giving each piece its first line number, and the pieces are parsed in parallel. For a file
/// of one block or less the buffer is the file's size.
///
/// # Errors
/// [`Error::Io`], or the first error in file order that `parse` or `consume` returns (within a
/// piece, a `parse` error comes before the `consume` errors of that piece's earlier lines).
pub(crate) fn par_lines<T: Send>(
    path: &Path,
    parse: impl Fn(usize, &[u8]) -> Result<Option<T>> + Sync,
    consume: impl FnMut(usize, T) -> Result<()>,
) -> Result<()> {
    par_lines_in_blocks(path, PAR_BLOCK, parse, consume)
}

/// [`par_lines`] with blocks of `block` bytes.
fn par_lines_in_blocks<T: Send>(
    path: &Path,
    block: usize,
    parse: impl Fn(usize, &[u8]) -> Result<Option<T>> + Sync,
    mut consume: impl FnMut(usize, T) -> Result<()>,
) -> Result<()> {
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let size = file.metadata().map_err(|e| Error::io(path, e))?.len();
    let mut buf = vec![0u8; usize::try_from(size).unwrap_or(block).clamp(1, block)];
    let (mut end, mut line, mut eof) = (0usize, 0usize, false);
    let pieces = 4 * rayon::current_num_threads();
    while !eof {
        while end < buf.len() {
            let got = file.read(&mut buf[end..]).map_err(|e| Error::io(path, e))?;
            if got == 0 {
                eof = true;
                break;
            }
            end += got;
        }
        // the complete lines of this block; a line longer than the buffer grows it
        let complete = if eof {
            end
        } else {
            match memchr::memrchr(b'\n', &buf[..end]) {
                Some(i) => i + 1,
                None => {
                    buf.resize(2 * buf.len(), 0);
                    continue;
                }
            }
        };
        let text = &buf[..complete];
        let newlines = par_pieces(text, pieces, |_, piece| {
            memchr::memchr_iter(b'\n', piece).count()
        });
        let firsts: Vec<usize> = newlines
            .iter()
            .scan(line, |l, n| {
                let first = *l;
                *l += n;
                Some(first)
            })
            .collect();
        let parsed: Vec<Result<Vec<(usize, T)>>> = par_pieces(text, pieces, |k, piece| {
            let mut out = Vec::new();
            for (n, l) in Lines::new(piece, firsts[k] + 1) {
                let l = l.strip_suffix(b"\r").unwrap_or(l);
                if let Some(item) = parse(n, l)? {
                    out.push((n, item));
                }
            }
            Ok(out)
        });
        for piece in parsed {
            for (l, item) in piece? {
                consume(l, item)?;
            }
        }
        line += newlines.iter().sum::<usize>();
        buf.copy_within(complete..end, 0);
        end -= complete;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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

    /// Every line, with its number, in file order, for blocks from smaller than a line to
    /// larger than the file, with `\r\n` endings, empty lines and no final newline.
    #[test]
    fn par_lines_sees_every_line_once_in_order_with_its_number() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.txt");
        let mut text = String::new();
        let mut want = Vec::new();
        for i in 0..500usize {
            let l = match i % 7 {
                0 => String::new(),
                3 => "x".repeat(40 + i % 13),
                _ => format!("{i} {}", i * i),
            };
            text.push_str(&l);
            text.push_str(if i % 5 == 0 { "\r\n" } else { "\n" });
            want.push((i + 1, l));
        }
        text.push_str("last");
        want.push((501, "last".to_string()));
        std::fs::write(&path, &text).unwrap();
        for block in [1, 5, 64, 1000, 1 << 20] {
            let mut got = Vec::new();
            par_lines_in_blocks(
                &path,
                block,
                |n, l| Ok(Some((n, String::from_utf8(l.to_vec()).unwrap()))),
                |n, (m, l)| {
                    assert_eq!(n, m);
                    got.push((n, l));
                    Ok(())
                },
            )
            .unwrap();
            assert_eq!(got, want, "block {block}");
            // the first error in file order wins
            let err = par_lines_in_blocks(
                &path,
                block,
                |n, _| match n % 97 {
                    0 => Err(Error::parse(&path, n, "bad")),
                    _ => Ok(Some(())),
                },
                |_, ()| Ok(()),
            )
            .unwrap_err();
            assert!(matches!(err, Error::Parse { line: 97, .. }), "{err:?}");
        }
    }

    /// [`words`] and [`fields`] give the maximal runs between their separators.
    #[test]
    fn tokens_split_at_their_separators() {
        let w: Vec<&[u8]> = words(b" 1\t2\r\x0b3,4\x0c ").collect();
        assert_eq!(w, [&b"1"[..], b"2", b"3,4"]);
        let f: Vec<&[u8]> = fields(b",1, 2\t3,,4\r ").collect();
        assert_eq!(f, [&b"1"[..], b"2", b"3", b"4\r"]);
        assert_eq!(words(b"").count(), 0);
        assert_eq!(fields(b" ,\t").count(), 0);
    }

    #[test]
    fn integers() {
        let p = Path::new("t");
        assert_eq!(parse_u64(b"17", p, 1, "n").unwrap(), 17);
        assert_eq!(parse_u64(b"+3", p, 1, "n").unwrap(), 3);
        for bad in [&b"0"[..], b"-1", b"1.5", b"", b"99999999999999999999999"] {
            assert!(parse_u64(bad, p, 1, "n").is_err(), "{bad:?}");
        }
        assert_eq!(parse_usize(b"18446744073709551615"), Some(usize::MAX));
        assert_eq!(parse_usize(b"18446744073709551616"), None);
        assert_eq!(parse_usize(b"+1"), None);
    }

    #[test]
    fn finite_numbers() {
        assert_eq!(finite_f64(b"-2.5e3"), Ok(-2500.0));
        assert_eq!(finite_f64(b"1e400"), Err(BadNumber::NotFinite));
        assert_eq!(finite_f64(b"nan"), Err(BadNumber::NotFinite));
        assert_eq!(finite_f64(b"1.5x"), Err(BadNumber::NotANumber));
    }
}
