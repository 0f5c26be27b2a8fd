//! File formats (DESIGN.md §4): Matrix Market, the model directory, the ROM directory.

pub mod matrix_market;
pub mod model_dir;
pub mod rom_dir;
