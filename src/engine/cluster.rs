//! The transport between the ranks of a run (docs/design.md §9): MPI with cargo feature
//! `mpi`, or anything else that can broadcast and send bytes (the tests use threads). It
//! imports nothing of the crate: the sweep options carry a cluster, and every layer above
//! may name it.

/// The ranks of a distributed run: who this process is and how it talks to the others.
/// Every method is collective in the MPI sense where it says so: all ranks call it in the same
/// order.
pub trait Cluster: Send + Sync + std::fmt::Debug {
    /// This process's rank, 0..size.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Number of ranks on this rank's machine (they share its memory).
    fn node_size(&self) -> usize;
    /// Rank 0's `bytes`, on every rank (collective; the other ranks' `bytes` are ignored).
    fn broadcast(&self, bytes: Vec<u8>) -> Vec<u8>;
    /// Sends `bytes` to rank `to` (matched by a [`Cluster::receive`] there).
    fn send(&self, to: usize, bytes: Vec<u8>);
    /// The next message from rank `from`.
    fn receive(&self, from: usize) -> Vec<u8>;
}
