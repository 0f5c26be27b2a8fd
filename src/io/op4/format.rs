//! What the OP4 reader and writer share: the file encodings and the string-header word of the
//! sparse column records (layout: the module doc of [`crate::io::op4`]).

/// How an OP4 file is encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// Formatted text.
    Ascii,
    /// Fortran unformatted records, little-endian.
    BinaryLittleEndian,
    /// Fortran unformatted records, big-endian.
    BinaryBigEndian,
}

/// The most rows a one-word string header addresses; larger matrices use the BIGMAT layout
/// (a negative NROW and two-word string headers).
pub(super) const MAX_STRING_ROW: usize = 65535;

/// The one-word string header `IS = IROW + 65536·(L+1)` of a string of `words` (L) words
/// that starts at the 1-based row `row` (IROW).
pub(super) fn string_header(row: i64, words: i64) -> i64 {
    row + 65536 * (words + 1)
}

/// IROW and L of a one-word string header `IS` ([`string_header`] undone).
pub(super) fn split_string_header(is: i64) -> (i64, i64) {
    let l = is / 65536 - 1;
    (is - 65536 * (l + 1), l)
}
