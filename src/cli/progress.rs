//! The CLI's progress bar and Ctrl-C: [`with_progress`] shows an indicatif bar with ETA on
//! stderr (hidden when stderr is not a terminal, so scripts and logs get only the results)
//! driven by the library's progress callback while one long computation runs; Ctrl-C during
//! it makes the callback return `false`, the library stops after the frequencies in flight
//! ([`sparsemor::Error::Cancelled`]) and nothing is written (every output is atomic). Ctrl-C
//! outside such a computation ends the process at once, as usual.

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use sparsemor::eigen::EigenProgress;
use sparsemor::engine::Cluster;
use sparsemor::sweep::{Progress, ProgressFn};
use sparsemor::Result;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// Set by Ctrl-C while a computation with a progress callback runs.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// Computations with a progress callback running now.
static ACTIVE: AtomicUsize = AtomicUsize::new(0);

/// Installs the Ctrl-C handler (once per process; a second call is a no-op).
pub fn handle_interrupts() {
    let _ = ctrlc::set_handler(|| {
        if ACTIVE.load(Ordering::SeqCst) == 0 {
            std::process::exit(130);
        }
        INTERRUPTED.store(true, Ordering::SeqCst);
    });
}

/// Runs `work` with a progress callback that advances a bar of `total` steps labelled `msg`
/// by one per call (one finished frequency); the bar is cleared at the end. Returns
/// [`sparsemor::Error::Cancelled`] (from the library) after Ctrl-C.
pub fn with_progress<T>(
    total: usize,
    msg: &str,
    work: impl FnOnce(ProgressFn<'_>) -> Result<T>,
) -> Result<T> {
    let pb = bar(total, msg);
    ACTIVE.fetch_add(1, Ordering::SeqCst);
    let out = work(&|_: Progress| {
        pb.inc(1);
        !INTERRUPTED.load(Ordering::SeqCst)
    });
    ACTIVE.fetch_sub(1, Ordering::SeqCst);
    pb.finish_and_clear();
    out
}

/// The steps of rank 0's bar for `n` frequencies: its own share, ⌈n/ranks⌉, when they are
/// spread over the ranks of a cluster (the other ranks show no bar).
pub fn rank0_share(n: usize, cluster: Option<&Arc<dyn Cluster>>) -> usize {
    n.div_ceil(cluster.map_or(1, |c| c.size().max(1)))
}

/// A bar of `total` steps labelled `msg` on stderr (a counter without bar when `total` is 0:
/// not known in advance), hidden when stderr is not a terminal.
fn bar(total: usize, msg: &str) -> ProgressBar {
    let pb = if std::io::stderr().is_terminal() {
        ProgressBar::new(total as u64)
    } else {
        ProgressBar::hidden()
    };
    let template = if total == 0 {
        "{msg} {pos} {elapsed_precise}"
    } else {
        "{msg} [{bar:30}] {pos}/{len} {elapsed_precise} (eta {eta})"
    };
    pb.set_style(
        ProgressStyle::with_template(template)
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(msg.to_string());
    pb
}

/// Runs an eigensolve with one bar per spectrum slice (modes converged of the slice's inertia
/// count), created when the slice starts and cleared at the end; Ctrl-C cancels as in
/// [`with_progress`].
pub fn with_slice_progress<T>(
    work: impl FnOnce(&(dyn Fn(EigenProgress) -> bool + Sync)) -> Result<T>,
) -> Result<T> {
    let multi = MultiProgress::new();
    let bars: Mutex<Vec<Option<ProgressBar>>> = Mutex::new(Vec::new());
    ACTIVE.fetch_add(1, Ordering::SeqCst);
    let out = work(&|p: EigenProgress| {
        let mut bars = bars.lock().unwrap_or_else(|e| e.into_inner());
        if bars.len() < p.slices {
            bars.resize(p.slices, None);
        }
        let pb = bars[p.slice].get_or_insert_with(|| {
            multi.add(bar(
                p.wanted,
                &format!(
                    "slice {}/{} {:.0}-{:.0} Hz",
                    p.slice + 1,
                    p.slices,
                    p.lo_hz,
                    p.hi_hz
                ),
            ))
        });
        pb.set_position(p.found as u64);
        !INTERRUPTED.load(Ordering::SeqCst)
    });
    ACTIVE.fetch_sub(1, Ordering::SeqCst);
    for pb in bars
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .flatten()
    {
        pb.finish_and_clear();
    }
    out
}
