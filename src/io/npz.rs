//! NumPy `.npz` archives (docs/design.md §4): a zip file of `.npy` arrays, stored without
//! compression as `numpy.savez` writes them, so `numpy.load` reads every array back bit for
//! bit. The `.npy` encoding is `npyz`'s, the archive `zip`'s; [`write()`] goes through
//! [`atomic::write_file`], so a failed write leaves no half archive.
//!
//! Matrices are written in Fortran (column) order, faer's layout, so `numpy.load(...)["Mr"]`
//! has the matrix's shape and values with no transposition on either side.

use crate::io::atomic;
use crate::Result;
use faer::MatRef;
use npyz::WriterBuilder;
use std::io::{Seek, Write};
use std::path::Path;
use zip::write::SimpleFileOptions;

/// An `.npz` archive being written: one call per named array.
pub struct Npz<W: Write + Seek> {
    zip: zip::ZipWriter<W>,
}

fn zip_err(e: zip::result::ZipError) -> std::io::Error {
    std::io::Error::other(e)
}

impl<W: Write + Seek> Npz<W> {
    /// Starts the member `<name>.npy`, announcing zip64 when it may exceed 4 GiB.
    fn member(&mut self, name: &str, bytes: u64) -> std::io::Result<&mut zip::ZipWriter<W>> {
        let opts = SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored)
            .large_file(bytes >= u64::from(u32::MAX) - 4096);
        self.zip
            .start_file(format!("{name}.npy"), opts)
            .map_err(zip_err)?;
        Ok(&mut self.zip)
    }

    /// A float64 array of `shape` from `values` in `order`.
    fn f64_array(
        &mut self,
        name: &str,
        shape: &[u64],
        order: npyz::Order,
        values: impl Iterator<Item = f64>,
    ) -> std::io::Result<()> {
        let w = self.member(name, 8 * shape.iter().product::<u64>())?;
        let mut out = npyz::WriteOptions::<f64>::new()
            .default_dtype()
            .shape(shape)
            .order(order)
            .writer(w)
            .begin_nd()?;
        out.extend(values)?;
        out.finish()
    }

    /// A float64 matrix (rows × columns), written column by column in Fortran order.
    ///
    /// # Errors
    /// I/O errors of the underlying writer.
    pub fn matrix(&mut self, name: &str, m: MatRef<'_, f64>) -> std::io::Result<()> {
        let shape = [m.nrows() as u64, m.ncols() as u64];
        let values = (0..m.ncols()).flat_map(|j| m.col(j).iter().copied());
        self.f64_array(name, &shape, npyz::Order::Fortran, values)
    }

    /// A float64 matrix with `cols` columns from a row-major slice (e.g. node coordinates).
    ///
    /// # Errors
    /// I/O errors of the underlying writer.
    pub fn rows(&mut self, name: &str, data: &[f64], cols: usize) -> std::io::Result<()> {
        let shape = [
            data.len().checked_div(cols).unwrap_or(0) as u64,
            cols as u64,
        ];
        self.f64_array(name, &shape, npyz::Order::C, data.iter().copied())
    }

    /// A float64 vector.
    ///
    /// # Errors
    /// I/O errors of the underlying writer.
    pub fn vector(&mut self, name: &str, v: &[f64]) -> std::io::Result<()> {
        self.f64_array(name, &[v.len() as u64], npyz::Order::C, v.iter().copied())
    }

    /// An int64 vector (indices, 0-based).
    ///
    /// # Errors
    /// I/O errors of the underlying writer.
    pub fn indices(&mut self, name: &str, v: &[usize]) -> std::io::Result<()> {
        let w = self.member(name, 8 * v.len() as u64)?;
        let mut out = npyz::WriteOptions::<i64>::new()
            .default_dtype()
            .shape(&[v.len() as u64])
            .writer(w)
            .begin_nd()?;
        out.extend(v.iter().map(|&i| i as i64))?;
        out.finish()
    }

    /// A 0-d unicode string (`numpy.load(...)[name].item()` gives the `str`).
    ///
    /// # Errors
    /// I/O errors of the underlying writer.
    pub fn text(&mut self, name: &str, s: &str) -> std::io::Result<()> {
        let chars = s.chars().count().max(1);
        let w = self.member(name, 4 * chars as u64)?;
        let dtype = npyz::DType::Plain(
            format!("<U{chars}")
                .parse::<npyz::TypeStr>()
                .map_err(std::io::Error::other)?,
        );
        let mut out = npyz::WriteOptions::<str>::new()
            .dtype(dtype)
            .shape(&[])
            .writer(w)
            .begin_nd()?;
        out.push(s)?;
        out.finish()
    }
}

/// Writes `path` atomically: `fill` adds the arrays.
///
/// # Errors
/// [`crate::Error::Io`] naming the file.
pub fn write(
    path: &Path,
    fill: impl FnOnce(&mut Npz<&mut std::io::BufWriter<std::fs::File>>) -> std::io::Result<()>,
) -> Result<()> {
    atomic::write_file(path, |w| {
        let mut npz = Npz {
            zip: zip::ZipWriter::new(w),
        };
        fill(&mut npz)?;
        npz.zip.finish().map_err(zip_err)?;
        Ok(())
    })
}
