//! The ranks' side of a distributed run (docs/design.md §9): rank ≥ 1 carries out rank 0's
//! commands until rank 0 stops the run.

use super::cluster::Cluster;
use super::frequencies::Engine;
use super::protocol::{self, Command};
use crate::body::Body;
use crate::sweep::SweepOptions;
use crate::{Error, Result};

/// The other ranks' side of a run (rank ≥ 1): carries out rank 0's commands on this rank's
/// share of the frequencies until rank 0 stops the run, and returns the exit code rank 0 gave.
/// Errors of a command go to rank 0, not out of here.
///
/// `body` is this rank's model, or the error (as text) that kept it from reading or preparing
/// it: every command is then answered with that error, so rank 0 reports it (naming this
/// rank) and stops the run. `opts` are the sweep options of the run (threads, backend, memory, probe
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
    let mut engine = body.map(|b| Engine::new(b, opts, None));
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
