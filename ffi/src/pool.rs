//! The per-call rayon pool of the C ABI: library work runs in a pool that lives only for the
//! call, so a C caller's process never keeps rayon's global threads.

use crate::error::Failure;
use std::sync::Mutex;

/// Runs `f` inside a rayon pool of `threads` threads that lives only for this call: the
/// library's parallel code (and rayon's `current_num_threads`) then never starts rayon's
/// global pool, whose threads would outlive every call in the caller's process (and show as
/// "possibly lost" memory in a leak checker). The pool's threads are joined before
/// returning. A panic in `f` is resumed after the join (the export's guard catches it).
pub(crate) fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T, Failure> {
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
        .map_err(|e| Failure::arg(format!("cannot start {threads} threads: {e}")))?;
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
