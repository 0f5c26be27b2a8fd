//! The CLI's progress bar and Ctrl-C: [`with_progress`] shows an indicatif bar with ETA on
//! stderr (hidden when stderr is not a terminal, so scripts and logs get only the results)
//! driven by the library's progress callback while one long computation runs; Ctrl-C during
//! it makes the callback return `false`, the library stops after the frequencies in flight
//! ([`sparsemor::Error::Cancelled`]) and nothing is written (every output is atomic). Ctrl-C
//! outside such a computation ends the process at once, as usual.

use indicatif::{ProgressBar, ProgressStyle};
use sparsemor::sweep::{Progress, ProgressFn};
use sparsemor::Result;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

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
    let pb = if std::io::stderr().is_terminal() {
        ProgressBar::new(total as u64)
    } else {
        ProgressBar::hidden()
    };
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed_precise} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(msg.to_string());
    ACTIVE.fetch_add(1, Ordering::SeqCst);
    let out = work(&|_: Progress| {
        pb.inc(1);
        !INTERRUPTED.load(Ordering::SeqCst)
    });
    ACTIVE.fetch_sub(1, Ordering::SeqCst);
    pb.finish_and_clear();
    out
}
