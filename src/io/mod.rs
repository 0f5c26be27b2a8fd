//! File formats (docs/design.md §4): Matrix Market, the model directory, the ROM directory, the
//! importers of FE codes' files ([`import`]: ANSYS, Abaqus, Nastran OP4, Harwell–Boeing), the
//! Nastran OP4 matrix files ([`op4`]: the reader the import uses, the writer), the ROM exports
//! ([`exudyn`], [`op4::write_rom`], [`dmig`], [`mbdyn`], [`sid`]); the
//! text toolkit their text readers share (`text`: lines, tokens, numbers, parallel line
//! parsing); the safe reading of the files a user names (`file`: regular files only); and the
//! atomic writes all writers (and the CLI's outputs) go through.

pub mod atomic;
mod binary;
pub mod dmig;
pub mod exudyn;
mod file;
pub mod import;
pub mod joints;
pub mod matrix_market;
pub mod mbdyn;
pub mod model_dir;
pub mod npz;
pub mod op4;
pub mod rom_dir;
pub mod sid;
mod text;
