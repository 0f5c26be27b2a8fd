//! The MPI side of the MUMPS backend (docs/design.md §3.1, §9): which processes take part in a
//! MUMPS instance, and the jobs rank 0 announces to the others when they share it.
//!
//! MUMPS runs on an MPI communicator. A process of its own (no `mpirun`, or a rank that solves
//! its own frequencies) gives every instance `MPI_COMM_SELF`; MPI is initialized for it on
//! first use when the program has not done so ([`communicator`]). Under `mpirun` the ranks
//! may instead **share every factorization** ([`share`]): each instance then lives on a
//! duplicate of `MPI_COMM_WORLD`, rank 0 (MUMPS's host, PAR = 1: it works as well) holds the
//! matrix and the right-hand sides, and MUMPS spreads the fronts, the factors and the work
//! over all ranks. MUMPS's calls are collective, so before each call rank 0 broadcasts the
//! job ([`announce`]) and the other ranks, in the backend's `serve` loop, make the same call
//! on their part of the same instance ([`Job`]).
//!
//! Every MUMPS call holds one lock ([`lock`]); the announcement is made under it,
//! so the jobs of concurrent sweep workers reach the other ranks in the order rank 0 runs
//! them. MPI is used at `MPI_THREAD_SERIALIZED` (the `mpi` feature's initialization, or the
//! one made here).

use crate::{Error, Result};
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::{AsRaw, Root};
use std::sync::{Mutex, MutexGuard, OnceLock};

/// Every call into MUMPS holds this lock (the backend's module doc says why), and so does
/// every announcement.
static MUMPS: Mutex<()> = Mutex::new(());

/// Takes the lock of MUMPS's calls.
pub(super) fn lock() -> MutexGuard<'static, ()> {
    MUMPS.lock().unwrap_or_else(|p| p.into_inner())
}

/// The communicator of the shared factorizations, when [`share`] was called.
static SHARED: OnceLock<Shared> = OnceLock::new();

/// A duplicate of `MPI_COMM_WORLD` (MUMPS's messages do not meet the run's own) and its
/// Fortran handle, which MUMPS takes.
struct Shared {
    comm: SimpleCommunicator,
    fortran: i32,
}

// SAFETY: the communicator is used for MUMPS calls and their announcements only, all under
// the backend's lock (module doc), and MPI runs at MPI_THREAD_SERIALIZED.
unsafe impl Send for Shared {}
unsafe impl Sync for Shared {}

/// One job of a shared instance, as rank 0 announces it: the instance (numbered by rank 0),
/// MUMPS's JOB, and for JOB = −1 (a new instance) its out-of-core directory, empty for in core.
pub(super) struct Job {
    pub(super) instance: u64,
    pub(super) job: i32,
    pub(super) dir: Vec<u8>,
}

/// JOB of the announcement that ends `serve`; its instance field carries the
/// exit code.
const STOP: i32 = i32::MIN;

/// Makes every later MUMPS instance of this process span all ranks of `MPI_COMM_WORLD`
/// (module doc). Collective: every rank calls it once, after MPI is initialized, before any
/// MUMPS call; rank 0 then runs the library, the others `serve`.
///
/// # Errors
/// [`Error::Distributed`] when MPI is not initialized or this was called before.
pub fn share() -> Result<()> {
    if !mpi::is_initialized() {
        return Err(Error::Distributed(
            "MUMPS over ranks: MPI is not initialized (run under mpirun with the mpi feature)"
                .into(),
        ));
    }
    let comm = SimpleCommunicator::world().duplicate();
    // SAFETY: a valid communicator; MPI_Comm_c2f only converts its handle.
    let fortran = unsafe { mpi::ffi::RSMPI_Comm_c2f(comm.as_raw()) };
    SHARED
        .set(Shared { comm, fortran })
        .map_err(|_| Error::Distributed("MUMPS over ranks: shared twice".into()))
}

/// The number of ranks that share each MUMPS factorization of this process (1 unless
/// [`share`] was called under `mpirun -np R`, then R).
pub fn ranks() -> usize {
    SHARED.get().map_or(1, |s| s.comm.size() as usize)
}

/// Whether this process is rank 0 of the shared factorizations, or has them to itself.
pub(super) fn is_host() -> bool {
    SHARED.get().is_none_or(|s| s.comm.rank() == 0)
}

/// The Fortran handle of the communicator of a new instance: the shared one, or
/// `MPI_COMM_SELF` (MPI initialized first when the program has not: once, at
/// `MPI_THREAD_SERIALIZED`, and kept until the process ends, since MPI cannot be initialized
/// a second time).
///
/// # Errors
/// [`Error::Factor`] when MPI cannot be initialized at `MPI_THREAD_SERIALIZED`.
pub(super) fn communicator() -> Result<i32> {
    if let Some(s) = SHARED.get() {
        return Ok(s.fortran);
    }
    static SELF: OnceLock<std::result::Result<i32, String>> = OnceLock::new();
    SELF.get_or_init(|| {
        if !mpi::is_initialized() {
            let (universe, level) = mpi::initialize_with_threading(mpi::Threading::Serialized)
                .ok_or("MPI was initialized by another library")?;
            if level < mpi::Threading::Serialized {
                return Err(format!(
                    "the MPI library provides thread level {level:?}; MUMPS here needs Serialized"
                ));
            }
            // never finalized: the library cannot know its last MUMPS call
            std::mem::forget(universe);
        }
        // SAFETY: MPI is initialized; MPI_COMM_SELF is a valid communicator.
        Ok(unsafe { mpi::ffi::RSMPI_Comm_c2f(mpi::ffi::RSMPI_COMM_SELF) })
    })
    .clone()
    .map_err(|e| Error::Factor(format!("backend mumps: {e}")))
}

/// Rank 0: tells the other ranks to run `job` (call under the backend's lock, right before
/// MUMPS's own call). Nothing happens when the factorizations are not shared.
pub(super) fn announce(job: Job) {
    if let Some(s) = SHARED.get() {
        broadcast(&s.comm, job.instance, job.job, job.dir);
    }
}

/// Rank 0: ends the other ranks' `serve` with `code`, the run's exit code.
/// Nothing happens when the factorizations are not shared.
pub fn dismiss(code: i32) {
    if let Some(s) = SHARED.get() {
        let _one = lock();
        broadcast(&s.comm, code as u64, STOP, Vec::new());
    }
}

/// Ranks ≥ 1: the next job rank 0 announces, or `Err(code)` when rank 0 dismissed the ranks.
pub(super) fn next() -> std::result::Result<Job, i32> {
    let s = SHARED.get().expect("serve only after share");
    let (instance, job, dir) = broadcast(&s.comm, 0, 0, Vec::new());
    if job == STOP {
        return Err(instance as i32);
    }
    Ok(Job { instance, job, dir })
}

/// Broadcasts (instance, job, dir) from rank 0; every rank returns rank 0's values.
fn broadcast(
    comm: &SimpleCommunicator,
    instance: u64,
    job: i32,
    dir: Vec<u8>,
) -> (u64, i32, Vec<u8>) {
    let root = comm.process_at_rank(0);
    let mut head = [instance, job as u32 as u64, dir.len() as u64];
    root.broadcast_into(&mut head[..]);
    let mut dir = if comm.rank() == 0 {
        dir
    } else {
        vec![0u8; head[2] as usize]
    };
    if !dir.is_empty() {
        root.broadcast_into(&mut dir[..]);
    }
    (head[0], head[1] as u32 as i32, dir)
}
