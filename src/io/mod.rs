//! File formats (docs/design.md §4): Matrix Market, the model directory, the ROM directory, the
//! importers of FE codes' files ([`import`]: ANSYS, Abaqus, Nastran OP4, Harwell–Boeing), the
//! ROM exports ([`exudyn`], [`op4`], [`dmig`], [`mbdyn`], [`sid`]); the
//! text toolkit their text readers share (`text`: lines, tokens, numbers, parallel line
//! parsing); and the atomic writes all writers (and the CLI's outputs) go through.

pub mod atomic;
mod binary;
pub mod dmig;
pub mod exudyn;
pub mod import;
pub mod matrix_market;
pub mod mbdyn;
pub mod model_dir;
pub mod npz;
pub mod op4;
pub mod rom_dir;
pub mod sid;
mod text;

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

/// The first 4 KiB of a file (all of a shorter one), which must be a regular file
/// ([`check_regular`]): what the importers tell a file's format from.
pub(crate) fn head(path: &std::path::Path) -> crate::Result<Vec<u8>> {
    use std::io::Read;
    check_regular(path)?;
    let mut head = Vec::with_capacity(4096);
    std::fs::File::open(path)
        .and_then(|f| f.take(4096).read_to_end(&mut head))
        .map_err(|e| crate::Error::io(path, e))?;
    Ok(head)
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
