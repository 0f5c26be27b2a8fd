//! The frequency engine: where the frequencies are solved — in this process, or over the
//! ranks of an MPI job (docs/design.md §9) — and what is done with each block.
//!
//! Frequencies are independent and streamed-QR states merge as a TSQR tree (§3.3), so a run
//! spreads its frequencies over the ranks. Rank 0 runs the library call (line-fitting's fit,
//! its sampling loop's decisions, the projection, the output); the other ranks
//! [`serve`]: each frequency call of rank 0's engine (`Engine`, `frequencies.rs`) is one
//! command (`protocol.rs`) that every rank carries out on its share — rank r takes the
//! frequencies k ≡ r (mod ranks) — and the answers combine up a binary tree to rank 0
//! (`gather`):
//!
//! ```text
//! line-fitting   each rank: its frequencies → its streamed QR (R n×n, Y n×(N−n), e N−n)
//!                tree:      [R1; R2] → R, [Y1; Y2] → Y  (one merge per stage, ⌈log₂ ranks⌉ stages)
//! sweep/evaluate each rank: H at its frequencies (outputs × inputs each) → rank 0
//! ```
//!
//! Communication per merge: the R triangle, n(n+1)/2 values, is independent of N; Y and e,
//! (n+1)(N−n) values, are the fit's right-hand side and scale with N like the result V itself
//! (N × n). Snapshots kept for interface growth stay on the rank that solved them.
//!
//! Errors: a rank whose work fails sends its error instead of an answer (a rank that could not
//! read the model answers every command so); rank 0 returns the error of the lowest failing
//! rank ([`Error::Remote`]) and tells every rank to stop with the same exit code ([`stop`]). No
//! rank waits for an answer that will not come. A rank that dies (killed, out of memory) ends
//! the job through the MPI launcher, which stops every rank of a job when one exits without
//! finalizing MPI; a panic calls `MPI_Abort` (`mpi::abort`, feature `mpi`).
//!
//! The transport is the small [`Cluster`] trait: MPI with cargo feature `mpi` (`mpi.rs`), or
//! anything else that can broadcast and send bytes (the tests use threads).

mod cluster;
mod frequencies;
#[cfg(feature = "mpi")]
pub mod mpi;
pub(crate) mod protocol;
mod serve;
mod wire;

pub use cluster::Cluster;
pub(crate) use frequencies::Engine;
pub(crate) use protocol::Keep;
pub use serve::{serve, stop};
