//! C ABI of [sparsemor](../sparsemor/index.html): model order reduction (line-fitting, SEREP)
//! of large sparse second-order FE models, for C, C++ and Python (the package in python/, over cffi).
//!
//! The header `ffi/include/sparsemor.h` is generated from this crate by cbindgen and checked
//! in; `tests/header.rs` fails when it is stale (regenerate with
//! `SPARSEMOR_FFI_REGENERATE=1 cargo test -p sparsemor-ffi --test it header`).
//!
//! Conventions (docs/design.md §6):
//! - every function that can fail returns a [`SparsemorStatus`]; on failure
//!   `sparsemor_last_error_message` (thread-local) says what went wrong and how to fix it;
//! - every exported body runs under `catch_unwind`: no panic crosses the boundary, a caught
//!   panic is [`SparsemorStatus::Panic`];
//! - objects are opaque handles with `_new`/`_free` (model, options, ROM); `_free(NULL)` is a
//!   no-op; the library never keeps a pointer into caller memory after a call returns (it
//!   copies what it needs);
//! - outputs go to caller-owned buffers with explicit lengths; a short buffer is
//!   [`SparsemorStatus::BufferTooSmall`] with the required length reported;
//! - input arrays are checked (NULL, alignment, lengths, CSC structure, finiteness) before any
//!   matrix is built;
//! - integers that select behaviour are plain `uint32_t` constants, never Rust enums, so a
//!   bad value from C is an error, not undefined behaviour.
//!
//! Entry points, in the order of use: `sparsemor_version`, `sparsemor_model_new`,
//! `sparsemor_model_set_scene` (DoFs) or `sparsemor_model_add_remote_point` and
//! `sparsemor_model_set_scene_general` (remote points, a sparse B and C),
//! `sparsemor_model_set_structural_damping` and `sparsemor_model_damping_info` (§3.12),
//! `sparsemor_options_new` and `sparsemor_options_set_*`,
//! `sparsemor_reduce_linefit` / `sparsemor_reduce_serep`, `sparsemor_rom_*` queries,
//! `sparsemor_rom_transfer_error`, `sparsemor_*_free`.
#![warn(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > 0.0)` rejects NaN as well; deliberate (as in the core crate).
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// CSC validation walks the arrays by index.
#![allow(clippy::needless_range_loop)]

mod damping;
mod error;
mod model;
mod options;
mod pool;
mod rom;
mod scene;
mod util;

pub use damping::*;
pub use error::{sparsemor_last_error_length, sparsemor_last_error_message, SparsemorStatus};
pub use model::*;
pub use options::*;
pub use rom::*;
pub use scene::*;

/// Version of the C ABI. Bumped on every incompatible change of a signature, struct layout,
/// status code or constant in this header; a client compiled against one ABI version must
/// check `sparsemor_version(...)` reports the same one at run time. This is the one constant
/// the ABI's version is derived from.
pub const SPARSEMOR_ABI_VERSION: u32 = 1;
/// Library version, major part (equals the `sparsemor-ffi` crate version; checked by a test).
pub const SPARSEMOR_VERSION_MAJOR: u32 = 0;
/// Library version, minor part.
pub const SPARSEMOR_VERSION_MINOR: u32 = 1;
/// Library version, patch part.
pub const SPARSEMOR_VERSION_PATCH: u32 = 0;

/// The library's version and ABI version, written to the non-NULL pointers among `major`,
/// `minor`, `patch`, `abi`. Compare `*abi` with the header's `SPARSEMOR_ABI_VERSION` to detect
/// a header/library mismatch.
///
/// # Safety
/// Each pointer NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_version(
    major: *mut u32,
    minor: *mut u32,
    patch: *mut u32,
    abi: *mut u32,
) -> SparsemorStatus {
    error::ffi_body!({
        use util::write_opt;
        unsafe {
            write_opt(major, SPARSEMOR_VERSION_MAJOR, "major")?;
            write_opt(minor, SPARSEMOR_VERSION_MINOR, "minor")?;
            write_opt(patch, SPARSEMOR_VERSION_PATCH, "patch")?;
            write_opt(abi, SPARSEMOR_ABI_VERSION, "abi")
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn version_constants_match_the_crate_version() {
        let v = |s: &str| s.parse::<u32>().unwrap();
        assert_eq!(SPARSEMOR_VERSION_MAJOR, v(env!("CARGO_PKG_VERSION_MAJOR")));
        assert_eq!(SPARSEMOR_VERSION_MINOR, v(env!("CARGO_PKG_VERSION_MINOR")));
        assert_eq!(SPARSEMOR_VERSION_PATCH, v(env!("CARGO_PKG_VERSION_PATCH")));
    }
}
