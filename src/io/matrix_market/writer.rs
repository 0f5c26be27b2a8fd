//! Writing Matrix Market files (see the [parent module](super), "Writing").

use std::io::Write;
use std::path::Path;

use faer::sparse::SparseColMatRef;
use faer::MatRef;

use crate::error::{Error, Result};
use crate::io::atomic;

/// Writes `a` as a `coordinate real` Matrix Market file.
///
/// With `symmetric == false` every stored entry is written (`general`). With
/// `symmetric == true` the header says `symmetric` and only the stored entries of the lower
/// triangle (row >= column) are written; the caller guarantees that `a` is symmetric (only
/// squareness is checked). Entries are written column by column in storage order, with 1-based
/// indices and shortest round-trip values, so [`read_sparse`](super::read_sparse) returns the same matrix
/// bit-exactly (for a canonical `a`). The file is written to `<path>.tmp` and then renamed.
pub fn write_coordinate(
    path: &Path,
    a: SparseColMatRef<'_, usize, f64>,
    symmetric: bool,
) -> Result<()> {
    let (m, n) = (a.nrows(), a.ncols());
    if symmetric && m != n {
        return Err(Error::InvalidModel(format!(
            "cannot write {} as a symmetric Matrix Market file: the matrix is {m}x{n}, not square",
            path.display()
        )));
    }
    let mut nnz = 0usize;
    for j in 0..n {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            if symmetric && i < j {
                continue;
            }
            if !v.is_finite() {
                return Err(non_finite_write(path, i, j, v));
            }
            nnz += 1;
        }
    }
    let kind = if symmetric { "symmetric" } else { "general" };
    atomic::write_file(path, |w| {
        writeln!(w, "%%MatrixMarket matrix coordinate real {kind}")?;
        writeln!(w, "{m} {n} {nnz}")?;
        let mut line = Vec::with_capacity(64);
        for j in 0..n {
            for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
                if symmetric && i < j {
                    continue;
                }
                line.clear();
                push_usize(&mut line, i + 1);
                line.push(b' ');
                push_usize(&mut line, j + 1);
                line.push(b' ');
                push_f64(&mut line, v);
                line.push(b'\n');
                w.write_all(&line)?;
            }
        }
        Ok(())
    })
}

/// Writes `a` as an `array real general` Matrix Market file, column-major, one value per line,
/// in shortest round-trip form (so [`read_dense`](super::read_dense) returns `a` bit-exactly). The file is written
/// to `<path>.tmp` and then renamed.
pub fn write_array(path: &Path, a: MatRef<'_, f64>) -> Result<()> {
    let (m, n) = (a.nrows(), a.ncols());
    for j in 0..n {
        for i in 0..m {
            let v = a[(i, j)];
            if !v.is_finite() {
                return Err(non_finite_write(path, i, j, v));
            }
        }
    }
    atomic::write_file(path, |w| {
        writeln!(w, "%%MatrixMarket matrix array real general")?;
        writeln!(w, "{m} {n}")?;
        let mut line = Vec::with_capacity(32);
        for j in 0..n {
            for i in 0..m {
                line.clear();
                push_f64(&mut line, a[(i, j)]);
                line.push(b'\n');
                w.write_all(&line)?;
            }
        }
        Ok(())
    })
}

// ---------------------------------------------------------------------------------------------
// Writing helpers

fn non_finite_write(path: &Path, i: usize, j: usize, v: f64) -> Error {
    Error::InvalidModel(format!(
        "cannot write {}: entry ({}, {}) is {v}; Matrix Market files must hold finite values",
        path.display(),
        i + 1,
        j + 1
    ))
}

/// Appends the decimal digits of `x`.
fn push_usize(out: &mut Vec<u8>, mut x: usize) {
    let mut buf = [0u8; 20];
    let mut k = buf.len();
    loop {
        k -= 1;
        buf[k] = b'0' + (x % 10) as u8;
        x /= 10;
        if x == 0 {
            break;
        }
    }
    out.extend_from_slice(&buf[k..]);
}

/// Appends finite `v` in the shortest form that parses back to the same bits.
#[inline]
fn push_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(zmij::Buffer::new().format_finite(v).as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_helpers() {
        let mut v = Vec::new();
        push_usize(&mut v, 0);
        v.push(b' ');
        push_usize(&mut v, usize::MAX);
        v.push(b' ');
        push_f64(&mut v, -0.0);
        v.push(b' ');
        push_f64(&mut v, 1e-300);
        assert_eq!(
            String::from_utf8(v).unwrap(),
            format!("0 {} -0.0 1e-300", usize::MAX)
        );
    }
}
