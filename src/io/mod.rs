//! File formats (DESIGN.md §4): Matrix Market, the model directory, the ROM directory, and the
//! importers of FE codes' files ([`import`]: ANSYS, Abaqus).

pub mod abaqus;
pub mod ansys;
pub mod import;
pub mod matrix_market;
pub mod model_dir;
pub mod rom_dir;
