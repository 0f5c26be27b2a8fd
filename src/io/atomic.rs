//! Atomic writes of files ([`write_file`], [`write_bytes`]) and directories ([`write_dir`]):
//! the result is built under a temporary name next to its target and renamed into place only
//! when it is complete, so an interrupted or failed write never leaves a half file or a
//! directory that looks complete. On error the temporary is removed and the target is left as
//! it was; errors name the file that failed.
//!
//! No `fsync`: the rename protects against a half result from a failed or interrupted write,
//! not against a power loss.

use crate::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes through `body` into `<path>.tmp` (buffered), then renames it to `path`, replacing
/// an existing file.
///
/// # Errors
/// [`Error::Io`] naming `<path>.tmp` when creating or writing it fails (including `body`'s
/// errors), naming `path` when the rename fails.
pub fn write_file(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<()> {
    let tmp = tmp_path(path);
    let file = File::create(&tmp).map_err(|e| Error::io(&tmp, e))?;
    let mut w = BufWriter::with_capacity(1 << 20, file);
    let written = body(&mut w).and_then(|()| w.flush());
    let result = match written {
        Ok(()) => match w.into_inner() {
            Ok(file) => {
                drop(file);
                std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
            }
            Err(e) => Err(Error::io(&tmp, e.into_error())),
        },
        Err(e) => {
            drop(w);
            Err(Error::io(&tmp, e))
        }
    };
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// [`write_file`] with the whole content at hand.
///
/// # Errors
/// As [`write_file`].
pub fn write_bytes(path: &Path, contents: impl AsRef<[u8]>) -> Result<()> {
    write_file(path, |w| w.write_all(contents.as_ref()))
}

/// Creates `dir` by filling a temporary sibling `.<name>.tmp-<pid>` with `fill` and renaming
/// it; an existing empty `dir` is replaced. On any error the temporary directory is removed
/// and `dir` is left as it was.
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty; `fill`'s errors; I/O errors.
pub fn write_dir(dir: &Path, fill: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    check_dir_free(dir)?;
    let name = dir
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp: PathBuf = dir.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(|e| Error::io(&tmp, e))?;
    let result = fill(&tmp).and_then(|_| {
        if dir.exists() {
            std::fs::remove_dir(dir).map_err(|e| Error::io(dir, e))?;
        }
        std::fs::rename(&tmp, dir).map_err(|e| Error::io(dir, e))
    });
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

/// The check [`write_dir`] makes first, for callers to make before long work: `dir` must not
/// exist or be empty.
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty.
pub fn check_dir_free(dir: &Path) -> Result<()> {
    if let Ok(mut it) = std::fs::read_dir(dir) {
        if it.next().is_some() {
            return Err(Error::InvalidSetting(format!(
                "{} exists and is not empty: remove it or choose another output directory",
                dir.display()
            )));
        }
    }
    Ok(())
}

/// `<path>.tmp`, next to `path`.
fn tmp_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".tmp");
    PathBuf::from(s)
}
