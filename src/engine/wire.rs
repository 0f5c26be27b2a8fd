//! The byte form of the messages between ranks: little-endian numbers, length-prefixed
//! lists. Both ends are this crate, built from the same source, so no versioning is needed;
//! a message that does not decode is reported, never trusted.

use crate::{Error, Result};
use faer::{c64, Mat};

/// Appends values to a message.
#[derive(Default)]
pub(super) struct Writer(pub Vec<u8>);

impl Writer {
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    pub fn usize(&mut self, v: usize) -> &mut Self {
        self.u64(v as u64)
    }

    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    pub fn usizes(&mut self, v: &[usize]) -> &mut Self {
        self.usize(v.len());
        v.iter().for_each(|&x| {
            self.usize(x);
        });
        self
    }

    pub fn f64s(&mut self, v: &[f64]) -> &mut Self {
        self.usize(v.len());
        self.0.reserve(8 * v.len());
        v.iter().for_each(|&x| {
            self.f64(x);
        });
        self
    }

    pub fn str(&mut self, s: &str) -> &mut Self {
        self.usize(s.len());
        self.0.extend_from_slice(s.as_bytes());
        self
    }

    /// A complex matrix: rows, columns, then column-major (re, im) pairs.
    pub fn c64_mat(&mut self, m: &Mat<c64>) -> &mut Self {
        self.usize(m.nrows()).usize(m.ncols());
        self.0.reserve(16 * m.nrows() * m.ncols());
        for j in 0..m.ncols() {
            for i in 0..m.nrows() {
                self.f64(m[(i, j)].re).f64(m[(i, j)].im);
            }
        }
        self
    }
}

/// Reads values back in the order they were written.
pub(super) struct Reader<'a> {
    bytes: &'a [u8],
}

fn malformed(what: &str) -> Error {
    Error::Distributed(format!(
        "a message between ranks is malformed ({what}): every rank must run the same sparsemor build"
    ))
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes }
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        if self.bytes.len() < n {
            return Err(malformed("truncated"));
        }
        let (head, tail) = self.bytes.split_at(n);
        self.bytes = tail;
        Ok(head)
    }

    pub fn u64(&mut self) -> Result<u64> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(
            b.try_into().map_err(|_| malformed("u64"))?,
        ))
    }

    pub fn usize(&mut self) -> Result<usize> {
        usize::try_from(self.u64()?).map_err(|_| malformed("length"))
    }

    pub fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_bits(self.u64()?))
    }

    /// A length that must fit in the rest of the message at `bytes_each` per item.
    fn len(&mut self, bytes_each: usize) -> Result<usize> {
        let n = self.usize()?;
        if n.saturating_mul(bytes_each) > self.bytes.len() {
            return Err(malformed("length beyond the message"));
        }
        Ok(n)
    }

    pub fn usizes(&mut self) -> Result<Vec<usize>> {
        let n = self.len(8)?;
        (0..n).map(|_| self.usize()).collect()
    }

    pub fn f64s(&mut self) -> Result<Vec<f64>> {
        let n = self.len(8)?;
        (0..n).map(|_| self.f64()).collect()
    }

    pub fn str(&mut self) -> Result<String> {
        let n = self.len(1)?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| malformed("text"))
    }

    pub fn c64_mat(&mut self) -> Result<Mat<c64>> {
        let (r, c) = (self.usize()?, self.usize()?);
        if r.saturating_mul(c).saturating_mul(16) > self.bytes.len() {
            return Err(malformed("matrix beyond the message"));
        }
        let mut m = Mat::<c64>::zeros(r, c);
        for j in 0..c {
            for i in 0..r {
                m[(i, j)] = c64::new(self.f64()?, self.f64()?);
            }
        }
        Ok(m)
    }
}
