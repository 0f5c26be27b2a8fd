//! The integration tests of the library and the `sparsemor` command, one module per
//! capability, in one test binary (one link instead of one per file).

mod cli;
mod common;
mod craig_bampton;
mod damping;
mod dense;
mod distributed;
mod eigen;
mod export;
mod export_nastran;
mod export_points;
mod export_sid;
mod extremes;
mod factor_ldlt;
mod fe_bar;
mod fuzz_regressions;
mod harwell_boeing;
mod import;
mod linefit;
mod lsq;
mod matrix_market;
mod model_dir;
#[cfg(feature = "mpi")]
mod mpi;
mod remote_points;
mod report;
mod rigid_elastic;
mod sampling;
mod serep;
mod sweep_dense;
