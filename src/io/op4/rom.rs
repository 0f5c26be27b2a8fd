//! The ROM as an OP4 file, [`write_rom`]: `rom.op4` holding Mr, Dr, Kr, K₄r (form 6, symmetric,
//! both triangles as NASTRAN stores them) and Br, Cr (form 2, rectangular), ASCII, real double
//! precision (type 2), dense column records, `1P,3E23.16` — the layout NASTRAN's `OUTPUT4`
//! writes by default, read back bit for bit (the writer: [`super::writer`]).

use super::format::Encoding;
use super::writer::{columns_of_dense, write, Layout, Matrix};
use crate::io::atomic;
use crate::reduce::Rom;
use crate::Result;
use std::path::Path;

/// The file [`write_rom`] writes.
pub const ROM_FILE: &str = "rom.op4";

/// The OP4 names of the ROM's matrices, in the order they are written, with their forms
/// (K4R, the structural damping, only when the ROM has it).
pub const ROM_MATRICES: [(&str, i32); 6] = [
    ("MR", 6),
    ("DR", 6),
    ("KR", 6),
    ("BR", 2),
    ("CR", 2),
    ("K4R", 6),
];

/// Writes the ROM's Mr, Dr, Kr, Br, Cr (and K₄r) as `MR DR KR BR CR (K4R)` into `dir/rom.op4` (see the
/// module doc; a zero matrix is a header and the end record). `dir` is created atomically.
///
/// # Errors
/// [`Error::InvalidSetting`](crate::Error::InvalidSetting) if `dir` exists and is not empty (naming it), or a matrix holds
/// a value that is not finite; I/O errors.
pub fn write_rom(dir: &Path, rom: &Rom) -> Result<()> {
    let mats: Vec<Matrix> = rom
        .matrices()
        .iter()
        .zip(ROM_MATRICES)
        .map(|((_, a), (name, form))| Matrix {
            name,
            rows: a.nrows(),
            cols: columns_of_dense(a.as_ref()),
            form,
            precision: 2,
        })
        .collect();
    atomic::write_dir(dir, |tmp| {
        write(&tmp.join(ROM_FILE), &mats, Encoding::Ascii, Layout::Dense)
    })
}
