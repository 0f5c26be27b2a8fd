//! File formats (docs/design.md §4): Matrix Market, Harwell–Boeing, the model directory, the ROM
//! directory, the importers of FE codes' files ([`import`]: ANSYS, Abaqus, Nastran OP4); and the
//! atomic writes all writers (and the CLI's outputs) go through.

pub mod abaqus;
pub mod ansys;
pub mod atomic;
mod binary;
pub mod exudyn;
pub mod harwell_boeing;
pub mod import;
pub mod matrix_market;
pub mod model_dir;
pub mod nastran;
pub mod npz;
pub mod rom_dir;

/// The bytes of `path`, which must be a regular file (after symlinks): a file name from
/// `model.toml` naming a device such as `/dev/zero` made the reader allocate until the
/// process was killed (found by the `model_dir` fuzz target's memory limit).
pub(crate) fn read_regular(path: &std::path::Path) -> crate::Result<Vec<u8>> {
    check_regular(path)?;
    std::fs::read(path).map_err(|e| crate::Error::io(path, e))
}

/// Refuses anything but a regular file (after symlinks), as [`read_regular`] does, for the
/// readers that stream a file instead of reading it whole.
pub(crate) fn check_regular(path: &std::path::Path) -> crate::Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| crate::Error::io(path, e))?;
    if !meta.is_file() {
        return Err(crate::Error::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "not a regular file (a directory, device or pipe); name a file",
            ),
        ));
    }
    Ok(())
}

/// The 32-bit word of the first four bytes of `b` in the file's byte order (the binary
/// readers: ANSYS `.full`, Nastran OP4). The caller guarantees `b.len() >= 4`.
pub(crate) fn word(b: &[u8], big_endian: bool) -> u32 {
    let w = [b[0], b[1], b[2], b[3]];
    if big_endian {
        u32::from_be_bytes(w)
    } else {
        u32::from_le_bytes(w)
    }
}

/// [`read_regular`] as UTF-8 text.
pub(crate) fn read_regular_text(path: &std::path::Path) -> crate::Result<String> {
    String::from_utf8(read_regular(path)?).map_err(|e| {
        crate::Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e.utf8_error()),
        )
    })
}

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
}
