//! The integration tests of the C ABI, one module per concern, in one test binary.

mod bad_input;
mod c_client;
mod common;
mod craig_bampton;
mod discipline;
mod general_scene;
mod header;
mod import;
mod readme;
mod structural;
