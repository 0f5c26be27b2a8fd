//! Sparse LU factorization backends for the shifted pencils `A(s)`.
#[cfg(feature = "umfpack")]
pub mod umfpack;
