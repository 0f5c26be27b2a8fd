//! File formats (DESIGN.md §4): Matrix Market, the model directory, the ROM directory; and
//! the atomic writes all of them (and the CLI's outputs) go through.

pub mod atomic;
pub mod matrix_market;
pub mod model_dir;
pub mod rom_dir;
