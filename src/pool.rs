//! Worker pools that live for one call (docs/design.md §5).
//!
//! Library work that wants `threads` workers runs in the caller's rayon pool when that pool has
//! exactly this size, else in a pool built for the call whose threads are joined before the
//! call returns. Nothing outlives the call: no idle thread in a C caller's process, and no
//! thread-local buffer either — faer's dense kernels reserve a page pool of twice the L3 cache
//! per thread (960 MiB of address space with a 480 MiB L3), which a pool dropped without a
//! join leaves alive until its threads happen to exit.

use crate::{Error, Result};
use std::sync::Mutex;

/// The one thread-count policy: `requested` when > 0; for 0, the size of the rayon pool the
/// caller runs in, or — outside any pool — what rayon's global pool would use
/// (`RAYON_NUM_THREADS` when set to a positive number, else the available cores), found
/// without starting that pool (a C caller's process must not keep its threads).
pub fn resolve_threads(requested: usize) -> usize {
    if requested > 0 {
        return requested;
    }
    if rayon::current_thread_index().is_some() {
        return rayon::current_num_threads().max(1);
    }
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&t| t > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Runs `f` with `threads` rayon workers (see the module doc): in the caller's pool when it
/// has that size, else in a pool of `threads` threads built for this call and joined before
/// returning. A panic in `f` is resumed after the join.
///
/// # Errors
/// [`Error::InvalidSetting`] when the threads cannot be started.
pub fn with_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T> {
    let threads = threads.max(1);
    if rayon::current_thread_index().is_some() && rayon::current_num_threads() == threads {
        return Ok(f());
    }
    let handles = Mutex::new(Vec::new());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .spawn_handler(|t| {
            let h = std::thread::Builder::new()
                .name("sparsemor".into())
                .spawn(move || t.run())?;
            handles.lock().unwrap_or_else(|p| p.into_inner()).push(h);
            Ok(())
        })
        .build()
        .map_err(|e| Error::InvalidSetting(format!("cannot start {threads} threads: {e}")))?;
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| pool.install(f)));
    drop(pool);
    for h in handles.into_inner().unwrap_or_else(|p| p.into_inner()) {
        let _ = h.join();
    }
    match r {
        Ok(v) => Ok(v),
        Err(p) => std::panic::resume_unwind(p),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pool has the size asked for, its threads are gone when the call returns, and a call
    /// from inside a pool of that size runs there.
    #[test]
    fn a_call_pool_has_its_size_and_leaves_no_thread() {
        let id = |_: ()| std::thread::current().id();
        let (size, inner, thread) = with_pool(3, || {
            let inner = with_pool(3, rayon::current_thread_index).unwrap();
            (rayon::current_num_threads(), inner, id(()))
        })
        .unwrap();
        assert_eq!(size, 3);
        assert!(inner.is_some());
        assert_ne!(thread, std::thread::current().id());
        // a panic inside comes back out after the join
        let p = std::panic::catch_unwind(|| with_pool(2, || panic!("inside")));
        assert!(p.is_err());
    }
}
