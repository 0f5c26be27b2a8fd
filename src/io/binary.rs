//! A binary file read record by record (ANSYS `.full`, Nastran OP4 binary): the position, the
//! length and the byte order, reads that turn an early end of file into an error naming what
//! was being read, and errors that name the byte offset. Each format frames its records
//! itself on top of it.

use crate::{Error, Result};
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// The 32-bit word of the first four bytes of `b` in the byte order `big_endian` says (also
/// for a file's head, before it is opened as a [`BinaryFile`]). The caller guarantees
/// `b.len() >= 4`.
pub(crate) fn word(b: &[u8], big_endian: bool) -> u32 {
    let w = [b[0], b[1], b[2], b[3]];
    if big_endian {
        u32::from_be_bytes(w)
    } else {
        u32::from_le_bytes(w)
    }
}

pub(crate) struct BinaryFile {
    file: BufReader<File>,
    path: PathBuf,
    /// File length in bytes.
    pub(crate) len: u64,
    /// Byte offset of the next read (kept by the record readers).
    pub(crate) pos: u64,
    pub(crate) big_endian: bool,
}

impl BinaryFile {
    /// Opens `path` at byte 0.
    pub(crate) fn open(path: &Path, big_endian: bool) -> Result<Self> {
        let file = File::open(path).map_err(|e| Error::io(path, e))?;
        let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
        Ok(BinaryFile {
            file: BufReader::with_capacity(1 << 16, file),
            path: path.to_path_buf(),
            len,
            pos: 0,
            big_endian,
        })
    }

    /// A parse error at byte `at`.
    pub(crate) fn error(&self, at: u64, msg: impl std::fmt::Display) -> Error {
        Error::parse(&self.path, 0, format!("byte {at}: {msg}"))
    }

    /// The 32-bit word of the first four bytes of `b` in the file's byte order.
    pub(crate) fn word(&self, b: &[u8]) -> u32 {
        word(b, self.big_endian)
    }

    /// Fills `buf` from the current file position; an early end is an error at `at` naming
    /// `what`. Does not move [`Self::pos`].
    pub(crate) fn read_exact(&mut self, buf: &mut [u8], at: u64, what: &str) -> Result<()> {
        self.file.read_exact(buf).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                self.error(at, format!("the file ends inside {what} (truncated file?)"))
            } else {
                Error::io(&self.path, e)
            }
        })
    }

    /// Moves the file and [`Self::pos`] to byte `at` (< [`Self::len`], checked by the caller).
    pub(crate) fn seek(&mut self, at: u64) -> Result<()> {
        self.file
            .seek(SeekFrom::Start(at))
            .map_err(|e| Error::io(&self.path, e))?;
        self.pos = at;
        Ok(())
    }
}
