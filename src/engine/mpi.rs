//! The [`Cluster`] of an MPI job (cargo feature `mpi`): rsmpi over the system's MPI library
//! (docs/design.md §9; running it: docs/mpi.md).
//!
//! MPI is initialized with `MPI_THREAD_SERIALIZED` and every call goes through one mutex, so
//! the communicator may be shared by the threads of a rank (only the thread that runs the
//! library call communicates). Messages longer than 1 GiB are sent in pieces (MPI counts are
//! 32-bit).

use super::cluster::Cluster;
use crate::{Error, Result};
use mpi::environment::Universe;
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::*;
use std::sync::Mutex;

/// Bytes per MPI message.
const PIECE: usize = 1 << 30;

/// The world of an MPI job; finalizes MPI when dropped.
pub struct Mpi {
    inner: Mutex<Inner>,
    rank: usize,
    size: usize,
    node_size: usize,
}

struct Inner {
    world: SimpleCommunicator,
    // dropped last: finalizes MPI
    _universe: Universe,
}

// SAFETY: MPI runs at MPI_THREAD_SERIALIZED (checked in `Mpi::init`) and every use of the
// communicator is serialized by the mutex.
unsafe impl Send for Inner {}

impl std::fmt::Debug for Mpi {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Mpi {{ rank: {}, size: {} }}", self.rank, self.size)
    }
}

impl Mpi {
    /// Initializes MPI (once per process).
    ///
    /// # Errors
    /// [`Error::Distributed`] when MPI was initialized before or does not provide
    /// `MPI_THREAD_SERIALIZED`.
    pub fn init() -> Result<Mpi> {
        let (universe, level) = mpi::initialize_with_threading(mpi::Threading::Serialized)
            .ok_or_else(|| Error::Distributed("MPI was already initialized".into()))?;
        if level < mpi::Threading::Serialized {
            return Err(Error::Distributed(format!(
                "the MPI library provides thread level {level:?}; sparsemor needs Serialized"
            )));
        }
        let world = universe.world();
        let node_size = world.split_shared(0).size() as usize;
        Ok(Mpi {
            rank: world.rank() as usize,
            size: world.size() as usize,
            node_size,
            inner: Mutex::new(Inner {
                world,
                _universe: universe,
            }),
        })
    }

    fn with<T>(&self, f: impl FnOnce(&SimpleCommunicator) -> T) -> T {
        let inner = self.inner.lock().unwrap_or_else(|p| p.into_inner());
        f(&inner.world)
    }
}

/// Ends every rank of the job at once (`MPI_Abort`): for a failure the ranks cannot report to
/// each other, such as a panic. Call only between [`Mpi::init`] and the drop of its [`Mpi`].
pub fn abort(code: i32) -> ! {
    // no lock: the thread that panicked may hold it
    // SAFETY: MPI_COMM_WORLD is valid between init and finalize; MPI_Abort does not return.
    unsafe {
        mpi::ffi::MPI_Abort(mpi::ffi::RSMPI_COMM_WORLD, code);
    }
    std::process::abort()
}

impl Cluster for Mpi {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn node_size(&self) -> usize {
        self.node_size
    }

    fn broadcast(&self, bytes: Vec<u8>) -> Vec<u8> {
        self.with(|w| {
            let root = w.process_at_rank(0);
            let mut len = bytes.len() as u64;
            root.broadcast_into(&mut len);
            let mut buf = if self.rank == 0 {
                bytes
            } else {
                vec![0u8; len as usize]
            };
            for piece in buf.chunks_mut(PIECE) {
                root.broadcast_into(piece);
            }
            buf
        })
    }

    fn send(&self, to: usize, bytes: Vec<u8>) {
        self.with(|w| {
            let p = w.process_at_rank(to as i32);
            p.send(&(bytes.len() as u64));
            for piece in bytes.chunks(PIECE) {
                p.send(piece);
            }
        })
    }

    fn receive(&self, from: usize) -> Vec<u8> {
        self.with(|w| {
            let p = w.process_at_rank(from as i32);
            let (len, _) = p.receive::<u64>();
            let mut buf = Vec::with_capacity(len as usize);
            while buf.len() < len as usize {
                let (piece, _) = p.receive_vec::<u8>();
                buf.extend_from_slice(&piece);
            }
            buf
        })
    }
}
