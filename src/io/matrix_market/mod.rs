//! Matrix Market (`.mtx`) reading and writing (docs/design.md §4).
//!
//! # What is read
//!
//! The banner must be the first line:
//! `%%MatrixMarket matrix <format> <field> <symmetry>` with
//!
//! * format `coordinate` (sparse triplets `row column value`, one per line) or `array`
//!   (dense, one value per line, column-major);
//! * field `real`, `double` or `integer` (integers are read as `f64`);
//! * symmetry `general` or `symmetric`.
//!
//! Fields `complex` and `pattern` and symmetries `hermitian` and `skew-symmetric` are rejected
//! with an error that says what is supported. The banner keywords are case-insensitive.
//! Comment lines (starting with `%`) and blank lines may stand between the banner and the size
//! line; blank lines between entries are tolerated. Lines may end in `\n` or `\r\n`; tokens are
//! separated by spaces or tabs.
//!
//! A file whose first two bytes are the gzip magic `1f 8b` is decompressed transparently,
//! whatever its name (`.mtx.gz` or not).
//!
//! # Conventions
//!
//! * **Symmetric files are expanded to full storage.** A `symmetric` coordinate file stores one
//!   triangle; every off-diagonal entry is mirrored, so the returned matrix holds both
//!   triangles. The spec asks for the lower triangle; a file holding only the upper triangle is
//!   accepted too, but a file mixing strictly-lower and strictly-upper entries is an error
//!   naming the first line of the second triangle. A `symmetric` array file holds the lower
//!   triangle column by column (the spec's layout); it is expanded the same way.
//!   [`MtxMatrix::symmetry`] still tells what the file declared.
//! * **Duplicate coordinate entries are summed** (the finite-element assembly convention, as in
//!   scipy), in file order. A mirrored entry is summed the same way, so the expansion of a
//!   symmetric file is exactly symmetric.
//! * Sparse results are in canonical CSC form: rows sorted within each column, no duplicates.
//!   Explicitly stored zeros of a coordinate file are kept.
//! * [`read_sparse`] of an array file keeps only the nonzero values; [`read_dense`] of a
//!   coordinate file scatters the (summed, expanded) entries into a dense matrix.
//! * Every value must be finite: NaN and Inf (also as the overflow of a too-large literal such as
//!   `1e400`, or of the sum of duplicate entries) are errors.
//!
//! # Errors
//!
//! Malformed files give [`Error::Parse`] naming the file and the 1-based line: a missing or bad
//! banner, an unsupported format/field/symmetry, a bad size line, a non-square symmetric matrix,
//! a line with the wrong number of tokens, an unparsable number, an index out of range (the
//! message gives the allowed 1-based range), a NaN or Inf value, entries from both triangles in
//! a symmetric file, too many entries (at the first line too many) and too few entries
//! (expected and found count, at the file's last line). Corrupt or truncated gzip data is an
//! [`Error::Parse`] on line 0. No input makes the reader panic; sizes that cannot be allocated
//! give an error, too.
//!
//! # Writing
//!
//! [`write_coordinate`] and [`write_array`] write `real` files with 1-based indices and each
//! value in its shortest round-trip form (the `zmij` formatter, successor of `ryu`: `-0.0`,
//! `1e-300`, `3027152.8056777236`, `1.2345678901234568e+17`), so that a written matrix reads
//! back bit-exactly (including `-0.0`, subnormals and extreme exponents). The file is written
//! atomically ([`super::atomic::write_file`]: `<path>.tmp`, renamed to `<path>` only when it is
//! complete; on error the temporary file is removed and `<path>` is untouched). Non-finite
//! values are refused with [`Error::InvalidModel`] before anything is written.
//!
//! # Performance
//!
//! The whole file is read into memory (decompressed if gzip). The entry section of a coordinate
//! file (from 1 MiB on, with more than one thread in the current rayon pool) is split at line
//! boundaries and parsed in parallel; the common line shape takes a fast path (8 digits at a
//! time for indices, `fast-float2` for values), anything else a general path with the precise
//! errors. Entries are kept with 32-bit indices when the dimensions allow. The CSC matrix is
//! assembled by counting per column, a prefix sum and a scatter, then sorting rows within
//! columns (skipped when already sorted, as in files written column- or row-major; parallel over
//! column blocks) and summing duplicates. Time and memory are O(file size + nnz + ncols);
//! each buffer is freed as soon as the next stage is done with it, so the peak is about
//! max(file + 16 bytes per entry, 16 bytes per entry + 16 bytes per stored nonzero) for
//! 32-bit-indexable sizes (e.g. 480 MB for a 314 MB file of 9.8e6 entries).
//! Array files are parsed on one thread (dense matrices are small in this crate's use).

mod array;
mod coordinate;
mod header;
mod writer;

pub use header::Symmetry;
pub use writer::{write_array, write_coordinate};

use std::io::Read;
use std::path::Path;

use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};
use faer::{Mat, MatRef};

use crate::error::{Error, Result};
use crate::io::file::read_regular;
use array::{dense_fits, parse_array_body};
use coordinate::{build_csc, parse_coordinate_body, Entry};
use header::{parse_header, Format, Header};

