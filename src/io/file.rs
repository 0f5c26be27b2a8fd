//! Reading the files a user names, safely: only regular files (after symlinks) are read, so a
//! name that points at a device such as `/dev/zero` (a file name in `model.toml`, say) is an
//! error instead of a read that allocates until the process is killed. The readers of the
//! model layer read whole files ([`read_regular`], [`read_regular_text`]), stream them after
//! [`check_regular`], or tell a file's format from its [`head`].

use crate::{Error, Result};
use std::io::Read;
use std::path::Path;

/// The bytes of `path`, which must be a regular file (after symlinks).
pub(crate) fn read_regular(path: &Path) -> Result<Vec<u8>> {
    check_regular(path)?;
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// Refuses anything but a regular file (after symlinks), as [`read_regular`] does, for the
/// readers that stream a file instead of reading it whole.
pub(crate) fn check_regular(path: &Path) -> Result<()> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::io(
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
pub(crate) fn head(path: &Path) -> Result<Vec<u8>> {
    check_regular(path)?;
    let mut head = Vec::with_capacity(4096);
    std::fs::File::open(path)
        .and_then(|f| f.take(4096).read_to_end(&mut head))
        .map_err(|e| Error::io(path, e))?;
    Ok(head)
}

/// [`read_regular`] as UTF-8 text.
pub(crate) fn read_regular_text(path: &Path) -> Result<String> {
    String::from_utf8(read_regular(path)?).map_err(|e| {
        Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e.utf8_error()),
        )
    })
}
