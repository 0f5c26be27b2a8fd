//! The per-call rayon pool of the C ABI: library work runs in a pool that lives only for the
//! call (`sparsemor::pool`), so a C caller's process never keeps rayon's global threads.

use crate::error::Failure;

/// Runs `f` inside a rayon pool of `threads` threads that lives only for this call
/// ([`sparsemor::pool::with_pool`]): the library's parallel code (and rayon's
/// `current_num_threads`) then never starts rayon's global pool, whose threads would outlive
/// every call in the caller's process (and show as "possibly lost" memory in a leak checker).
/// The pool's threads are joined before returning. A panic in `f` is resumed after the join
/// (the export's guard catches it).
pub(crate) fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T, Failure> {
    sparsemor::pool::with_pool(threads, f).map_err(|e| Failure::arg(e.to_string()))
}