/// The values of a Matrix Market file, always in full storage (symmetric files expanded).
#[derive(Debug, Clone)]
pub enum MtxData {
    /// From a `coordinate` file: canonical CSC (rows sorted, no duplicates).
    Sparse(SparseColMat<usize, f64>),
    /// From an `array` file.
    Dense(Mat<f64>),
}

/// A matrix read from a Matrix Market file.
#[derive(Debug, Clone)]
pub struct MtxMatrix {
    /// The symmetry the file declared. [`MtxMatrix::data`] holds both triangles either way.
    pub symmetry: Symmetry,
    /// The values, in full storage.
    pub data: MtxData,
}

impl MtxMatrix {
    /// Number of rows.
    pub fn nrows(&self) -> usize {
        match &self.data {
            MtxData::Sparse(a) => a.nrows(),
            MtxData::Dense(a) => a.nrows(),
        }
    }

    /// Number of columns.
    pub fn ncols(&self) -> usize {
        match &self.data {
            MtxData::Sparse(a) => a.ncols(),
            MtxData::Dense(a) => a.ncols(),
        }
    }
}

/// Reads a Matrix Market file (coordinate or array; gzip-compressed or not).
///
/// Symmetric files are expanded to full storage; see the [module documentation](self) for the
/// accepted formats and the conventions.
pub fn read(path: &Path) -> Result<MtxMatrix> {
    let bytes = read_regular(path)?;
    // Each buffer is dropped as soon as the next stage no longer needs it, so the peak memory
    // is max(file + entries, entries + matrix), not their sum.
    let parsed = if bytes.starts_with(&GZIP_MAGIC) {
        let plain = gunzip(&bytes, path)?;
        drop(bytes);
        parse_plain(&plain, path)?
    } else {
        let parsed = parse_plain(&bytes, path)?;
        drop(bytes);
        parsed
    };
    parsed.finish(path)
}

/// Reads a Matrix Market file as a sparse matrix in canonical CSC form.
///
/// Symmetric files are expanded to full storage (both triangles), rows are sorted within each
/// column and duplicate entries are summed. An array file is converted, keeping its nonzero
/// values.
pub fn read_sparse(path: &Path) -> Result<SparseColMat<usize, f64>> {
    let m = read(path)?;
    Ok(match m.data {
        MtxData::Sparse(a) => a,
        MtxData::Dense(a) => dense_to_sparse(a.as_ref()),
    })
}

/// Reads a Matrix Market file as a dense matrix.
///
/// Symmetric files are expanded to full storage. A coordinate file is converted (duplicates
/// summed, missing entries zero); its declared size must fit in memory densely.
pub fn read_dense(path: &Path) -> Result<Mat<f64>> {
    let m = read(path)?;
    match m.data {
        MtxData::Dense(a) => Ok(a),
        MtxData::Sparse(a) => sparse_to_dense(a.as_ref(), path),
    }
}

/// Parses Matrix Market data already in memory (gzip-compressed or not).
///
/// `path` is used only to name the source in errors. Same rules as [`read`].
pub fn parse_bytes(bytes: &[u8], path: &Path) -> Result<MtxMatrix> {
    let parsed = if bytes.starts_with(&GZIP_MAGIC) {
        let plain = gunzip(bytes, path)?;
        parse_plain(&plain, path)?
    } else {
        parse_plain(bytes, path)?
    };
    parsed.finish(path)
}

const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

fn gunzip(data: &[u8], path: &Path) -> Result<Vec<u8>> {
    // The gzip trailer holds the uncompressed size mod 2^32: a good capacity hint for files
    // under 4 GiB, and harmless otherwise (the vector grows).
    let hint = match data.len().checked_sub(4).and_then(|k| data.get(k..)) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]) as usize,
        _ => 0,
    };
    let mut out = Vec::new();
    let _ = out.try_reserve_exact(hint.min(data.len().saturating_mul(64)).saturating_add(1));
    flate2::read::MultiGzDecoder::new(data)
        .read_to_end(&mut out)
        .map_err(|e| {
            Error::parse(
                path,
                0,
                format!("corrupt or truncated gzip data ({e}); the file starts with the gzip magic bytes 1f 8b but cannot be decompressed"),
            )
        })?;
    Ok(out)
}

/// A parsed file that no longer needs the text.
enum Parsed {
    /// Coordinate entries with 32-bit indices (when the dimensions allow: half the memory).
    Coord32(Header, Vec<Vec<Entry<u32>>>),
    /// Coordinate entries with full-width indices.
    Coord64(Header, Vec<Vec<Entry<usize>>>),
    /// An array file.
    Dense(Header, Mat<f64>),
}

impl Parsed {
    /// Assembles the matrix.
    fn finish(self, path: &Path) -> Result<MtxMatrix> {
        let (h, data) = match self {
            Parsed::Coord32(h, chunks) => (h, MtxData::Sparse(build_csc(&h, chunks, path)?)),
            Parsed::Coord64(h, chunks) => (h, MtxData::Sparse(build_csc(&h, chunks, path)?)),
            Parsed::Dense(h, m) => (h, MtxData::Dense(m)),
        };
        Ok(MtxMatrix {
            symmetry: h.symmetry,
            data,
        })
    }
}

