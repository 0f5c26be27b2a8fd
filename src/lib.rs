//! sparsemor: model order reduction of large sparse structural FE models.
#![warn(missing_docs)]

pub mod error;
pub mod factor;

pub use error::{Error, Result};
