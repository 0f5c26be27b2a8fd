//! The CLI's progress bar: [`with_progress`] shows an indicatif bar on stderr driven by the
//! library's progress callback while one long computation runs.

use indicatif::{ProgressBar, ProgressStyle};
use sparsemor::sweep::{Progress, ProgressFn};
use sparsemor::Result;

/// Runs `work` with a progress callback that moves a bar of `total` steps labelled `msg`; the
/// bar is cleared when `work` succeeds.
pub fn with_progress<T>(
    total: usize,
    msg: &str,
    work: impl FnOnce(ProgressFn<'_>) -> Result<T>,
) -> Result<T> {
    let pb = ProgressBar::new(total as u64);
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed_precise} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(msg.to_string());
    let out = work(&|p: Progress| {
        pb.set_position(p.done as u64);
        true
    })?;
    pb.finish_and_clear();
    Ok(out)
}
