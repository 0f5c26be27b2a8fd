//! File formats (DESIGN.md §4): Matrix Market, the model directory, the ROM directory.

pub mod matrix_market;
