//! sparsemor: model order reduction of large sparse structural FE models.
//!
//! The full model M q'' + D q' + K q = B u, y = C q (DESIGN.md §1) is loaded or generated
//! ([`model::Model`], [`io`], [`fe`]); its transfer function H(iω) = C (K − ω²M + iωD)⁻¹ B is
//! computed sparsely and in parallel over frequencies ([`sweep`]) on a pencil with one
//! symbolic analysis ([`pencil`], [`factor`]), with the rigid-body part of a free body
//! separated without cancellation ([`rigid`]).
#![warn(missing_docs)]
// `!(x > 0.0)` and friends are deliberate: unlike `x <= 0.0` they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Sparse kernels walk CSC arrays by index; iterator rewrites hide the structure.
#![allow(clippy::needless_range_loop)]

pub mod body;
pub mod eigen;
pub mod error;
pub mod factor;
pub mod fe;
pub mod io;
pub mod lsq;
pub mod memory;
pub mod metrics;
pub mod model;
pub mod pencil;
pub mod reduce;
pub mod report;
pub mod rigid;
pub mod scene;
pub mod sparse;
pub mod sweep;
pub mod units;

pub use error::{Error, Result};
