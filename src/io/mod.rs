//! File formats (docs/design.md §4): Matrix Market, the model directory, the ROM directory, the
//! importers of FE codes' files ([`import`]: ANSYS, Abaqus); and the atomic writes all
//! writers (and the CLI's outputs) go through.

pub mod abaqus;
pub mod ansys;
pub mod atomic;
pub mod exudyn;
pub mod import;
pub mod matrix_market;
pub mod model_dir;
pub mod npz;
pub mod rom_dir;
