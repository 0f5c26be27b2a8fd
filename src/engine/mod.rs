//! Where the frequencies are solved: in this process, or over the ranks of an MPI job
//! (docs/design.md §9).
//!
//! Frequencies are independent and streamed-QR states merge as a TSQR tree (§3.3), so a run
//! spreads its frequencies over the ranks. Rank 0 runs the library call (line-fitting's fit,
//! its sampling loop's decisions, the projection, the output); the other ranks
//! [`serve`]: each frequency call of rank 0's engine (`Engine`) is one command (`protocol.rs`)
//! that every rank carries out on its share — rank r takes the frequencies k ≡ r (mod ranks) —
//! and the answers combine up a binary tree to rank 0 (`gather`):
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
mod engine;
#[cfg(feature = "mpi")]
pub mod mpi;
pub(crate) mod protocol;
mod wire;

pub use cluster::Cluster;
pub(crate) use engine::Engine;
pub(crate) use protocol::Keep;

use crate::body::Body;
use crate::sweep::SweepOptions;
use crate::{Error, Result};
use protocol::Command;

/// The other ranks' side of a run (rank ≥ 1): carries out rank 0's commands on this rank's
/// share of the frequencies until rank 0 stops the run, and returns the exit code rank 0 gave.
/// Errors of a command go to rank 0, not out of here.
///
/// `body` is this rank's model, or the error (as text) that kept it from reading or preparing it: every
/// command is then answered with that error, so rank 0 reports it (naming this rank) and stops
/// the run. `opts` are the sweep options of the run (threads, backend, memory, probe
/// tolerance), the same on every rank.
///
/// # Errors
/// [`Error::Distributed`] when a command does not decode; the run cannot go on then.
pub fn serve(
    cluster: &dyn Cluster,
    body: std::result::Result<&Body, &str>,
    opts: &SweepOptions,
) -> Result<i32> {
    let (rank, size) = (cluster.rank(), cluster.size());
    let mut engine = body.map(|b| Engine::new(b, opts));
    loop {
        let cmd = Command::decode(&cluster.broadcast(Vec::new()))?;
        if let Command::Stop { code } = cmd {
            return Ok(code);
        }
        let mine = match &mut engine {
            Ok(engine) => engine.run_share(&cmd, rank, size, &crate::sweep::no_progress),
            Err(message) => Err(Error::Remote {
                rank,
                message: message.to_string(),
            }),
        };
        protocol::gather(cluster, mine)?;
    }
}

/// Rank 0's end of a run: tells the serving ranks to exit with `code` (collective with their
/// [`serve`]). Call exactly once, after the last library call, also when it failed.
pub fn stop(cluster: &dyn Cluster, code: i32) {
    cluster.broadcast(Command::Stop { code }.encode());
}
