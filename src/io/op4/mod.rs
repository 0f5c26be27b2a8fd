//! Nastran OUTPUT4 (OP4) matrix files (docs/design.md §3.9, §4): read by [`read_op4`] (the
//! Nastran model import, [`crate::io::import::nastran`], is built on it), written by
//! [`append`] and [`write`] in every encoding and column layout the reader reads, and the
//! ROM's `rom.op4` ([`write_rom`]).
//!
//! # The format
//! Written by the DMAP module `OUTPUT4` of MSC and NX Nastran (MSC Nastran DMAP Programmer's
//! Guide / NX Nastran DMAP Programmer's Guide, "OUTPUT4"); the layout below was checked
//! against the public OP4 reader and writer of pyNastran (`pyNastran/op4/op4.py`, version
//! 1.4.1), whose files the tests read back. A file holds one or more matrices, one after the
//! other. Each matrix is
//!
//! 1. a **header**: `NCOL NROW NF NTYPE NAME` — columns, rows (negative: the BIGMAT layout,
//!    also used whenever NROW > 65535), the form `NF` (1 square, 2 rectangular/general,
//!    6 symmetric, ...), the type `NTYPE` (1 real single, 2 real double, 3 complex single,
//!    4 complex double) and an 8-character name;
//! 2. **column records** `ICOL IROW NW` followed by data. `ICOL` is the 1-based column. With
//!    `IROW > 0` the record is *dense*: `NW` words holding consecutive values from row `IROW`
//!    on (a real double is 2 words, a real single 1). With `IROW = 0` the record is *sparse*
//!    ("string" format): `NW` words of strings, each a string header followed by its values.
//!    A string header is one word `IS = IROW + 65536·(L+1)` (L = words of values), or, in
//!    the BIGMAT layout, two words `L+1, IROW`. Null columns are not written;
//! 3. an **end record** with `ICOL = NCOL+1` (`IROW = 1`, one dummy value).
//!
//! **Binary** files are Fortran unformatted sequential files: every header and column record
//! is framed by a 4-byte length marker before and after it, in the byte order of the machine
//! that wrote it. The header record is 24 bytes (4 integers and 8 characters); its first
//! marker, 24, tells the byte order. Files with 8-byte integers (a 48-byte header) are
//! refused.
//!
//! **ASCII** (formatted) files write the header as `4I8, 2A4` followed by the Fortran format
//! of the values (`1P,3E23.16`: 3 values a line, 23 characters each; `1P,5E16.9` for single
//! precision), then each column record as a line of 3 integers, string headers as a line of
//! 1 (or, BIGMAT, 2) integers, and the values in fixed-width fields.
//!
//! # Files
//! `format` holds what reader and writer share (the [`Encoding`], the string-header word);
//! `reader` and `writer` read and write plain matrices (the model layer: the import reads
//! with them); `rom` writes a ROM (the output layer: it needs [`crate::reduce::Rom`]). This
//! file only declares and re-exports.

mod format;
mod reader;
mod rom;
mod writer;

pub use format::Encoding;
pub(crate) use reader::looks_like_op4;
pub use reader::{read_op4, read_op4_keeping, Location, Op4Matrix};
pub use rom::{write_rom, ROM_FILE, ROM_MATRICES};
pub use writer::{append, columns_of_csc, columns_of_dense, write, Layout, Matrix};