fn parse_plain(bytes: &[u8], path: &Path) -> Result<Parsed> {
    let h = parse_header(bytes, path)?;
    let body = bytes.get(h.body_start..).unwrap_or(&[]);
    Ok(match h.format {
        Format::Coordinate if h.nrows.max(h.ncols) <= u32::MAX as usize => {
            Parsed::Coord32(h, parse_coordinate_body(body, &h, path)?)
        }
        Format::Coordinate => Parsed::Coord64(h, parse_coordinate_body(body, &h, path)?),
        Format::Array => Parsed::Dense(h, parse_array_body(body, &h, path)?),
    })
}

// ---------------------------------------------------------------------------------------------
// Conversions

fn dense_to_sparse(a: MatRef<'_, f64>) -> SparseColMat<usize, f64> {
    let (m, n) = (a.nrows(), a.ncols());
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::new();
    let mut val = Vec::new();
    col_ptr.push(0);
    for j in 0..n {
        for i in 0..m {
            let v = a[(i, j)];
            if v != 0.0 {
                row_idx.push(i);
                val.push(v);
            }
        }
        col_ptr.push(row_idx.len());
    }
    let symbolic = SymbolicSparseColMat::new_checked(m, n, col_ptr, None, row_idx);
    SparseColMat::new(symbolic, val)
}

fn sparse_to_dense(a: SparseColMatRef<'_, usize, f64>, path: &Path) -> Result<Mat<f64>> {
    let (m, n) = (a.nrows(), a.ncols());
    // Probe the allocation first: the dimensions come from the file.
    if !dense_fits(m, n) {
        return Err(Error::parse(
            path,
            0,
            format!("the {m}x{n} sparse matrix is too large to convert to a dense matrix"),
        ));
    }
    let mut out = Mat::<f64>::zeros(m, n);
    for j in 0..n {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            out[(i, j)] += v;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference for [`leading_digits`]: one digit at a time.
    #[test]
    fn parallel_and_sequential_parses_agree() {
        // A file with duplicates, unsorted order and both index widths' paths.
        let mut text = String::from("%%MatrixMarket matrix coordinate real symmetric\n");
        let n = 200_000usize;
        text.push_str(&format!("1000 1000 {n}\n"));
        let mut x = 12345u64;
        for _ in 0..n {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let (i, j) = ((x % 1000) as usize + 1, ((x >> 20) % 1000) as usize + 1);
            let (i, j) = if i >= j { (i, j) } else { (j, i) };
            text.push_str(&format!("{i} {j} {}\n", (x >> 11) as f64 / 1e10));
        }
        let path = Path::new("mem.mtx");
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let four = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let a = one.install(|| parse_bytes(text.as_bytes(), path)).unwrap();
        let b = four.install(|| parse_bytes(text.as_bytes(), path)).unwrap();
        let (MtxData::Sparse(a), MtxData::Sparse(b)) = (a.data, b.data) else {
            panic!("sparse expected")
        };
        assert_eq!(a.symbolic().col_ptr(), b.symbolic().col_ptr());
        assert_eq!(a.symbolic().row_idx(), b.symbolic().row_idx());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(a.val()), bits(b.val()));
        // The usize entry path gives the same matrix as the u32 one.
        let h = parse_header(text.as_bytes(), path).unwrap();
        let body = &text.as_bytes()[h.body_start..];
        let wide = build_csc(
            &h,
            parse_coordinate_body::<usize>(body, &h, path).unwrap(),
            path,
        )
        .unwrap();
        assert_eq!(wide.symbolic().row_idx(), a.symbolic().row_idx());
        assert_eq!(bits(wide.val()), bits(a.val()));
    }

    #[test]
    fn huge_declared_sizes_error_instead_of_panicking() {
        let p = Path::new("huge.mtx");
        let cases: &[&[u8]] = &[
            b"%%MatrixMarket matrix coordinate real general\n1 1000000000000000000 0\n",
            b"%%MatrixMarket matrix coordinate real general\n1 1 18446744073709551615\n1 1 1\n",
            b"%%MatrixMarket matrix array real general\n0 1000000000000000000\n",
            b"%%MatrixMarket matrix array real general\n1000000000000000000 1000000000000000000\n1\n",
            b"%%MatrixMarket matrix array real symmetric\n10000000000 10000000000\n1\n",
        ];
        for &c in cases {
            assert!(parse_bytes(c, p).is_err(), "{}", String::from_utf8_lossy(c));
        }
        // A tall coordinate matrix whose dense form cannot exist.
        let text =
            b"%%MatrixMarket matrix coordinate real general\n1000000000000000000 2 1\n1 1 1\n";
        let m = parse_bytes(text, p).unwrap();
        let MtxData::Sparse(a) = m.data else {
            panic!("sparse expected")
        };
        assert!(sparse_to_dense(a.as_ref(), p).is_err());
    }
}
